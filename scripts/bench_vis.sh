#!/usr/bin/env bash
# The error-against-run-time table of README.md: per level and method, the run time, the
# visible pairs and the over-estimate against the sampled lower bound, on the Quake portal
# files of ../shared/prt and the bigger third-party levels. Release build; not a test.
#   scripts/bench_vis.sh [THREADS] [SAMPLES]
set -euo pipefail
cd "$(dirname "$0")/.."
threads="${1:-2}"
samples="${2:-2000}"
cargo build --release --quiet
exe=target/release/portcullis
prt_dir="${PRT_DIR:-../shared/prt}"
[ -d "$prt_dir" ] || prt_dir=/work/shared/prt
files=()
for n in qbspfeatures light_general e3m4 base1; do
  [ -f "$prt_dir/$n.prt" ] && files+=("$prt_dir/$n.prt")
done
echo "machine: $(nproc) cores, $(date -u +%Y-%m-%d), --threads $threads, --samples $samples"
first=1
for f in "${files[@]}" tests/fixtures/third_party/lportal_boxrooms.glb tests/fixtures/third_party/panda3d_culling.glb; do
  extra=()
  case "$f" in *panda3d*) extra=(--tags panda3d) ;; esac
  if [ $first = 1 ]; then
    "$exe" vis --report --threads "$threads" --samples "$samples" "${extra[@]}" "$f" 2>/dev/null
    first=0
  else
    "$exe" vis --report --threads "$threads" --samples "$samples" "${extra[@]}" "$f" 2>/dev/null | tail -n +3
  fi
done
# Peak memory of the full method on the biggest file.
big="${files[${#files[@]}-1]}"
/usr/bin/time -f "peak memory, full on $(basename "$big"): %M KB" "$exe" vis --threads "$threads" "$big" > /dev/null
