#!/usr/bin/env bash
# The studio under a burst of inference requests: N threads each POST one
# 4096² PNG (73 KB, a painted island) to /api/infer at once; prints wall time,
# the answers' status codes and the server's peak RSS (VmHWM). The bound:
# at most two decoded sketches held at once (studio/src/server.cpp,
# kStudioDecodeSlots); superseded requests are answered 409 without decoding.
#   bash scripts/bench-studio-burst.sh [N=32] [PORT=8765]
set -euo pipefail
cd "$(dirname "$0")/.."
n=${1:-32}; port=${2:-8765}
[ -x build/cli/reefgen-torch ] || bash scripts/build.sh >&2
source scripts/cpu-line.sh
cpu_line build/cli/reefgen
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
/usr/bin/python3 - build/cli/reefgen "$n" "$port" "$out" <<'PY'
import sys, time, threading, subprocess, urllib.request, urllib.error
import numpy as np, cv2
B, n, port, out = sys.argv[1], int(sys.argv[2]), sys.argv[3], sys.argv[4]
img = np.zeros((4096, 4096, 3), np.uint8); img[:] = (255, 120, 0)
cv2.circle(img, (2048, 2048), 900, (0, 200, 0), -1)
png = cv2.imencode('.png', img)[1].tobytes()
p = subprocess.Popen([B, '-q', 'studio', '--port', port, '--max-side', '4096', '--out', out + '/exports'],
                     stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
try:
    for _ in range(150):
        try:
            urllib.request.urlopen('http://127.0.0.1:%s/api/info' % port, timeout=1); break
        except Exception:
            time.sleep(0.2)
    codes = []
    def post():
        r = urllib.request.Request('http://127.0.0.1:%s/api/infer' % port, data=png, headers={'Content-Type': 'image/png'})
        try: codes.append(urllib.request.urlopen(r, timeout=600).status)
        except urllib.error.HTTPError as e: codes.append(e.code)
    t0 = time.time()
    ts = [threading.Thread(target=post) for _ in range(n)]
    [t.start() for t in ts]; [t.join() for t in ts]
    hwm = [l for l in open('/proc/%d/status' % p.pid) if l.startswith('VmHWM')][0].split()[1]
    print('%d parallel 4096² PNGs (%d bytes each): %.1f s, answers %s, server peak RSS %.2f GB'
          % (n, len(png), time.time() - t0, {c: codes.count(c) for c in sorted(set(codes))}, int(hwm) / 2**20))
finally:
    p.terminate(); p.wait()
PY
