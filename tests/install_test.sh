#!/usr/bin/env bash
# `cmake --install` gives a working reefgen: the programs in PREFIX/bin, the
# shipped model and the studio page found in PREFIX/share/reefgen (not in
# the source or build tree), a network command and a generator command run.
set -uo pipefail
BUILD="$1"
P=$(mktemp -d); trap 'rm -rf "$P"' EXIT
cmake --install "$BUILD" --prefix "$P" >/dev/null || { echo "FAIL: cmake --install"; exit 1; }
fail=0
for f in bin/reefgen bin/reefgen-torch share/reefgen/models/reef-256.pt share/reefgen/studio/index.html; do
  [ -s "$P/$f" ] || { echo "FAIL: $f not installed"; fail=1; }
done
cd "$P"
"$P/bin/reefgen" -q model info > info.json 2>err || { echo "FAIL: model info: $(cat err)"; fail=1; }
grep -q "$P/share/reefgen/models/reef-256.pt" info.json || { echo "FAIL: the installed model is not the one used: $(head -c 300 info.json)"; fail=1; }
"$P/bin/reefgen" -q generate --preset atoll --size 48 -o "$P/a" >/dev/null || { echo "FAIL: generate"; fail=1; }
# The Python package in Debian's layout (PREFIX/lib/python3/dist-packages).
if ls "$P"/lib/python3/dist-packages/reefgen/_reefgen*.so >/dev/null 2>&1; then
  (cd / && PYTHONPATH="$P/lib/python3/dist-packages" /usr/bin/python3 -c \
    "import reefgen; h, l = reefgen.generate('atoll', size=48); assert h.shape == (48, 48)") 2>err ||
    { echo "FAIL: import reefgen from the install: $(tail -1 err)"; fail=1; }
fi
# reefgen.infer from the install: the installed model, not the source tree's.
if ls "$P"/lib/python3/dist-packages/reefgen/_reefgen_infer*.so >/dev/null 2>&1; then
  (cd / && PYTHONPATH="$P/lib/python3/dist-packages" /usr/bin/python3 -c "
import reefgen
assert reefgen.default_model() == '$P/share/reefgen/models/reef-256.pt', reefgen.default_model()
_, l = reefgen.generate('young-volcano', size=64)
h = reefgen.infer(l, size=64)
assert h.shape == (64, 64) and h.max() > 0, (h.shape, h.max())") 2>err ||
    { echo "FAIL: reefgen.infer from the install: $(tail -1 err)"; fail=1; }
fi
exit $fail
