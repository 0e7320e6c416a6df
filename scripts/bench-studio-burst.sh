#!/usr/bin/env bash
# The studio under a burst of inference requests: N threads each POST one
# 4096² PNG (73 KB, a painted island) to /api/infer at once; prints wall time,
# the answers' status codes and the server's peak RSS (VmHWM). The bound:
# at most two decoded sketches held at once (studio/src/server.cpp,
# kStudioDecodeSlots); superseded requests are answered 409 without decoding.
# --huge: N requests to each image route (/api/infer, /api/layers,
# /api/export) at once, each a 2.6 MB PNG whose header declares 30000²
# (2.7 GB decoded); all must be refused from the header and the RSS stay low.
#   bash scripts/bench-studio-burst.sh [N=32] [PORT=8765] [--huge]
set -euo pipefail
cd "$(dirname "$0")/.."
n=${1:-32}; port=${2:-8765}; mode=${3:-}
[ -x build/cli/reefgen-torch ] || bash scripts/build.sh >&2
source scripts/cpu-line.sh
cpu_line build/cli/reefgen
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
/usr/bin/python3 - build/cli/reefgen "$n" "$port" "$out" "$mode" <<'PY'
import sys, time, threading, subprocess, urllib.request, urllib.error, struct, zlib, base64, json
import numpy as np, cv2
B, n, port, out, mode = sys.argv[1], int(sys.argv[2]), sys.argv[3], sys.argv[4], sys.argv[5]
img = np.zeros((4096, 4096, 3), np.uint8); img[:] = (255, 120, 0)
cv2.circle(img, (2048, 2048), 900, (0, 200, 0), -1)
png = cv2.imencode('.png', img)[1].tobytes()
routes = [('/api/infer', png, 'image/png')]
if mode == '--huge':
    chunk = lambda t, d: struct.pack('>I', len(d)) + t + d + struct.pack('>I', zlib.crc32(t + d))
    png = (b'\x89PNG\r\n\x1a\n' + chunk(b'IHDR', struct.pack('>IIBBBBB', 30000, 30000, 8, 2, 0, 0, 0))
           + chunk(b'IDAT', bytes(2600000)) + chunk(b'IEND', b''))
    body = json.dumps({'sketch_png': base64.b64encode(png).decode()}).encode()
    routes = [('/api/infer', png, 'image/png'), ('/api/layers?view=flow', body, 'application/json'),
              ('/api/export?format=exr&name=huge', body, 'application/json')]
p = subprocess.Popen([B, '-q', 'studio', '--port', port, '--max-side', '4096', '--out', out + '/exports'],
                     stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
try:
    for _ in range(150):
        try:
            urllib.request.urlopen('http://127.0.0.1:%s/api/info' % port, timeout=1); break
        except Exception:
            time.sleep(0.2)
    codes = []
    def post(route):
        path, data, ctype = route
        r = urllib.request.Request('http://127.0.0.1:%s%s' % (port, path), data=data, headers={'Content-Type': ctype})
        try: codes.append(urllib.request.urlopen(r, timeout=600).status)
        except urllib.error.HTTPError as e: codes.append(e.code)
    t0 = time.time()
    ts = [threading.Thread(target=post, args=(r,)) for r in routes for _ in range(n)]
    [t.start() for t in ts]; [t.join() for t in ts]
    hwm = [l for l in open('/proc/%d/status' % p.pid) if l.startswith('VmHWM')][0].split()[1]
    alive = urllib.request.urlopen('http://127.0.0.1:%s/api/info' % port, timeout=10).status
    what = '30000²-declaring PNGs to %d routes' % len(routes) if mode == '--huge' else '4096² PNGs'
    print('%d parallel %s (%d bytes each): %.1f s, answers %s, server peak RSS %.2f GB, then /api/info %d'
          % (n * len(routes), what, len(png), time.time() - t0, {c: codes.count(c) for c in sorted(set(codes))},
             int(hwm) / 2**20, alive))
finally:
    p.terminate(); p.wait()
PY
