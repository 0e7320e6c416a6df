# Type stubs of reefgen (docs/PYTHON.md); tests/python/test_module.py checks
# that they name every public function with the module's own parameters.
import os
from typing import Any, Dict, List, Optional, Tuple, Union

import numpy as np
import numpy.typing as npt

__version__: str
HEIGHT_RANGE_M: Tuple[float, float]

class Error(RuntimeError): ...
class ConfigError(ValueError): ...

Config = Union[None, Dict[str, Any], str, os.PathLike]
Heights = npt.NDArray[np.float32]
Labels = npt.NDArray[np.uint8]

def pair(config: Config = None, seed: int = 0, index: int = 0) -> Tuple[Heights, Labels]: ...
def pair_info(config: Config = None, seed: int = 0, index: int = 0) -> Dict[str, Any]: ...
def generate(spec: Union[str, Dict[str, Any], os.PathLike] = "young-volcano", size: int = 256,
             seed: Optional[int] = None, subsidence: Optional[float] = None, age_myr: Optional[float] = None,
             maturity: Optional[float] = None) -> Tuple[Heights, Labels]: ...
def default_model() -> Optional[str]: ...
def infer(sketch: npt.NDArray[Any], size: int = 0, model: Union[None, str, os.PathLike] = None, seed: int = 0,
          raw: bool = False, precision: str = "fp32", engine: str = "auto", stochastic: bool = False,
          threads: Optional[int] = None, world_size_m: Optional[float] = None, variation: float = 1.0,
          age_myr: Optional[float] = None, maturity: Optional[float] = None,
          variations: int = 1) -> Union[Heights, List[Heights]]: ...
# (regions uint8, subsidence float32) or, with ruggedness=True, also the style (uint8).
def decode_labels(image: npt.NDArray[Any], ruggedness: bool = False) -> Tuple[npt.NDArray[Any], ...]: ...
REGIONS: Tuple[str, str, str, str, str]
def realism(heights: npt.NDArray[np.float32], metres_per_px: float) -> Dict[str, Any]: ...
def presets() -> List[str]: ...
