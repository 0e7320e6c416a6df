"""ctest python_module: the Python module against the files the CLI writes.

usage: python3 test_module.py REEFGEN_BINARY [REEFGEN_TORCH_BINARY]   (PYTHONPATH holds build/python)
"""
import json
import math
import os
import random
import shutil
import subprocess
import sys
import tempfile
import unittest

os.environ.setdefault("OPENCV_IO_ENABLE_OPENEXR", "1")
import cv2  # noqa: E402
import numpy as np  # noqa: E402
import torch  # noqa: E402
from torch.utils.data import DataLoader  # noqa: E402

import reefgen  # noqa: E402
import reefgen.torch as rtorch  # noqa: E402

BIN = None
TORCH_BIN = None  # reefgen-torch: reefgen.infer's checks need the LibTorch half
CONFIG = {"count": 120, "size_px": 32, "levels": 2, "val_fraction": 0.2, "test_fraction": 0.1,
          "p_affine": 0.5, "p_translate": 0.5, "p_paste": 0.5, "paste_scale": 0.5}
SEED = 4


def temp_with_config(cls, prefix):
    """A temporary folder (removed after the class, also when its set-up fails) holding CONFIG as ds.json."""
    import json
    tmp = tempfile.mkdtemp(prefix=prefix)
    cls.addClassCleanup(shutil.rmtree, tmp, True)
    config = os.path.join(tmp, "ds.json")
    with open(config, "w") as f:
        json.dump(CONFIG, f)
    return tmp, config


def read_exr(path):
    h = cv2.imread(path, cv2.IMREAD_UNCHANGED)
    assert h is not None, path
    return h


