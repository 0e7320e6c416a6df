#!/usr/bin/env bash
# The Unity importer every Unity bundle carries (engines/unity/ReefgenImporter.cs):
# the bundle's copy is the source's; it compiles with Debian's C# compiler
# (mono-mcs) against Unity's API as the importer calls it
# (tests/unity/UnityApiStubs.cs: Unity's names and signatures); and every
# field its Bundle and Tile classes read is in the bundle's reefgen-unity.json
# with the JSON type JsonUtility needs, the files it names are there, of the
# sizes it expects. Exit 77 (skipped) without mcs.
#   bash tests/unity_importer_test.sh build/cli/reefgen
set -u
BIN=$(realpath "$1")
ROOT=$(cd "$(dirname "$0")/.." && pwd)
command -v mcs >/dev/null || { echo "SKIP: no mcs (apt-get install mono-mcs)"; exit 77; }
T=$(mktemp -d); trap 'rm -rf "$T"' EXIT
fail=0
bad() { echo "FAIL: $*"; fail=1; }
"$BIN" -q generate --preset atoll --size 65 --for unity -o "$T/a" >/dev/null || { echo "FAIL: generate --for unity"; exit 1; }
B="$T/a.unity"
cmp -s "$B/ReefgenImporter.cs" "$ROOT/engines/unity/ReefgenImporter.cs" || bad "the bundle's ReefgenImporter.cs is not the source's"
mcs -target:library -d:UNITY_EDITOR -nowarn:0649 -out:"$T/importer.dll" "$ROOT/tests/unity/UnityApiStubs.cs" \
  "$B/ReefgenImporter.cs" >"$T/mcs.log" 2>&1 || bad "the importer does not compile: $(cat "$T/mcs.log")"
# Editor-only: without UNITY_EDITOR (a player build) it compiles to nothing.
mcs -target:library -out:"$T/player.dll" "$B/ReefgenImporter.cs" >"$T/mcs2.log" 2>&1 \
  || bad "the importer breaks a player build: $(cat "$T/mcs2.log")"
/usr/bin/python3 - "$B" <<'PY' || fail=1
import json, os, re, sys
import cv2
b = sys.argv[1]
cs = open(os.path.join(b, "ReefgenImporter.cs"), encoding="utf-8").read()
j = json.load(open(os.path.join(b, "reefgen-unity.json")))
def fields(cls):
    body = cs[cs.index("public class " + cls):]
    body = body[:body.index("}")]
    return re.findall(r"public (\w+(?:\[\])?) (\w+);", body)
def check(obj, cls):
    ok = True
    for typ, name in fields(cls):
        if name not in obj:
            print("FAIL: %s.%s is not in reefgen-unity.json" % (cls, name)); ok = False; continue
        v = obj[name]
        want = {"string": str, "int": int, "float": (int, float), "string[]": list, "float[]": list, "Tile[]": list}[typ]
        if not isinstance(v, want) or (typ == "int" and isinstance(v, bool)):
            print("FAIL: %s.%s is %r, not %s" % (cls, name, v, typ)); ok = False
        if typ == "float[]" and not all(isinstance(x, (int, float)) for x in v): ok = False; print("FAIL: %s.%s" % (cls, name))
    return ok
ok = check(j, "Bundle") and all(check(t, "Tile") for t in j["tiles"])
assert len(fields("Bundle")) >= 8 and len(fields("Tile")) == 5, "the field parser found too little"
side, alpha = j["tile_side_px"], j["alphamap_px"]
assert j["engine"] == "unity" and len(j["layers"]) == 8 and len(j["layer_colours"]) == 24
for t in j["tiles"]:
    assert os.path.getsize(os.path.join(b, t["raw"])) == 2 * side * side, t
    for s in t["splat"]:
        img = cv2.imread(os.path.join(b, s), cv2.IMREAD_UNCHANGED)
        assert img is not None and img.shape == (alpha, alpha, 4), (s, None if img is None else img.shape)
    assert len(t["position_m"]) == 3
print("reefgen-unity.json: every field the importer reads, %d tile(s)" % len(j["tiles"]))
sys.exit(0 if ok else 1)
PY
[ $fail = 0 ] && echo "unity importer: ok"
exit $fail
