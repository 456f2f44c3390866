#!/usr/bin/env bash
# `cull` at fly-through scale (docs/performance.md, "Runtime"): N cameras (default 100 000) at
# random points of random cells of MAP01, random directions, traced by `portcullis cull` with
# each output format; prints cameras per second and the peak memory (GNU time's max RSS).
# Release build; not a test. Usage: scripts/bench_cull.sh [N]
set -euo pipefail
cd "$(dirname "$0")/.."
n="${1:-100000}"
cargo build --release --quiet
bin=target/release/portcullis
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
"$bin" convert tests/fixtures/third_party/MAP01_godot.glb -o "$tmp/map01.glb" 2>/dev/null
python3 - "$tmp/map01.glb" "$n" > "$tmp/cameras.jsonl" <<'PY'
import json, math, random, struct, sys
data = open(sys.argv[1], "rb").read()
size = struct.unpack("<I", data[12:16])[0]
cells = json.loads(data[20:20 + size])["extensions"]["PORTCULLIS_portals"]["cells"]
rng = random.Random(1)
out = []
while len(out) < int(sys.argv[2]):
    c = rng.choice(cells)
    lo, hi = c["bounds"]["min"], c["bounds"]["max"]
    p = [rng.uniform(a, b) for a, b in zip(lo, hi)]
    if any(q[0] * p[0] + q[1] * p[1] + q[2] * p[2] - q[3] > -0.05 for q in c["planes"]):
        continue
    a = rng.uniform(0, 2 * math.pi)
    out.append(json.dumps({"eye": p, "look": [math.cos(a), rng.uniform(-0.3, 0.3), math.sin(a)],
                           "fov_y": 75, "aspect": 16 / 9, "near": 0.05}))
print("\n".join(out))
PY
echo "machine: $(nproc) cores, $(date -u '+%Y-%m-%d %H:%M UTC'); MAP01, $n cameras"
echo
echo "| format | seconds | cameras/s | peak memory |"
echo "|---|---:|---:|---:|"
for fmt in jsonl json human; do
  /usr/bin/time -f "%e %M" -o "$tmp/time" "$bin" cull "$tmp/map01.glb" --cameras "$tmp/cameras.jsonl" \
    --format "$fmt" > /dev/null
  read -r secs kb < "$tmp/time"
  python3 -c "import sys; s, kb, n = float(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3]); print(f'| {sys.argv[4]} | {s:.1f} | {n / s:,.0f} | {kb / 1024:.0f} MB |')" "$secs" "$kb" "$n" "$fmt"
done
