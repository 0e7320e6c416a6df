"""PyTorch datasets over reefgen's pairs (docs/PYTHON.md).

PairStream generates pairs in the training process: pair i is a pure
function of (config, seed, i), and the indices are dealt round-robin over
data-parallel ranks and DataLoader workers, so no pair repeats and a
DataLoader gives the same tensors in the same order whatever num_workers.
PairFolder reads a folder made by `reefgen dataset build`, its files checked
against the manifest's checksums first, as `reefgen train` does.
"""
import itertools
import json
import os

import numpy as np
import torch
from torch.utils.data import Dataset, IterableDataset, get_worker_info

import reefgen

__all__ = ["PairStream", "PairFolder", "to_tensors"]


def to_tensors(heights, labels, height_range_m=None):
    """pix2pix's tensors: label {3,S,S} in [-1, 1] and height {1,S,S}, in
    [-1, 1] over height_range_m = (lo, hi) metres, or in metres without it."""
    label = torch.from_numpy(np.ascontiguousarray(labels)).permute(2, 0, 1).float().div_(127.5).sub_(1.0)
    height = torch.from_numpy(np.ascontiguousarray(heights)).unsqueeze(0)
    if height_range_m is not None:
        lo, hi = height_range_m
        height = height.sub(lo).mul_(2.0 / (hi - lo)).sub_(1.0)
    return label, height


class PairStream(IterableDataset):
    """Pairs start, start+1, ... (count of them, or forever with count=None),
    each as (label, height) tensors (to_tensors) and, with with_index, its index.

    rank / world_size: this process's share of a data-parallel job (defaults:
    torch.distributed's when it is initialised, else 0 / 1)."""

    def __init__(self, config=None, seed=0, count=None, start=0, rank=None, world_size=None,
                 height_range_m=None, with_index=False):
        super().__init__()
        if count is not None and count < 0:
            raise ValueError(f"count {count}: must be >= 0 (or None for a stream without end)")
        self.config = reefgen._config_json(config)  # read once, the same in every worker
        self.seed, self.count, self.start = int(seed), count, int(start)
        dist = torch.distributed
        ready = dist.is_available() and dist.is_initialized()
        self.rank = rank if rank is not None else (dist.get_rank() if ready else 0)
        self.world_size = world_size if world_size is not None else (dist.get_world_size() if ready else 1)
        if not 0 <= self.rank < self.world_size:
            raise ValueError(f"rank {self.rank} of world size {self.world_size}: need 0 <= rank < world size")
        self.height_range_m, self.with_index = height_range_m, with_index

    def indices(self):
        """This worker's indices: the stream dealt over ranks × workers."""
        info = get_worker_info()
        workers, worker = (info.num_workers, info.id) if info is not None else (1, 0)
        shards, shard = self.world_size * workers, self.rank * workers + worker
        end = None if self.count is None else self.start + self.count
        return itertools.islice(itertools.count(self.start), shard, None if end is None else end - self.start, shards)

    def __iter__(self):
        for i in self.indices():
            heights, labels = reefgen._reefgen.pair(self.config, self.seed, i)
            label, height = to_tensors(heights, labels, self.height_range_m)
            yield (label, height, i) if self.with_index else (label, height)


class PairFolder(Dataset):
    """A split of a `reefgen dataset build` folder as (label, height) tensors."""

    def __init__(self, root, split="train", height_range_m=None, verify=True):
        import cv2  # Debian's python3-opencv reads the EXR heights

        self._cv2 = cv2
        os.environ.setdefault("OPENCV_IO_ENABLE_OPENEXR", "1")
        self.root = os.fspath(root)
        manifest = os.path.join(self.root, "manifest.jsonl")
        _refuse_other_layouts(self.root)
        try:
            with open(manifest, encoding="utf-8") as f:
                rows = [json.loads(line) for line in f if line.strip()]
        except OSError as e:
            raise reefgen.Error(f"{manifest}: {e.strerror}; is {self.root} a folder made by `reefgen dataset build`?") from None
        self.rows = [r for r in rows if r.get("split") == split]
        self.height_range_m = height_range_m
        if verify:
            for r in self.rows:
                for key in ("label", "height"):
                    _check(os.path.join(self.root, r[key]), r.get(key + "_fnv64"))

    def __len__(self):
        return len(self.rows)

    def __getitem__(self, k):
        r = self.rows[k]
        cv2 = self._cv2
        bgr = cv2.imread(os.path.join(self.root, r["label"]), cv2.IMREAD_COLOR)
        heights = cv2.imread(os.path.join(self.root, r["height"]), cv2.IMREAD_UNCHANGED)
        if bgr is None or heights is None:
            raise reefgen.Error(f"{self.root}: cannot read pair {r.get('index')}; rebuild the dataset")
        return to_tensors(heights.astype(np.float32), bgr[:, :, ::-1], self.height_range_m)


def _refuse_other_layouts(root):
    """`dataset build --format pix2pix|webdataset|imagefolder` folders are for other tools' readers."""
    try:
        with open(os.path.join(root, "dataset.json"), encoding="utf-8") as f:
            layout = json.load(f).get("layout", "reefgen")
    except (OSError, ValueError):
        return  # the manifest's own checks name what is wrong
    if layout != "reefgen":
        raise reefgen.Error(f"{root}: a dataset in the {layout} layout (dataset build --format {layout}), for other "
                            "tools; PairFolder reads reefgen's layout: build one without --format")


def _check(path, expected):
    """The file's checksum against the manifest's (reefgen's file_checksum, as `reefgen train` verifies)."""
    if expected is not None and reefgen._reefgen.file_checksum(path) != expected:
        raise reefgen.Error(f"{path}: checksum differs from the manifest's; the file changed since `reefgen dataset build` wrote it: rebuild or resume the dataset")
