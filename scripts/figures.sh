#!/usr/bin/env bash
# Every figure of README.md and docs/, each group with the one command that measures it
# (issue 53, item 13). Release build; not a test.
#   scripts/figures.sh              list the groups: where each is quoted, what it runs
#   scripts/figures.sh NAME         measure one group, printed as the page's table
# Counts (cells, portals, pairs, verdicts, rays) are the same on any machine; times and peak
# memory are this machine's (the pages say at which commit theirs were measured).
# Groups beside ericw-tools' qbsp and vis need both built outside this project and named by
# QBSP and VIS (how: docs/performance.md#qbsp-and-vis-ericw-tools); the brush maps are
# ericw-tools' testmaps, read from ../shared/levels/ericw-tools/testmaps or ERICW_TESTMAPS, the
# other shared levels from ../shared/levels or SHARED_LEVELS.
set -euo pipefail
cd "$(dirname "$0")/.."
maps="${ERICW_TESTMAPS:-../shared/levels/ericw-tools/testmaps}"
bin=target/release/portcullis
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

# The maps the brush-map tables measure, and the three of the whole-job table.
four=(E1M1-edited-ents.map LibreQuake/lq1/maps/src/e3/e3m4.map retrojam1_ericw.map qbspfeatures.map)
three=("${four[@]:0:3}")

need_maps() {
  [ -d "$maps" ] || { echo "error: no testmaps in $maps; set ERICW_TESTMAPS" >&2; exit 2; }
}
need_qbsp() {
  [ -x "${QBSP:-}" ] || { echo "error: set QBSP (and VIS) to ericw-tools' binaries: docs/performance.md#qbsp-and-vis-ericw-tools" >&2; exit 2; }
}
# wall seconds and peak MB of one command, as "S s, M MB"
timed() {
  /usr/bin/time -f "%e %M" -o "$tmp/time" "$@" > /dev/null 2>&1 || true
  read -r s kb < "$tmp/time"
  echo "$s s, $((kb / 1024)) MB"
}
# distinct cell pairs a converted .gltf's portals join (a directed portal each way is one pair)
cell_pairs() {
  python3 -c '
import json, sys
ext = json.load(open(sys.argv[1]))["extensions"]["PORTCULLIS_portals"]
pairs = {tuple(sorted(p["cells"])) for p in ext["portals"] if None not in p["cells"]}
print(len(pairs))' "$1"
}

figure="${1:-list}"
[ "$figure" = list ] || cargo build --release --quiet
case "$figure" in
  list)
    cat <<'EOF'
