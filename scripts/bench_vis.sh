#!/usr/bin/env bash
# The error-against-run-time table of docs/performance.md: per level and method, the run time, the
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
# The whole `vis` process with full (read, compute, print), as classic vis's times in
# ../shared/prt/README.md are: best of 5 wall-clock runs per thread count, and peak memory.
echo
echo "| file | threads | whole process, full (best of 5) | peak memory |"
echo "|---|---|---|---|"
for f in "${files[@]}"; do
  for t in "$threads" 1; do
    best=""
    for _ in 1 2 3 4 5; do
      /usr/bin/time -o /tmp/portcullis-bench-vis.$$ -f "%e %M" "$exe" vis --threads "$t" "$f" > /dev/null
      read -r wall kb < /tmp/portcullis-bench-vis.$$
      if [ -z "$best" ] || awk "BEGIN{exit !($wall < $best)}"; then best=$wall; mem=$kb; fi
    done
    echo "| $(basename "$f") | $t | $best s | $((mem / 1024)) MB |"
  done
done
rm -f /tmp/portcullis-bench-vis.$$
