"""PyTorch datasets over reefgen's pairs (docs/PYTHON.md).

PairStream generates pairs in the training process: pair i is a pure
function of (config, seed, i); a split keeps `dataset build`'s train, val or
test pairs, a seeded shuffle orders each epoch, and the order is dealt over
data-parallel ranks and DataLoader workers in whole batches, so no pair
repeats and a DataLoader gives the same batches whatever num_workers.
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


# Pairs a stream can name: DatasetParams::count's upper bound.
_MAX_PAIRS = 100_000_000
# Indices whose splits are looked up at once (pair_splits makes no pair).
_SPLIT_WINDOW = 4096
_SPLIT_LETTER = {"train": "t", "val": "v", "test": "s"}


class PairStream(IterableDataset):
    """Pairs start, start+1, ... (count of them, or without end), each as
    (label, height) tensors (to_tensors) and, with with_index, its index;
    with with_conditioning, then a dict of the pair's conditioning: index,
    configuration, level, subsidence (λ, float) and split (a DataLoader
    collates a batch's into tensors and a list).

    split: "train", "val" or "test" keeps the pairs `reefgen dataset build`
    puts in that split (the same rule: whole configurations go to one split);
    None keeps every pair.
    shuffle: each epoch (set_epoch) takes the pairs in another order, seeded
    by (seed, epoch): a permutation of each run of shuffle_window pairs (all
    of them when there are no more), the same for the same seed and epoch.
    batch_size: the DataLoader's; the order is dealt to ranks and workers in
    whole batches of this many, so a DataLoader with that batch_size gives
    the same batches in the same order whatever num_workers.
    rank / world_size: this process's share of a data-parallel job (defaults:
    torch.distributed's when it is initialised, else 0 / 1): batch b goes to
    rank b % world_size. Every pair of the epoch goes to exactly one rank and
    worker; ranks may get one batch more than others."""

    def __init__(self, config=None, seed=0, count=None, start=0, rank=None, world_size=None,
                 height_range_m=None, with_index=False, split=None, shuffle=False, batch_size=1,
                 shuffle_window=65536, with_conditioning=False):
        super().__init__()
        if count is not None and count < 0:
            raise ValueError(f"count {count}: must be >= 0 (or None for a stream without end)")
        if split is not None and split not in _SPLIT_LETTER:
            raise ValueError(f"split {split!r}: must be 'train', 'val', 'test' or None")
        if int(batch_size) < 1 or int(shuffle_window) < 1:
            raise ValueError(f"batch_size {batch_size} and shuffle_window {shuffle_window} must be >= 1")
        self.config = reefgen._config_json(config)  # read once, the same in every worker
        self.seed, self.count, self.start = reefgen._seed(seed), count, int(start)
        # A bad config or start is refused here, not in a worker at the first pair.
        reefgen._reefgen.pair_splits(self.config, self.seed, self.start, 0)
        dist = torch.distributed
        ready = dist.is_available() and dist.is_initialized()
        self.rank = rank if rank is not None else (dist.get_rank() if ready else 0)
        self.world_size = world_size if world_size is not None else (dist.get_world_size() if ready else 1)
        if not 0 <= self.rank < self.world_size:
            raise ValueError(f"rank {self.rank} of world size {self.world_size}: need 0 <= rank < world size")
        self.height_range_m, self.with_index = height_range_m, with_index
        self.with_conditioning = bool(with_conditioning)
        self.split, self.shuffle = split, bool(shuffle)
        self.batch_size, self.shuffle_window = int(batch_size), int(shuffle_window)
        # The epoch in shared memory: a DataLoader with persistent_workers
        # keeps the workers' copies of this object across epochs, so a plain
        # attribute set in the main process never reached them (every epoch
        # repeated epoch 0's order). Forked or spawned, a worker's copy reads
        # the same storage.
        self._epoch = torch.zeros(1, dtype=torch.int64).share_memory_()

    @property
    def epoch(self):
        return int(self._epoch[0])

    def set_epoch(self, epoch):
        """The epoch whose order the next iteration takes (as DistributedSampler.set_epoch),
        in every DataLoader worker too, persistent ones included."""
        self._epoch.fill_(int(epoch))

    def _kept(self):
        """The indices of the split, in index order."""
        end = _MAX_PAIRS if self.count is None else min(_MAX_PAIRS, self.start + self.count)
        if self.split is None:
            yield from range(self.start, end)
            return
        letter = _SPLIT_LETTER[self.split]
        for first in range(self.start, end, _SPLIT_WINDOW):
            letters = reefgen._reefgen.pair_splits(self.config, self.seed, first, min(_SPLIT_WINDOW, end - first))
            yield from (first + k for k, c in enumerate(letters) if c == letter)

    def order(self):
        """Every index of this epoch, in the order the stream deals them."""
        if not self.shuffle:
            yield from self._kept()
            return
        it, window = iter(self._kept()), 0
        while True:
            run = np.fromiter(itertools.islice(it, self.shuffle_window), dtype=np.int64)
            if run.size == 0:
                return
            rng = np.random.default_rng([self.seed & 0xFFFFFFFF, self.seed >> 32, self.epoch, window])
            yield from (int(i) for i in rng.permutation(run))
            window += 1

    def indices(self):
        """This worker's indices: the epoch's order dealt over ranks × workers in whole batches."""
        info = get_worker_info()
        workers, worker = (info.num_workers, info.id) if info is not None else (1, 0)
        for position, i in enumerate(self.order()):
            batch = position // self.batch_size
            if batch % self.world_size == self.rank and (batch // self.world_size) % workers == worker:
                yield i

    def __iter__(self):
        for i in self.indices():
            made = reefgen._reefgen.pair(self.config, self.seed, i, self.with_conditioning)
            label, height = to_tensors(made[0], made[1], self.height_range_m)
            item = (label, height, i) if self.with_index else (label, height)
            yield item + (made[2],) if self.with_conditioning else item


class PairFolder(Dataset):
    """A split of a `reefgen dataset build` folder as (label, height) tensors."""

    def __init__(self, root, split="train", height_range_m=None, verify=True):
        import cv2  # Debian's python3-opencv reads the EXR heights

        self._cv2 = cv2
        os.environ.setdefault("OPENCV_IO_ENABLE_OPENEXR", "1")
        self.root = os.fspath(root)
        # The manifest read and checked as `reefgen train` reads it: reefgen's
        # layout, paths inside the folder and, with verify, every file's checksum.
        self.rows = [json.loads(r) for r in reefgen._reefgen.manifest_records(self.root, split, verify)]
        self.height_range_m = height_range_m

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