figure          quoted in                                   runs
real-levels     docs/performance.md, Convert on real levels  convert on the third-party levels: triangles, cells, portals, time, peak memory
brush-maps      docs/performance.md, README status           cargo bench --bench brush_maps on E1M1, e3m4, retrojam1, qbspfeatures; peak memory of check --sealed (and qbsp with QBSP)
cell-pairs      docs/performance.md, README status           convert --vis none: cell pairs of E1M1, e3m4, retrojam1 (and qbsp's portals with QBSP)
whole-job       docs/performance.md, README status           convert (full PVS) and --vis none, time and memory; QBSP VIS: cargo bench --bench pvs_vs_vis on the three maps
grid            docs/performance.md, A grid of rooms          cargo bench --bench brush_maps -- grid 1000 3000; the full PVS of each glTF grid (vis --report)
verdicts        docs/brush_maps.md tables, README status      PORTCULLIS_BLESS=1 cargo test --release --test brush_maps (writes the tables)
e1m1-vis        docs/brush_maps.md, Visibility on E1M1        vis --report --methods full on E1M1.map and (QBSP) on qbsp's E1M1.prt
pvs-vs-vis      docs/brush_maps.md, README status (QBSP VIS)  cargo bench --bench pvs_vs_vis on E1M1, qbspfeatures, retrojam1, qbsp_func_detail
runtime         docs/performance.md, The runtime; README      cargo bench --bench stages -- cull
cull            docs/performance.md, The runtime; README      scripts/bench_cull.sh
stages          docs/performance.md, Every stage; README      scripts/bench.sh
vis             docs/performance.md, Visibility; README       scripts/bench_vis.sh 2 2000
sightlines      docs/sightlines.md, README Sightlines         scripts/sightlines.sh
tolerance       README Numerics                               the tolerance inspect prints for panda3d's .glb (f32) and six-digit .obj
EOF
    ;;
  real-levels)
    t=tests/fixtures/third_party
    echo "| level | triangles | cells | portals | time | peak memory |"
    echo "|---|---|---|---|---|---|"
    for f in lportal_tutorial_simple.glb lportal_boxrooms.glb panda3d_culling.glb E1M2_godot.glb \
      MAP01_godot.glb occlusion_room.glb gi_zdm2.glb pandora.obj; do
      tags=()
      case "$f" in panda3d*) tags=(--tags panda3d) ;; esac
      tri=$("$bin" inspect --format json "${tags[@]}" "$t/$f" 2> /dev/null |
        python3 -c 'import json, sys; print(json.load(sys.stdin)["files"][0]["scene"]["triangles"])')
      counts=$("$bin" convert "${tags[@]}" "$t/$f" -o "$tmp/o.glb" 2>&1 | sed -n 's/.*: \([0-9]*\) cells, \([0-9]*\) portals$/\1 | \2/p')
      echo "| $f | $tri | $counts | $(timed "$bin" convert "${tags[@]}" "$t/$f" -o "$tmp/o.glb" | sed 's/, / | /') |"
    done
    ;;
  brush-maps)
    need_maps
    cargo bench --bench brush_maps -- "${four[@]}"
    echo
    echo "| map | check --sealed: time, peak memory | qbsp: time, peak memory |"
    echo "|---|---|---|"
    for m in "${four[@]}"; do
      q="(QBSP unset)"
      [ -x "${QBSP:-}" ] && q=$(timed "$QBSP" -noverbose "$maps/$m" "$tmp/out.bsp")
      echo "| $(basename "$m") | $(timed "$bin" check --sealed "$maps/$m") | $q |"
    done
    ;;
  cell-pairs)
    need_maps
    echo "| map | cells | directed portals | cell pairs | qbsp: leafs, portals (.prt) |"
    echo "|---|---|---|---|---|"
    for m in "${three[@]}"; do
      line=$("$bin" convert --vis none "$maps/$m" -o "$tmp/out.gltf" 2>&1 | tail -n 2 | head -n 1)
      c=$(echo "$line" | sed -n 's/.*: \([0-9]*\) cells, \([0-9]*\) portals$/\1 | \2/p')
      q="(QBSP unset)"
      if [ -x "${QBSP:-}" ]; then
        rm -f "$tmp/q.prt"
        "$QBSP" -noverbose "$maps/$m" "$tmp/q.bsp" > /dev/null 2>&1 || true
        q=$(awk 'NR == 1 { f = $1 } NR == 2 { l = $1 } (f == "PRT1" && NR == 3) || (f == "PRT2" && NR == 4) { print l ", " $1; exit }' "$tmp/q.prt")
      fi
      echo "| $(basename "$m") | $c | $(cell_pairs "$tmp/out.gltf") | $q |"
    done
    ;;
  whole-job)
    need_maps
    echo "| map | \`convert\` (full PVS) | \`convert --vis none\` |"
    echo "|---|---|---|"
    for m in "${three[@]}"; do
      echo "| $(basename "$m") | $(timed "$bin" convert "$maps/$m" -o "$tmp/o.glb") | $(timed "$bin" convert --vis none "$maps/$m" -o "$tmp/o.glb") |"
    done
    echo
    if [ -x "${QBSP:-}" ] && [ -x "${VIS:-}" ]; then
      cargo bench --bench pvs_vs_vis -- "${three[@]}"
    else
      echo "(QBSP and VIS unset: qbsp + vis and the PVS / LOS columns need them)"
    fi
    ;;
  grid)
    GRID_DIR="$tmp" cargo bench --bench brush_maps -- grid 1000 3000
    echo
    echo "| rooms | cell pairs (map, no doors) | full PVS (glTF, no doors): time, visible pairs, over the sampled lower bound |"
    echo "|---|---|---|"
    for n in 1000 3000; do
      "$bin" convert --vis none "$tmp/grid${n}_false.map" -o "$tmp/g.gltf" > /dev/null 2>&1
      pvs=$("$bin" vis --report --methods full --rays 0 "$tmp/grid${n}_false.gltf" 2> /dev/null |
        awk -F'|' 'NR == 3 { for (i = 7; i <= 10; i++) gsub(/^ +| +$/, "", $i); print $7 ", " $9 " pairs, " $10 }')
      echo "| $n | $(cell_pairs "$tmp/g.gltf") | $pvs |"
    done
    ;;
  verdicts)
    PORTCULLIS_BLESS=1 cargo test --release --test brush_maps -- ericw_testmaps --nocapture
    git --no-pager diff --stat -- docs/brush_maps.md
    ;;
  e1m1-vis)
    need_maps
    "$bin" vis --report --methods full --threads 2 --rays 0 "$maps/E1M1-edited-ents.map" 2> /dev/null
    if [ -x "${QBSP:-}" ]; then
      "$QBSP" -noverbose "$maps/E1M1-edited-ents.map" "$tmp/E1M1-edited-ents.bsp" > /dev/null 2>&1
      "$bin" vis --report --methods full --threads 2 "$tmp/E1M1-edited-ents.prt" 2> /dev/null | tail -n 1
    fi
    ;;
  pvs-vs-vis)
    need_maps
    need_qbsp
    cargo bench --bench pvs_vs_vis -- E1M1-edited-ents.map qbspfeatures.map retrojam1_ericw.map qbsp_func_detail.map
    ;;
  runtime) cargo bench --bench stages -- cull ;;
  cull) scripts/bench_cull.sh ;;
  stages) scripts/bench.sh ;;
  vis) scripts/bench_vis.sh 2 2000 ;;
  sightlines) scripts/sightlines.sh ;;
  tolerance)
    echo "| level | tolerance |"
    echo "|---|---|"
    for f in panda3d_culling.glb panda3d_culling.obj; do
      tags=()
      case "$f" in panda3d*) tags=(--tags panda3d) ;; esac
      t=$("$bin" inspect --format json "${tags[@]}" "tests/fixtures/third_party/$f" 2> /dev/null |
        python3 -c 'import json, sys; print("%.1e m" % json.load(sys.stdin)["files"][0]["tolerance"])')
      echo "| $f | $t |"
    done
    ;;
  *)
    echo "error: no figure \`$figure\`; \`scripts/figures.sh\` lists them" >&2
    exit 2
    ;;
esac
