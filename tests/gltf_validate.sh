#!/usr/bin/env bash
# Khronos' glTF validator (npm gltf-validator, pinned) on GLB files reefgen
# writes (floating islands, and a height-field grid mesh as infer writes it): zero errors and zero warnings. Skipped (exit 77) where Node.js/npm
# or the npm registry are not available, saying so.
set -u
BIN="$1"; CACHE="$2"
command -v node >/dev/null && command -v npm >/dev/null || { echo "SKIP: node/npm not installed"; exit 77; }
if [ ! -f "$CACHE/node_modules/gltf-validator/package.json" ]; then
  # Installed beside and moved into place whole (an interrupted install leaves
  # nothing half-done); bounded, so a slow or unreachable registry cannot hold CI up.
  tmp="$CACHE.tmp.$$"; rm -rf "$tmp" "$CACHE"; mkdir -p "$tmp"
  (cd "$tmp" && timeout 180 npm install --silent --no-audit --no-fund gltf-validator@2.0.0-dev.3.10 >/dev/null 2>&1) ||
    { rm -rf "$tmp"; echo "SKIP: npm could not install gltf-validator (no registry?)"; exit 77; }
  mv "$tmp" "$CACHE"
fi
T=$(mktemp -d); trap 'rm -rf "$T"' EXIT
PAINT="$(dirname "$0")/../docs/examples/floating-painting.png"
"$BIN" -q floating --painting "$PAINT" -o "$T/default.glb" >/dev/null || { echo "FAIL: floating"; exit 1; }
"$BIN" -q floating --painting "$PAINT" --preset spire -o "$T/spire.glb" >/dev/null || { echo "FAIL: floating spire"; exit 1; }
"$BIN" -q terrain wilbur --seed 2 --size 64 -o "$T/w" --mesh glb >/dev/null && "$BIN" -q floating --height "$T/w.height.exr" -o "$T/terrain.glb" >/dev/null ||
  { echo "FAIL: floating --height"; exit 1; }
# The Blender bundle's GLB: its colour and normal textures inside the binary chunk.
"$BIN" -q generate --preset young-volcano --size 65 -o "$T/b/isl" --for blender >/dev/null && cp "$T/b/isl.blender/isl.glb" "$T/textured.glb" ||
  { echo "FAIL: generate --for blender"; exit 1; }
cat > "$T/validate.js" <<'JS'
const v = require(process.argv[2] + '/node_modules/gltf-validator');
const fs = require('fs');
(async () => {
  let bad = 0;
  for (const f of process.argv.slice(3)) {
    const r = await v.validateBytes(new Uint8Array(fs.readFileSync(f)));
    const n = r.issues.numErrors + r.issues.numWarnings;
    console.log(`${f}: ${r.issues.numErrors} errors, ${r.issues.numWarnings} warnings`);
    for (const m of r.issues.messages.slice(0, 5)) console.log(`  ${m.code}: ${m.message} ${m.pointer || ''}`);
    if (n) bad++;
  }
  process.exit(bad ? 1 : 0);
})();
JS
node "$T/validate.js" "$(cd "$CACHE" && pwd)" "$T"/*.glb
