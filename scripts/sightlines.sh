#!/usr/bin/env bash
# The sightline table of docs/sightlines.md: `check --sightlines N` (default 5000 rays from each cell) on
# every bundled sample, every shared level (../shared/levels, the Doom maps under --tags doom)
# and a generated 300-room building, as one Markdown table: cells, the PVS's pairs of
# different cells, the share some ray confirmed, and the sightlines the PVS misses (must be 0).
# Release build; not a test (minutes). Usage: [SHARED_LEVELS=DIR] scripts/sightlines.sh [RAYS]
set -euo pipefail
cd "$(dirname "$0")/.."
rays="${1:-5000}"
cargo build --release --quiet
bin=target/release/portcullis
# The shared third-party levels: beside the project, or where SHARED_LEVELS says.
shared="${SHARED_LEVELS:-../shared/levels}"
if [ ! -d "$shared/freedoom" ]; then
  echo "error: no shared levels in $shared; set SHARED_LEVELS to the folder holding freedoom/, godot/, ..." >&2
  exit 2
fi
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
"$bin" gen --rooms 300 --seed 1 -o "$tmp/building_300.glb" >/dev/null 2>&1

levels=()
for f in samples/*.gltf samples/*.obj samples/*.map; do levels+=("$f|"); done
for f in "$shared"/freedoom/*.glb; do
  case "$f" in
    *_godot.glb) levels+=("$f|") ;;
    *) levels+=("$f|doom") ;;
  esac
done
for f in "$shared"/godot/*.glb "$shared"/godot/*.obj "$shared"/lportal/*.glb "$shared"/sauerbraten/*.obj; do
  [ -e "$f" ] && levels+=("$f|")
done
for f in "$shared"/panda3d/*.glb; do
  [ -e "$f" ] && levels+=("$f|panda3d")
done
levels+=("$tmp/building_300.glb|")

echo "machine: $(nproc) cores, $(date -u '+%Y-%m-%d %H:%M UTC'), $rays rays from each cell"
echo
echo "| level | cells | PVS pairs | confirmed by rays | missed sightlines |"
echo "|---|---:|---:|---:|---:|"
for entry in "${levels[@]}"; do
  f="${entry%%|*}"
  preset="${entry##*|}"
  args=(check --sightlines "$rays" --format json)
  [ -n "$preset" ] && args+=(--tags "$preset")
  "$bin" "${args[@]}" "$f" >"$tmp/out.json" 2>/dev/null || true
  name="${f#"$shared"/}"
  name="${name#"$tmp"/}"
  [ -n "$preset" ] && name="$name (--tags $preset)"
  python3 - "$tmp/out.json" "$name" <<'EOF'
import json, re, sys
doc = json.load(open(sys.argv[1]))
f = doc["files"][0]
diags = f.get("diagnostics", [])
missed = sum(1 for d in diags if d["code"] == "PVS_MISSES_SIGHTLINE")
info = next((d["message"] for d in diags if d["code"] == "SIGHTLINES_CONFIRMED"), "")
m = re.search(r"each of (\d+) cells confirmed (\d+) of the PVS's (\d+) pairs .*?\(([\d.]+)%\)", info)
if m and m.group(1) == "0":
    print(f"| {sys.argv[2]} | 0 | - | no rooms tagged | {missed} |")
elif m:
    cells, conf, pairs, share = m.groups()
    print(f"| {sys.argv[2]} | {cells} | {pairs} | {conf} ({share}%) | {missed} |")
else:
    print(f"| {sys.argv[2]} | - | - | - | {missed} |")
EOF
done
