#!/usr/bin/env bash
# `pip install .` into a fresh virtual environment (Debian's python3 -m venv
# --system-site-packages, so numpy is Debian's), offline: setuptools from
# Debian as the backend (--no-build-isolation), the modules from the given
# CMake tree (REEFGEN_BUILD_DIR). Then, from outside the source tree, import
# reefgen, find the packaged model, infer an island, and see the stubs.
set -uo pipefail
SRC="$1"; BUILD="$2"; PY="$3"
T=$(mktemp -d); trap 'rm -rf "$T"' EXIT
"$PY" -m venv --system-site-packages "$T/venv" >"$T/err" 2>&1 ||
  { echo "FAIL: $PY -m venv: $(tail -1 "$T/err") (bash scripts/install-deps.sh installs python3-venv)"; exit 1; }
REEFGEN_BUILD_DIR="$BUILD" "$T/venv/bin/pip" install -q --no-build-isolation --no-index "$SRC" >"$T/err" 2>&1 ||
  { echo "FAIL: pip install: $(tail -3 "$T/err")"; exit 1; }
# The wheel as docs/PYTHON.md makes it, into a fresh folder: --no-deps, since
# numpy is Debian's and --no-index has no index to fetch it from.
mkdir -p "$T/wheels"
(cd "$SRC" && REEFGEN_BUILD_DIR="$BUILD" "$T/venv/bin/pip" wheel -q --no-build-isolation --no-index --no-deps \
  -w "$T/wheels" .) >"$T/err" 2>&1 || { echo "FAIL: pip wheel: $(tail -3 "$T/err")"; exit 1; }
ls "$T/wheels"/reefgen-*.whl >/dev/null 2>&1 || { echo "FAIL: pip wheel wrote no reefgen-*.whl: $(ls "$T/wheels")"; exit 1; }
"$PY" -c "import sys, zipfile; n = zipfile.ZipFile(sys.argv[1]).namelist(); assert 'reefgen/models/reef-256.pt' in n, n[:20]" \
  "$(ls "$T/wheels"/reefgen-*.whl | head -1)" || { echo "FAIL: the wheel lacks the packaged model"; exit 1; }
cd / && "$T/venv/bin/python" - "$T/venv" <<'PY' || exit 1
import os, sys
import reefgen
venv = sys.argv[1]
site = os.path.dirname(os.path.dirname(reefgen.__file__))
assert site.startswith(venv), f"reefgen imported from {reefgen.__file__}, not the virtual environment"
model = reefgen.default_model()
assert model == os.path.join(site, "reefgen", "models", "reef-256.pt"), model
for f in ("__init__.pyi", "py.typed"):
    assert os.path.isfile(os.path.join(site, "reefgen", f)), f"{f} not installed"
heights, labels = reefgen.generate("young-volcano", size=64)
assert heights.shape == (64, 64), heights.shape
if hasattr(reefgen, "infer"):
    try:
        h = reefgen.infer(labels, size=64)
    except reefgen.Error as e:
        if "LibTorch half" in str(e):
            print("note: a torch-free build: reefgen.infer is not there"); sys.exit(0)
        raise
    assert h.shape == (64, 64) and h.max() > 0, (h.shape, h.max())
print("ok: pip-installed reefgen", reefgen.__file__)
PY
