#!/usr/bin/env bash
# End-to-end checks, part 4: a world past 8192² (its layers in tiles), the
# longest single run of the checks, on its own so the parts run side by side.
source "$(dirname "$0")/cli_lib.sh"
"$BIN" -q sketch random --size 768x385 --islands 6 --seed 3 -o "$T/w/sea.png" >/dev/null || bad "sketch random 768x385"
# Past 8192² the layers come in tiles on the GeoTIFF grid, with the world's
# scales in the sidecar and a VRT mosaic per float layer that GDAL opens.
# 8200×4111: just past 8192 across and 4096 down, so the tiles run both ways
# (3 × 2) on the fewest cells.
if "$BIN" -q world "$T/w/sea.png" --size 8200 --layers --geotiff -o "$T/w/wide" >/dev/null 2>"$T/err"; then
  "$PY" - "$T/w/wide.json" "$T/w/wide.layers" <<'PYEOF' && ok || bad "world --size 8200 --layers: tiles, scales or splats wrong"
import cv2, json, sys, os
j = json.load(open(sys.argv[1])); L = j["layers"]
assert j["size_px"] == [8200, 4111], j["size_px"]
assert L["tiles_per_axis"] == [3, 2] and len(L["layer_tiles"]) == 6, L["tiles_per_axis"]
assert L["scales"]["flow_area_m2"] > 1e5 and L["scales"]["wear_m"] > 0, L["scales"]
t = L["layer_tiles"][1]["files"]
a = cv2.imread(os.path.join(sys.argv[2], t["splat0"]), cv2.IMREAD_UNCHANGED).astype(int)
b = cv2.imread(os.path.join(sys.argv[2], t["splat1"]), cv2.IMREAD_UNCHANGED).astype(int)
assert a.shape == (2056, 2734, 4) and ((a.sum(2) + b.sum(2)) == 255).all()
PYEOF
  gdalinfo "$T/w/wide.layers/wide.flow.vrt" | grep -q "Size is 8200, 4111" && ok || bad "world layers: the flow VRT is not the whole world"
else bad "world --size 8200 --layers: $(cat "$T/err")"; fi

finish