class Module(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp, cls.config = temp_with_config(cls, "reefgen_py_")
        cls.data = os.path.join(cls.tmp, "data")
        subprocess.run([BIN, "-q", "dataset", "build", "--config", cls.config, "--seed", str(SEED),
                        "--out", cls.data], check=True, stdout=subprocess.DEVNULL)
        import json
        with open(os.path.join(cls.data, "manifest.jsonl")) as f:
            cls.rows = {r["index"]: r for r in map(json.loads, f)}

    def test_pair_equals_the_dataset_files(self):
        indices = random.Random(1).sample(range(CONFIG["count"]), 100)  # the bar: 100 random indices
        for i in indices:
            heights, labels = reefgen.pair(self.config, seed=SEED, index=i)
            r = self.rows[i]
            self.assertEqual(heights.dtype, np.float32)
            self.assertTrue(np.array_equal(heights, read_exr(os.path.join(self.data, r["height"]))), i)
            png = cv2.imread(os.path.join(self.data, r["label"]), cv2.IMREAD_COLOR)[:, :, ::-1]
            self.assertTrue(np.array_equal(labels, png), i)
            info = reefgen.pair_info(self.config, seed=SEED, index=i)
            self.assertEqual((info["split"], info["subsidence"]), (r["split"], r["subsidence"]))
            # The whole record, augmentation included (it was None on every pair).
            self.assertEqual(info["augmentation"], r["augmentation"], i)
            self.assertEqual(info["configuration"], r["configuration"], i)

    def test_generate_equals_the_cli(self):
        prefix = os.path.join(self.tmp, "volcano")
        subprocess.run([BIN, "-q", "generate", "--preset", "young-volcano", "--size", "64", "--seed", "9",
                        "-o", prefix], check=True, stdout=subprocess.DEVNULL)
        heights, labels = reefgen.generate("young-volcano", size=64, seed=9)
        self.assertTrue(np.array_equal(heights, read_exr(prefix + ".height.exr")))
        self.assertTrue(np.array_equal(labels, cv2.imread(prefix + ".label.png", cv2.IMREAD_COLOR)[:, :, ::-1]))
        stats = reefgen.realism(heights, 6000.0 / 64)
        self.assertGreater(stats["land_cells"], 0)
        self.assertAlmostEqual(stats["max_height_m"], float(heights.max()), places=3)
        # An age, as --age-myr: the same bytes; an age out of range names the field.
        subprocess.run([BIN, "-q", "generate", "--preset", "young-volcano", "--size", "64", "--seed", "9",
                        "--age-myr", "3.5", "-o", prefix + "-old"], check=True, stdout=subprocess.DEVNULL)
        old, _ = reefgen.generate("young-volcano", size=64, seed=9, age_myr=3.5)
        self.assertTrue(np.array_equal(old, read_exr(prefix + "-old.height.exr")))
        self.assertFalse(np.array_equal(old, heights))
        with self.assertRaises(reefgen.Error) as e:
            reefgen.generate("young-volcano", size=64, age_myr=-3)
        self.assertIn("age_myr", str(e.exception))

    def test_type_stubs_match_the_module(self):
        # The .pyi stubs (and py.typed) ship beside the package and name every public function,
        # class and method with the module's own parameter names and defaults.
        import ast
        import inspect
        root = os.path.dirname(reefgen.__file__)
        self.assertTrue(os.path.exists(os.path.join(root, "py.typed")))
        for module in (reefgen, rtorch):
            with open(os.path.splitext(module.__file__)[0] + ".pyi") as f:
                tree = ast.parse(f.read())

            def check(node, obj, where):
                # A property's stub is its getter's: (self).
                real = inspect.signature(obj.fget if isinstance(obj, property) else obj).parameters
                args = node.args.args
                defaults = [None] * (len(args) - len(node.args.defaults)) + list(node.args.defaults)
                self.assertEqual([a.arg for a in args], list(real), where)
                for a, d in zip(args, defaults):
                    want = real[a.arg].default
                    if d is None:
                        self.assertIs(want, inspect.Parameter.empty, (where, a.arg))
                    else:
                        self.assertEqual(ast.literal_eval(d), want, (where, a.arg))

            named = set()
            for node in tree.body:
                if isinstance(node, ast.FunctionDef):
                    named.add(node.name)
                    check(node, getattr(module, node.name), node.name)
                elif isinstance(node, ast.ClassDef):
                    named.add(node.name)
                    cls = getattr(module, node.name)
                    for m in node.body:
                        if isinstance(m, ast.FunctionDef):
                            check(m, getattr(cls, m.name), node.name + "." + m.name)
                elif isinstance(node, ast.AnnAssign):
                    named.add(node.target.id)
            for name in module.__all__:
                self.assertIn(name, named, module.__name__ + " stub lacks " + name)

    def test_ctrl_c_stops_a_long_call(self):
        # Ctrl-C 0.3 s into generate(size=8192) (14 s and more on 2 cores): the call stops between
        # its erosion steps with KeyboardInterrupt, whose message says so (a Ctrl-C seen only
        # after the call returned is a bare KeyboardInterrupt), and the module still works.
        # No clock: a loaded machine makes any time bar flaky.
        import signal
        import threading
        timer = threading.Timer(0.3, lambda: os.kill(os.getpid(), signal.SIGINT))
        timer.start()
        with self.assertRaises(KeyboardInterrupt) as caught:
            reefgen.generate("young-volcano", size=8192)
        timer.join()
        self.assertIn("stopped between steps", str(caught.exception), "Ctrl-C waited for the call to end")
        heights, _ = reefgen.generate("young-volcano", size=64)
        self.assertEqual(heights.shape, (64, 64))

    def test_errors_are_one_line(self):
        with self.assertRaises(reefgen.Error) as e:
            reefgen.generate("no-such-preset")
        self.assertIn("young-volcano", str(e.exception))
        with self.assertRaises(reefgen.Error) as e:
            reefgen.pair({"count": 0})
        self.assertNotIn("\n", str(e.exception))
        with self.assertRaises(reefgen.Error):
            reefgen.pair(os.path.join(self.tmp, "missing.json"))
        # The arguments the command line refuses are reefgen.Error here too, one line each, never
        # a raw cast error or a silent default: a negative index, a negative seed, a NaN subsidence.
        for call, needle in ((lambda: reefgen.pair_info(None, 0, -5), "outside [0,"),
                             (lambda: reefgen.pair(seed=-1), "whole number in [0,"),
                             (lambda: reefgen.pair(seed=2**64), "whole number in [0,"),
                             (lambda: reefgen.pair(seed=1.5), "whole number in [0,"),
                             (lambda: reefgen.generate("atoll", size=32, seed=-1), "whole number in [0,"),
                             (lambda: reefgen.generate("atoll", size=32, subsidence=float("nan")), "finite number in [0, 1]"),
                             (lambda: reefgen.generate("atoll", size=32, subsidence=2), "finite number in [0, 1]")):
            with self.assertRaises(reefgen.Error) as e:
                call()
            self.assertIn(needle, str(e.exception))
            self.assertNotIn("\n", str(e.exception))
        self.assertEqual(reefgen.pair_info(None, np.uint64(3), 0)["index"], 0)  # numpy integers are seeds too
        # Numbers strict and alike across functions: a fractional or text size, index, thread or
        # variation count is refused (it was truncated or parsed); an age outside the flag's
        # [0, 60] is refused by generate as by infer (generate took -1 as "not set"); a NaN in a
        # spec or config dict is one line naming it (it was the JSON parser's raw text).
        for call, needle in ((lambda: reefgen.generate("atoll", size=32.5), "size 32.5 must be a whole number"),
                             (lambda: reefgen.generate("atoll", size="32"), "size '32' must be a whole number"),
                             (lambda: reefgen.pair(index=1.5), "index 1.5 must be a whole number"),
                             (lambda: reefgen.generate("atoll", size=32, age_myr=-1), "age_myr -1.0 must be a finite number in [0, 60]"),
                             (lambda: reefgen.generate("atoll", size=32, maturity="2"), "maturity '2' must be a number"),
                             (lambda: reefgen.generate({"noise": {"seed": float("nan")}}, size=32), "spec: a NaN"),
                             (lambda: reefgen.pair({"count": float("inf")}), "config: a NaN or an infinite")):
            with self.assertRaises(reefgen.Error) as e:
                call()
            self.assertIn(needle, str(e.exception))
            self.assertNotIn("\n", str(e.exception))
        if TORCH_BIN:
            _, labels = reefgen.generate("atoll", size=64)
            for kwargs, needle in (({"size": 64.5}, "size 64.5 must be a whole number"),
                                   ({"threads": 1.5}, "threads 1.5 must be a whole number"),
                                   ({"variations": 2.5}, "variations 2.5 must be a whole number"),
                                   ({"age_myr": -1}, "age_myr -1.0 must be a finite number in [0, 60]")):
                with self.assertRaises(reefgen.Error) as e:
                    reefgen.infer(labels, **kwargs)
                self.assertIn(needle, str(e.exception))

    def test_infer_equals_the_cli(self):
        if not TORCH_BIN:
            self.skipTest("built without LibTorch (no reefgen-torch): reefgen.infer is not there")
        _, labels = reefgen.generate("barrier-reef", size=64, seed=3)
        sketch = os.path.join(self.tmp, "sketch.png")
        cv2.imwrite(sketch, labels[:, :, ::-1])
        prefix = os.path.join(self.tmp, "inferred")
        subprocess.run([TORCH_BIN, "-q", "infer", sketch, "--size", "128", "--seed", "2", "-o", prefix],
                       check=True, stdout=subprocess.DEVNULL)
        cli = read_exr(prefix + ".height.exr")
        heights = reefgen.infer(labels, size=128, seed=2)
        self.assertEqual((heights.shape, heights.dtype), ((128, 128), np.float32))
        self.assertTrue(np.array_equal(heights, cli))
        # RGBA, 16 bits and one thread: the same heights.
        rgba = np.dstack([labels, np.full(labels.shape[:2], 255, np.uint8)])
        self.assertTrue(np.array_equal(reefgen.infer(rgba, size=128, seed=2, threads=1), cli))
        self.assertTrue(np.array_equal(reefgen.infer(labels.astype(np.uint16) * 257, size=128, seed=2), cli))
        # Another seed, another island; variation 0 keeps the network's island (no re-roll).
        self.assertFalse(np.array_equal(reefgen.infer(labels, size=128, seed=3), cli))
        mean = reefgen.infer(labels, size=128, seed=2, variation=0)
        self.assertFalse(np.array_equal(mean, cli))
        for bad in (-0.1, 1.5, float("nan")):
            with self.assertRaises(reefgen.Error) as e:
                reefgen.infer(labels, size=128, variation=bad)
            self.assertIn("variation must be in [0, 1]", str(e.exception))
        # An age, as --age-myr: the same bytes as the command.
        subprocess.run([TORCH_BIN, "-q", "infer", sketch, "--size", "128", "--seed", "2", "--age-myr", "5",
                        "-o", prefix + "-old"], check=True, stdout=subprocess.DEVNULL)
        self.assertTrue(np.array_equal(reefgen.infer(labels, size=128, seed=2, age_myr=5),
                                       read_exr(prefix + "-old.height.exr")))
        with self.assertRaises(reefgen.Error) as e:
            reefgen.infer(labels, size=128, maturity=100)
        self.assertIn("maturity", str(e.exception))
        # variations=N: the islands of seeds 2, 3, 4, each infer(..., seed=s)'s.
        three = reefgen.infer(labels, size=128, seed=2, variations=3)
        self.assertEqual(len(three), 3)
        self.assertTrue(np.array_equal(three[0], cli))
        self.assertTrue(np.array_equal(three[2], reefgen.infer(labels, size=128, seed=4)))
        with self.assertRaises(reefgen.Error) as e:
            reefgen.infer(labels, size=128, variations=17)
        self.assertIn("variations must be in [1, 16]", str(e.exception))
        raw = reefgen.infer(labels, raw=True)
        self.assertEqual(raw.shape, (64, 64))
        self.assertFalse(np.array_equal(raw, reefgen.infer(labels)))  # --raw skips the clean-up
        with self.assertRaises(reefgen.Error) as e:
            reefgen.infer(labels, model=os.path.join(self.tmp, "missing.pt"))
        self.assertIn("missing.pt", str(e.exception))
        with self.assertRaises(reefgen.Error) as e:
            reefgen.infer(np.zeros((8, 8, 3), np.uint8))
        self.assertIn("region colour", str(e.exception))
        with self.assertRaises(reefgen.Error):
            reefgen.infer(labels.astype(np.float32))
        with self.assertRaises(reefgen.Error) as e:
            reefgen.infer(np.zeros((0, 0, 3), np.uint8))
        self.assertIn("empty", str(e.exception))
        with self.assertRaises(reefgen.Error):
            reefgen.infer(labels, seed=-1)
        with self.assertRaises(reefgen.Error) as e:
            reefgen.infer(labels, engine="onednn", stochastic=True)
        self.assertIn("stochastic=True needs engine=torch", str(e.exception))  # its keywords, not the flags
        # The engine's own refusal (an unknown Winograd backend) is reefgen.Error too, one line. A copy
        # of the model: the engine of the one used above is loaded already.
        fresh = os.path.join(self.tmp, "fresh.pt")
        shutil.copyfile(os.path.join(os.path.dirname(__file__), "..", "..", "models", "reef-256.pt"), fresh)
        os.environ["REEFGEN_WINOGRAD_GEMM"] = "blas"
        try:
            with self.assertRaises(reefgen.Error) as e:
                reefgen.infer(labels, size=128, model=fresh)
        finally:
            del os.environ["REEFGEN_WINOGRAD_GEMM"]
        self.assertIn("REEFGEN_WINOGRAD_GEMM='blas'", str(e.exception))

    def stream(self, workers, **kw):
        ds = rtorch.PairStream(self.config, seed=SEED, count=12, with_index=True, **kw)
        out = []
        for label, height, i in DataLoader(ds, batch_size=None, num_workers=workers):
            out.append((int(i), label, height))
        return out

    def test_stream_is_the_same_whatever_the_workers(self):
        runs = {w: self.stream(w) for w in (0, 1, 2)}
        for w, run in runs.items():
            self.assertEqual(sorted(i for i, _, _ in run), list(range(12)), w)  # each pair once
            for (i, label, height), (j, label0, height0) in zip(run, runs[0]):
                self.assertEqual(i, j)
                self.assertTrue(torch.equal(label, label0) and torch.equal(height, height0), (w, i))
        heights, labels = reefgen.pair(self.config, seed=SEED, index=5)
        label, height = rtorch.to_tensors(heights, labels)
        self.assertTrue(torch.equal(runs[2][5][1], label) and torch.equal(runs[2][5][2], height))

    def test_decode_labels_reads_what_infer_reads(self):
        heights, labels = reefgen.pair(self.config, seed=SEED, index=3)
        regions, subsidence = reefgen.decode_labels(labels)
        self.assertEqual((regions.shape, regions.dtype, subsidence.dtype), (labels.shape[:2], np.uint8, np.float32))
        self.assertEqual(set(np.unique(regions)) <= set(range(5)), True)
        # The pair's label map encodes one λ (V = 1 - 0.75 λ): decoded back within an 8-bit step.
        info = reefgen.pair_info(self.config, seed=SEED, index=3)
        self.assertLess(float(np.abs(subsidence - info["subsidence"]).max()), 0.75 / 255 * 2)
        # Land is where the island or beach is painted, above the sea in the young pairs' heights.
        self.assertEqual(reefgen.REGIONS[0], "island")
        rgba = np.dstack([labels, np.full(labels.shape[:2], 255, np.uint8)])
        r2, s2, rugged = reefgen.decode_labels(rgba, ruggedness=True)
        self.assertTrue(np.array_equal(r2, regions) and np.array_equal(s2, subsidence))
        self.assertTrue((rugged == 255).all())  # the palette's full colours: rugged
        pastel = labels.astype(np.float32)
        pastel = (pastel.max(axis=2, keepdims=True) - (pastel.max(axis=2, keepdims=True) - pastel) * 0.3).astype(np.uint8)
        self.assertTrue((reefgen.decode_labels(pastel, ruggedness=True)[2] == 0).all())  # saturation 0.3: smooth
        with self.assertRaises(reefgen.Error) as e:
            reefgen.decode_labels(np.zeros((4, 4), np.float64))
        self.assertIn("decode_labels: the sketch must be", str(e.exception))

    def test_stream_gives_each_pairs_conditioning(self):
        ds = rtorch.PairStream(self.config, seed=SEED, count=6, with_index=True, with_conditioning=True)
        seen = 0
        for label, height, i, cond in ds:
            info = reefgen.pair_info(self.config, seed=SEED, index=i)
            for k in ("index", "configuration", "level", "subsidence", "split", "seed", "maturity", "ruggedness"):
                self.assertEqual(cond[k], info[k], (i, k))
            self.assertTrue(math.isnan(cond["age_myr"]))  # this config draws no age
            self.assertEqual(cond["maturity"], 1.0)
            seen += 1
        self.assertEqual(seen, 6)
        # A DataLoader collates a batch's conditioning: tensors of numbers, a list of split names.
        batch = next(iter(DataLoader(rtorch.PairStream(self.config, seed=SEED, count=4, with_conditioning=True,
                                                       batch_size=4), batch_size=4)))
        self.assertEqual(tuple(batch[2]["subsidence"].shape), (4,))
        self.assertEqual(len(batch[2]["split"]), 4)
        self.assertEqual(tuple(batch[2]["age_myr"].shape), (4,))
        self.assertEqual(len(batch[2]["seed"]), 4)  # 64-bit seeds as decimal strings
        # A config that draws ages: each pair's age, its subsidence from it.
        with open(self.config) as f:
            aged = json.load(f)
        aged.update(age_min_myr=0.1, age_max_myr=8)
        info = reefgen.pair_info(aged, seed=SEED, index=1)
        self.assertTrue(0.1 <= info["age_myr"] <= 8)
        self.assertAlmostEqual(info["subsidence"], min(1.0, math.sqrt(info["age_myr"] / 60)), places=12)

    def test_stream_splits_across_ranks(self):
        parts = [self.stream(2, rank=r, world_size=3) for r in range(3)]
        seen = [i for part in parts for i, _, _ in part]
        self.assertEqual(sorted(seen), list(range(12)))

    def test_stream_deals_whole_batches_whatever_the_workers(self):
        # DataLoader batches of 8 from 20 pairs: [0..7], [8..15], [16..19] with 0, 2 or 4 workers
        # (dealt per index, 2 workers gave [0, 2, 4, ..., 14] first).
        want = [list(range(0, 8)), list(range(8, 16)), list(range(16, 20))]
        for workers in (0, 2, 4):
            ds = rtorch.PairStream(self.config, seed=SEED, count=20, with_index=True, batch_size=8)
            got = [b[2].tolist() for b in DataLoader(ds, batch_size=8, num_workers=workers)]
            self.assertEqual(got, want, workers)

    def test_stream_split_and_shuffle_over_ranks_and_workers(self):
        train = sorted(i for i, r in self.rows.items() if r["split"] == "train")
        self.assertTrue(0 < len(train) < CONFIG["count"])

        def epoch(e):
            seen = []
            for rank in range(2):
                ds = rtorch.PairStream(self.config, seed=SEED, count=CONFIG["count"], split="train", shuffle=True,
                                       with_index=True, batch_size=4, rank=rank, world_size=2)
                ds.set_epoch(e)
                for _, _, idx in DataLoader(ds, batch_size=4, num_workers=2):
                    seen += idx.tolist()
            return seen

        first = epoch(0)
        self.assertEqual(sorted(first), train)  # every train pair once, no val or test pair
        ds = rtorch.PairStream(self.config, seed=SEED, count=CONFIG["count"], split="train", shuffle=True)
        order0 = list(ds.order())
        self.assertEqual(order0, list(ds.order()))  # the same seed and epoch: the same order
        self.assertNotEqual(order0, train)
        ds.set_epoch(1)
        order1 = list(ds.order())
        self.assertEqual(sorted(order1), train)
        self.assertNotEqual(order1, order0)  # another epoch, another order
        # Persistent workers keep their copy of the stream across epochs: set_epoch reaches them.
        ds = rtorch.PairStream(self.config, seed=SEED, count=CONFIG["count"], split="train", shuffle=True,
                               with_index=True, batch_size=2)
        loader = DataLoader(ds, batch_size=2, num_workers=2, persistent_workers=True)
        by_epoch = []
        for e in range(2):
            ds.set_epoch(e)
            by_epoch.append([i for b in loader for i in b[2].tolist()])
        self.assertEqual(by_epoch[0], order0)
        self.assertEqual(by_epoch[1], order1)
        other = rtorch.PairStream(self.config, seed=SEED + 1, count=CONFIG["count"], split="val")
        val = sorted(i for i, r in self.rows.items() if r["split"] == "val")
        self.assertNotEqual(list(other.order()), val)  # the split follows the seed, as dataset build's
        same = rtorch.PairStream(self.config, seed=SEED, count=CONFIG["count"], split="val")
        self.assertEqual(list(same.order()), val)
        # A bad config is refused when the stream is made, not in a worker at the first pair.
        with self.assertRaises(reefgen.Error):
            rtorch.PairStream({"count": 0})
        with self.assertRaises(ValueError):
            rtorch.PairStream(self.config, split="validation")

    def test_pair_folder_checks_the_manifest(self):
        train = rtorch.PairFolder(self.data, "train")
        n = sum(1 for r in self.rows.values() if r["split"] == "train")
        self.assertEqual(len(train), n)
        label, height = train[0]
        self.assertEqual(tuple(label.shape), (3, 32, 32))
        self.assertEqual(tuple(height.shape), (1, 32, 32))
        copy = os.path.join(self.tmp, "copy")
        shutil.copytree(self.data, copy)
        first = next(r for r in self.rows.values() if r["split"] == "train")
        with open(os.path.join(copy, first["label"]), "r+b") as f:
            f.seek(40)
            f.write(b"\x00\x01\x02")
        with self.assertRaises(reefgen.Error) as e:
            rtorch.PairFolder(copy, "train")
        self.assertIn("checksum", str(e.exception))

    def test_the_docs_example_trains(self):
        example = os.path.join(os.path.dirname(__file__), "..", "..", "docs", "examples", "train_from_stream.py")
        out = subprocess.run([sys.executable, example, "10"], check=True, capture_output=True, text=True).stdout
        losses = [float(line.split()[-1]) for line in out.splitlines() if line.startswith("step")]
        self.assertEqual(len(losses), 3, out)  # steps 1, 5, 10
        self.assertLess(losses[-1], losses[0], out)


def fnv1a64(data):
    """The manifests' checksum, written here independently of reefgen's."""
    h = 0xCBF29CE484222325
    for b in data:
        h = ((h ^ b) * 0x100000001B3) & 0xFFFFFFFFFFFFFFFF
    return "%016x" % h


class Layouts(unittest.TestCase):
    """dataset build --format: the files other tools read, read as they read them."""

    @classmethod
    def setUpClass(cls):
        cls.tmp, cls.config = temp_with_config(cls, "reefgen_layouts_")
        for layout in ("pix2pix", "webdataset", "imagefolder"):
            small_shards = ["--tar-mb", "1"] if layout == "webdataset" else []  # 71 pairs a shard: two shards
            subprocess.run([BIN, "-q", "dataset", "build", "--config", cls.config, "--seed", str(SEED), "--out",
                            os.path.join(cls.tmp, layout), "--format", layout] + small_shards,
                           check=True, stdout=subprocess.DEVNULL)

    def rows(self, layout):
        import json
        with open(os.path.join(self.tmp, layout, "manifest.jsonl")) as f:
            return [json.loads(line) for line in f]

    def test_webdataset_shards_hold_the_manifests_members(self):
        import io
        import json
        import tarfile
        root = os.path.join(self.tmp, "webdataset")
        rows = self.rows("webdataset")
        self.assertEqual(sorted(r["index"] for r in rows), list(range(CONFIG["count"])))
        listed, shards = 0, 0
        for split in ("train", "val", "test"):
            with open(os.path.join(root, split + ".index.json")) as f:
                index = json.load(f)
            for shard in index["shardlist"]:
                path = os.path.join(root, shard["url"])
                self.assertEqual(shard["filesize"], os.path.getsize(path))
                mine = {r["key"]: r for r in rows if r["shard"] == shard["url"]}
                with tarfile.open(path) as tar:
                    members = {m.name: tar.extractfile(m).read() for m in tar.getmembers()}
                self.assertEqual(len(members), 3 * shard["nsamples"])
                self.assertEqual(len(mine), shard["nsamples"])
                for key, r in mine.items():
                    self.assertEqual(r["split"], split)
                    label, height, record = (members[key + ".label.png"], members[key + ".height.npy"],
                                             members[key + ".json"])
                    self.assertEqual(fnv1a64(label), r["label_fnv64"])
                    self.assertEqual(fnv1a64(height), r["height_fnv64"])
                    self.assertEqual(fnv1a64(record), r["json_fnv64"])
                    self.assertEqual(json.loads(record)["index"], r["index"])
                    heights, labels = reefgen.pair(self.config, seed=SEED, index=r["index"])
                    self.assertTrue(np.array_equal(np.load(io.BytesIO(height)), heights))
                    png = cv2.imdecode(np.frombuffer(label, np.uint8), cv2.IMREAD_COLOR)[:, :, ::-1]
                    self.assertTrue(np.array_equal(png, labels))
                listed += shard["nsamples"]
                shards += 1
        self.assertEqual(listed, CONFIG["count"])
        self.assertGreater(shards, 3)  # train in two shards at --tar-mb 1

    def test_pix2pix_opens_with_pil_as_aligned_a_b(self):
        import json
        from PIL import Image
        root = os.path.join(self.tmp, "pix2pix")
        with open(os.path.join(root, "dataset.json")) as f:
            rng = json.load(f)["range"]
        lo, hi = rng["floor_m"], rng["peak_m"]
        S = CONFIG["size_px"]
        for r in self.rows("pix2pix"):
            path = os.path.join(root, r["ab"])
            self.assertTrue(r["ab"].startswith(r["split"] + "/"))
            with open(path, "rb") as f:
                self.assertEqual(fnv1a64(f.read()), r["ab_fnv64"])
            # What pix2pix's aligned mode does: open, RGB, cut in two halves.
            ab = Image.open(path).convert("RGB")
            self.assertEqual(ab.size, (2 * S, S))
            a = np.asarray(ab.crop((0, 0, S, S)))
            b = np.asarray(ab.crop((S, 0, 2 * S, S)))
            heights, labels = reefgen.pair(self.config, seed=SEED, index=r["index"])
            self.assertTrue(np.array_equal(a, labels))
            expected = (heights - lo) / (hi - lo) * 255
            self.assertLessEqual(np.abs(b[:, :, 0] - expected).max(), 1.0)
            # All 16 bits for readers that keep them: 1 cm steps.
            b16 = cv2.imread(path, cv2.IMREAD_UNCHANGED)[:, S:, 0]
            self.assertLessEqual(np.abs(lo + b16 / 65535.0 * (hi - lo) - heights).max(), 0.006)

    def test_imagefolder_metadata_names_the_files(self):
        import json
        from PIL import Image
        root = os.path.join(self.tmp, "imagefolder")
        seen = []
        for split in ("train", "val", "test"):
            with open(os.path.join(root, split, "metadata.jsonl")) as f:
                meta = [json.loads(line) for line in f]
            images = sorted(n for n in os.listdir(os.path.join(root, split)) if n.endswith(".png"))
            self.assertEqual(sorted(m["file_name"] for m in meta), images)  # every image has its row
            for m in meta:
                heights, labels = reefgen.pair(self.config, seed=SEED, index=m["index"])
                self.assertTrue(np.array_equal(np.asarray(Image.open(os.path.join(root, split, m["file_name"]))),
                                               labels))
                self.assertTrue(np.array_equal(np.load(os.path.join(root, split, m["height_file"])), heights))
                seen.append(m["index"])
        self.assertEqual(sorted(seen), list(range(CONFIG["count"])))
        with self.assertRaises(reefgen.Error) as e:
            rtorch.PairFolder(root, "train")
        self.assertIn("imagefolder layout", str(e.exception))


if __name__ == "__main__":
    BIN = sys.argv.pop(1)
    if len(sys.argv) > 1 and not sys.argv[1].startswith("-"):
        TORCH_BIN = sys.argv.pop(1)
    unittest.main(verbosity=2)
