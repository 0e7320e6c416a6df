"""reefgen for Python: coral-reef islands and training pairs from the C++ core.

    import reefgen
    heights, labels = reefgen.generate("young-volcano", size=256)    # float32 metres, uint8 RGB
    heights, labels = reefgen.pair(seed=1, index=7)                   # `reefgen dataset build`'s pair 7
    reefgen.realism(heights, metres_per_px=23.4)                     # pits, terraces, valleys, seams

Arrays are numpy arrays over the C++ buffers (no copy). Errors raise
reefgen.Error (a RuntimeError) with the command line's one-line message.
docs/PYTHON.md has the details and reefgen.torch the PyTorch datasets.
"""
import json as _json
import math as _math
import os as _os

from ._reefgen import Error, ConfigError, __version__
from . import _reefgen

__all__ = ["generate", "pair", "pair_info", "realism", "presets", "Error", "ConfigError", "__version__"]


def _config_json(config):
    """A dataset config as JSON text: None (the built-in defaults), a dict or a path."""
    if config is None:
        return ""
    if isinstance(config, dict):
        return _json.dumps(config)
    path = _os.fspath(config)
    try:
        with open(path, encoding="utf-8") as f:
            return f.read()
    except OSError as e:
        raise Error(f"cannot read {path}: {e.strerror}; give a dataset config JSON (configs/dataset/*.json)") from None


def pair(config=None, seed=0, index=0):
    """(heights, labels) of pair `index` of `reefgen dataset build --config CONFIG --seed SEED`.

    heights: (S, S) float32 metres, sea level 0, the values of INDEX.height.exr;
    labels: (S, S, 3) uint8 RGB, the pixels of INDEX.label.png.
    """
    return _reefgen.pair(_config_json(config), int(seed), int(index))


def pair_info(config=None, seed=0, index=0):
    """What the manifest says of pair `index`: split, configuration, level, subsidence, augmentation."""
    info = _reefgen.pair_info(_config_json(config), int(seed), int(index))
    info["augmentation"] = _json.loads(info["augmentation"])
    return info


def generate(spec="young-volcano", size=256, seed=None, subsidence=None):
    """(heights, labels) of `reefgen generate`: `spec` is a preset name (reefgen.presets()),
    a spec dict or a spec file (configs/presets/*.json); seed is the detail noise's."""
    preset, spec_json = "", ""
    if isinstance(spec, dict):
        spec_json = _json.dumps(spec)
    elif isinstance(spec, str) and spec in _reefgen.presets():
        preset = spec
    elif isinstance(spec, (str, _os.PathLike)) and _os.path.isfile(spec):
        with open(spec, encoding="utf-8") as f:
            spec_json = f.read()
    else:
        preset = str(spec)  # unknown: the C++ error lists the presets
    return _reefgen.generate(preset, spec_json, int(size), seed,
                             _math.nan if subsidence is None else float(subsidence))


def realism(heights, metres_per_px):
    """The realism statistics of `reefgen realism` for a (H, W) array of metres."""
    return _reefgen.realism(heights, float(metres_per_px))


def presets():
    """The built-in presets' names."""
    return list(_reefgen.presets())
