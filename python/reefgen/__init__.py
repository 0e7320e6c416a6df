"""reefgen for Python: coral-reef islands and training pairs from the C++ core.

    import reefgen
    heights, labels = reefgen.generate("young-volcano", size=256)    # float32 metres, uint8 RGB
    heights, labels = reefgen.pair(seed=1, index=7)                   # `reefgen dataset build`'s pair 7
    reefgen.realism(heights, metres_per_px=23.4)                     # pits, terraces, valleys, seams
    heights = reefgen.infer(sketch_rgb, size=1024)                  # `reefgen infer`: a painted sketch to metres

Arrays are numpy arrays over the C++ buffers (no copy). Errors raise
reefgen.Error (a RuntimeError) with the command line's one-line message.
docs/PYTHON.md has the details and reefgen.torch the PyTorch datasets.
"""
import json as _json
import math as _math
import numbers as _numbers
import operator as _operator
import os as _os

from ._reefgen import Error, ConfigError, HEIGHT_RANGE_M, __version__
from . import _reefgen

__all__ = ["generate", "pair", "pair_info", "infer", "default_model", "decode_labels", "realism", "presets", "Error",
           "ConfigError", "HEIGHT_RANGE_M", "REGIONS", "__version__"]
# Region ids of a label map (decode_labels), by name.
REGIONS = ("island", "beach", "lagoon", "reef", "abyss")


def _dict_json(d, what):
    """A dict as strict JSON: NaN and infinities are refused naming them (JSON has neither)."""
    try:
        return _json.dumps(d, allow_nan=False)
    except ValueError:
        raise Error(f"{what}: a NaN or an infinite number in the dict; JSON has neither, give a finite value") from None
    except TypeError as e:
        raise Error(f"{what}: {e}; give numbers, strings, lists and dicts") from None


# The command line's ranges for the numbers every function shares (--age-myr, --maturity).
_AGE_RANGE_MYR = (0.0, 60.0)
_MATURITY_RANGE = (0.05, 20.0)


def _whole(v, name):
    """A whole number as the command line takes it (numpy integers too); 256.5, "256" or True is refused."""
    try:
        return None if isinstance(v, bool) else _operator.index(v)
    except TypeError:
        pass
    raise Error(f"{name} {v!r} must be a whole number")


def _number(v, name):
    """A real number (numpy floats and integers too); a string or a bool is refused. Its
    range, NaN included, is checked where the command line checks it (the C++ half)."""
    if isinstance(v, bool) or not isinstance(v, _numbers.Real):
        raise Error(f"{name} {v!r} must be a number")
    return float(v)


def _config_json(config):
    """A dataset config as JSON text: None (the built-in defaults), a dict or a path."""
    if config is None:
        return ""
    if isinstance(config, dict):
        return _dict_json(config, "config")
    path = _os.fspath(config)
    try:
        with open(path, encoding="utf-8") as f:
            return f.read()
    except OSError as e:
        raise Error(f"cannot read {path}: {e.strerror}; give a dataset config JSON (configs/dataset/*.json)") from None


def _seed(seed, name="seed"):
    """A seed as the command line takes it: a whole number in [0, 2^64 - 1] (numpy integers too)."""
    try:
        value = None if isinstance(seed, bool) else _operator.index(seed)
    except TypeError:
        value = None
    if value is None or not 0 <= value < 2**64:
        raise Error(f"{name} {seed!r} must be a whole number in [0, {2**64 - 1}]")
    return value


def pair(config=None, seed=0, index=0):
    """(heights, labels) of pair `index` of `reefgen dataset build --config CONFIG --seed SEED`.

    heights: (S, S) float32 metres, sea level 0, the values of INDEX.height.exr;
    labels: (S, S, 3) uint8 RGB, the pixels of INDEX.label.png.
    """
    return _reefgen.pair(_config_json(config), _seed(seed), _whole(index, "index"))


def pair_info(config=None, seed=0, index=0):
    """What the manifest says of pair `index`: split, configuration, level, subsidence, seed
    (a decimal string), age_myr (NaN when the config draws none), maturity, ruggedness,
    augmentation (docs/DATASET.md "Ages")."""
    info = _reefgen.pair_info(_config_json(config), _seed(seed), _whole(index, "index"))
    info["augmentation"] = _json.loads(info["augmentation"])
    return info


def generate(spec="young-volcano", size=256, seed=None, subsidence=None, age_myr=None, maturity=None):
    """(heights, labels) of `reefgen generate`: `spec` is a preset name (reefgen.presets()),
    a spec dict or a spec file (configs/presets/*.json); seed is the detail noise's;
    age_myr: the island's age in My (sets subsidence and erosion maturity, docs/SPEC.md
    "Age"), maturity: the erosion's alone; subsidence: λ, over the age's."""
    preset, spec_json = "", ""
    if isinstance(spec, dict):
        spec_json = _dict_json(spec, "spec")
    elif isinstance(spec, str) and spec in _reefgen.presets():
        preset = spec
    elif isinstance(spec, (str, _os.PathLike)) and _os.path.isfile(spec):
        with open(spec, encoding="utf-8") as f:
            spec_json = f.read()
    else:
        preset = str(spec)  # unknown: the C++ error lists the presets
    return _reefgen.generate(preset, spec_json, _whole(size, "size"), None if seed is None else _seed(seed),
                             _optional_number(subsidence, "subsidence", (0.0, 1.0)),
                             _optional_number(age_myr, "age_myr", _AGE_RANGE_MYR),
                             _optional_number(maturity, "maturity", _MATURITY_RANGE))


