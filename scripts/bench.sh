#!/usr/bin/env bash
# The stage tables of docs/performance.md ("Every stage at scale"): every stage and PVS method per
# generated building size, the read+write floor, the whole-process time and the peak memory,
# as one Markdown table. Release build; not a test. Arguments go to `portcullis bench`:
#   scripts/bench.sh                          # 10, 100, 1 000 and 10 000 rooms, fastest of 3
#   scripts/bench.sh --rooms 10000 --methods none
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --quiet
echo "machine: $(nproc) cores, $(date -u '+%Y-%m-%d %H:%M UTC')"
if [ $# -eq 0 ]; then
  set -- --rooms 10,100,1000,10000 --runs 3
fi
exec target/release/portcullis bench "$@"
