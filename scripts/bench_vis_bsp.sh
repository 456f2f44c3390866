#!/usr/bin/env bash
# `portcullis vis MAP.bsp` against ericw-tools vis, side by side (docs/performance.md): each map
# of ../shared/bsp vised by both from a fresh copy, alternated RUNS times, the wall time and peak
# memory of the whole process, and the median per tool. ericw-tools is GPL and not shipped here:
# build it in a scratch folder (docs/performance.md says how) and name its vis in $VIS.
#   VIS=~/ericw-tools/build/vis/vis scripts/bench_vis_bsp.sh [THREADS] [RUNS] [MAP...]
set -euo pipefail
cd "$(dirname "$0")/.."
threads="${1:-2}"
runs="${2:-3}"
shift $(($# < 2 ? $# : 2))
[ -x "${VIS:-}" ] || { echo "error: set VIS to ericw-tools' vis binary (docs/performance.md)" >&2; exit 2; }
bsp_dir="${BSP_DIR:-../shared/bsp}"
[ -d "$bsp_dir" ] || { echo "error: $bsp_dir is missing (../shared/bsp beside the clone)" >&2; exit 2; }
maps=("$@")
[ ${#maps[@]} -gt 0 ] || maps=(qbspfeatures light_general E1M1-edited-ents e3m4 retrojam1_ericw base1-test)
cargo build --release --quiet
target="${CARGO_TARGET_DIR:-target}"
case "$target" in /*) ;; *) target="$(pwd)/$target" ;; esac
exe="$target/release/portcullis"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
median() { sort -g | awk '{a[NR]=$1} END {print a[int((NR + 1) / 2)]}'; }
echo "machine: $(nproc) cores, $(date -u +%Y-%m-%d), -threads $threads, $runs runs, load $(cut -d' ' -f1-3 /proc/loadavg)"
echo "| map | ericw vis | portcullis vis | ratio | peak memory (vis / portcullis) |"
echo "|---|---|---|---|---|"
for m in "${maps[@]}"; do
  : > "$work/vis.t"; : > "$work/ours.t"
  for _ in $(seq "$runs"); do
    for tool in vis ours; do
      cp "$bsp_dir/$m.bsp" "$bsp_dir/$m.prt" "$work/"
      chmod u+w "$work/$m.bsp" "$work/$m.prt"
      if [ $tool = vis ]; then cmd=("$VIS" -threads "$threads" "$work/$m.bsp"); else cmd=("$exe" vis -threads "$threads" "$work/$m.bsp"); fi
      /usr/bin/time -f "%e %M" -o "$work/one" "${cmd[@]}" > /dev/null 2>&1
      cat "$work/one" >> "$work/$tool.t"
    done
  done
  v=$(cut -d' ' -f1 "$work/vis.t" | median); o=$(cut -d' ' -f1 "$work/ours.t" | median)
  vm=$(cut -d' ' -f2 "$work/vis.t" | median); om=$(cut -d' ' -f2 "$work/ours.t" | median)
  ratio=$(awk -v o="$o" -v v="$v" 'BEGIN { if (v > 0) printf "%.2f", o / v; else print "–" }')
  echo "| $m | $v s | $o s | $ratio | $((vm / 1024)) MB / $((om / 1024)) MB |"
done