def _optional_number(v, name, bounds):
    """None -> NaN ("not given" to the C++ half); else a finite number inside bounds, as the
    command line's flag takes it (generate and infer alike)."""
    if v is None:
        return _math.nan
    v = _number(v, name)
    lo, hi = bounds
    if not lo <= v <= hi:  # NaN too
        raise Error(f"{name} {v} must be a finite number in [{lo:g}, {hi:g}] (None: not set)")
    return v


def default_model():
    """The generator reefgen.infer loads without model=: $REEFGEN_MODEL, else the shipped
    model of a pip-installed reefgen (reefgen/models in the package), else that of an
    installed reefgen (PREFIX/share/reefgen/models beside PREFIX/lib/python3), else None:
    in a build tree infer then loads the source tree's models/ (the C++ look-up)."""
    env = _os.environ.get("REEFGEN_MODEL")
    if env:
        return env
    packaged = _os.path.join(_os.path.dirname(_os.path.abspath(__file__)), "models", "reef-256.pt")
    if _os.path.isfile(packaged):
        return packaged
    # PREFIX/lib/python3/dist-packages/reefgen/__init__.py -> PREFIX
    prefix = _os.path.dirname(_os.path.dirname(_os.path.dirname(_os.path.dirname(_os.path.dirname(
        _os.path.abspath(__file__))))))
    installed = _os.path.join(prefix, "share", "reefgen", "models", "reef-256.pt")
    return installed if _os.path.isfile(installed) else None


def infer(sketch, size=0, model=None, seed=0, raw=False, precision="fp32", engine="auto",
          stochastic=False, threads=None, world_size_m=None, variation=1.0, age_myr=None, maturity=None,
          variations=1):
    """(H, W) float32 metres of `reefgen infer`: the same numbers as its height.exr.

    sketch: a painted label map, (H, W, 3) RGB or (H, W, 4) RGBA, uint8 or uint16
    (np.asarray(PIL.Image.open(path)), or reefgen.generate's labels);
    size: the output side (0 = the sketch's; larger sides are amplified);
    model: a generator file (default: default_model(), the shipped model);
    raw: the network's answer only resized (`--raw`); precision, engine, stochastic:
    as the command's flags; threads: LibTorch's for this call (default: all cores);
    world_size_m: the canvas width (default 6000 m);
    seed, variation: another island for the same painting per seed, re-rolled
    that far in [0, 1] (0: the network's own answer; `--seed`, `--variation`);
    age_myr, maturity: the island's age in My (its subsidence replaces the painted
    brightness, its erosion maturity the amplification's) and the maturity alone
    (`--age-myr`, `--maturity`; None: not set);
    variations: N > 1 returns a list of N islands, seeds seed … seed + N − 1, each
    the array infer(..., seed=s) gives (`--variations N`: the network runs once).
    Needs the LibTorch half of the build (libtorch-dev); the generator is loaded once.
    """
    try:
        from . import _reefgen_infer
    except ImportError as e:
        raise Error("reefgen.infer needs the LibTorch half of reefgen (built with libtorch-dev: "
                    f"bash scripts/install-deps.sh, then rebuild): {e}") from None
    if model is None:
        model = default_model() or ""  # "": the build's source tree (the C++ look-up names the fix)
    return _reefgen_infer.infer(sketch, _whole(size, "size"), _os.fspath(model), _seed(seed),
                                bool(raw), str(precision), str(engine), bool(stochastic),
                                None if threads is None else _whole(threads, "threads"),
                                None if world_size_m is None else _number(world_size_m, "world_size_m"),
                                _number(variation, "variation"),
                                _optional_number(age_myr, "age_myr", _AGE_RANGE_MYR),
                                _optional_number(maturity, "maturity", _MATURITY_RANGE), _whole(variations, "variations"))


def decode_labels(image, ruggedness=False):
    """(regions, subsidence) of a label map as `reefgen infer` decodes it: regions (H, W) uint8
    (0 island, 1 beach, 2 lagoon, 3 reef, 4 abyss: reefgen.REGIONS[id]), subsidence (H, W) float32
    in [0, 1]; with ruggedness=True also the per-region style (H, W) uint8, 255 = rugged
    (docs/INFERENCE.md "Per-region style"). image: (H, W, 3) RGB or (H, W, 4) RGBA, uint8 or
    uint16 (reefgen.generate's labels, a pair's labels, np.asarray(PIL.Image.open(path)))."""
    regions, subsidence, rugged = _reefgen.decode_labels(image)
    return (regions, subsidence, rugged) if ruggedness else (regions, subsidence)


def realism(heights, metres_per_px):
    """The realism statistics of `reefgen realism` for a (H, W) array of metres."""
    return _reefgen.realism(heights, _number(metres_per_px, "metres_per_px"))


def presets():
    """The built-in presets' names."""
    return list(_reefgen.presets())
