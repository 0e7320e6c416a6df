# Type stubs of reefgen.torch (docs/PYTHON.md "PyTorch").
import os
from typing import Any, Dict, Iterator, Optional, Tuple, Union

import numpy.typing as npt
import torch
from torch.utils.data import Dataset, IterableDataset

Config = Union[None, Dict[str, Any], str, os.PathLike]

def to_tensors(heights: npt.NDArray[Any], labels: npt.NDArray[Any],
               height_range_m: Optional[Tuple[float, float]] = None) -> Tuple[torch.Tensor, torch.Tensor]: ...

class PairStream(IterableDataset):
    config: str
    seed: int
    count: Optional[int]
    start: int
    rank: int
    world_size: int
    split: Optional[str]
    shuffle: bool
    batch_size: int
    shuffle_window: int
    with_conditioning: bool
    @property
    def epoch(self) -> int: ...
    def __init__(self, config: Config = None, seed: int = 0, count: Optional[int] = None, start: int = 0,
                 rank: Optional[int] = None, world_size: Optional[int] = None,
                 height_range_m: Optional[Tuple[float, float]] = None, with_index: bool = False,
                 split: Optional[str] = None, shuffle: bool = False, batch_size: int = 1,
                 shuffle_window: int = 65536, with_conditioning: bool = False) -> None: ...
    def set_epoch(self, epoch: int) -> None: ...
    def order(self) -> Iterator[int]: ...
    def indices(self) -> Iterator[int]: ...
    def __iter__(self) -> Iterator[Any]: ...

class PairFolder(Dataset):
    def __init__(self, root: Union[str, os.PathLike], split: str = "train",
                 height_range_m: Optional[Tuple[float, float]] = None, verify: bool = True) -> None: ...
    def __len__(self) -> int: ...
    def __getitem__(self, k: int) -> Tuple[torch.Tensor, torch.Tensor]: ...
