#!/usr/bin/env bash
# Runs one portcullis binary over every sample, broken sample, test fixture and shared level and
# writes everything it prints and writes (converted glTF/GLB/USDA, .prt, SVG, debug GLB, HTML
# view, check/inspect/vis output, exit codes) into one folder, so two builds can be compared
# byte for byte: a refactor must leave that folder unchanged.
#
#   scripts/compare_outputs.sh BIN OUT_DIR            write BIN's outputs to OUT_DIR
#   scripts/compare_outputs.sh --diff OLD_BIN NEW_BIN  write both and diff them (exit 1 if any differ)
#
# Shared levels and portal files are read from $SHARED (default ../shared, relative to the
# repository); the run names how many it found, so a missing folder cannot pass unnoticed.
set -u
here=$(cd "$(dirname "$0")/.." && pwd)

if [ "${1:-}" = "--diff" ]; then
    old=$(realpath "$2") new=$(realpath "$3")
    tmp=$(mktemp -d)
    "$0" "$old" "$tmp/old" & "$0" "$new" "$tmp/new"; wait
    if diff -r "$tmp/old" "$tmp/new" > "$tmp/diff.txt"; then
        echo "identical: $(find "$tmp/old" -type f | wc -l) files"
        rm -rf "$tmp"
    else
        head -50 "$tmp/diff.txt"
        echo "outputs differ (kept in $tmp)"
        exit 1
    fi
    exit 0
fi

bin=$(realpath "$1") out=$2
mkdir -p "$out"
out=$(realpath "$out")
cd "$here"
shared=${SHARED:-../shared}
echo "shared levels from $shared: $(ls "$shared"/levels/*/*.{glb,gltf,obj,map} 2> /dev/null | wc -l) files" >&2

# preset for a level, from its folder or name
preset() {
    case "$1" in
        *panda3d*) echo panda3d ;;
        *freedoom*) echo doom ;;
        *godot*) echo godot ;;
        *) echo "" ;;
    esac
}

run() { # name, command... : stdout, stderr (paths made relative) and exit code into $out/name.*
    local name=$1; shift
    (cd "$work" && "$@" > "$out/$name.stdout" 2> "$out/$name.stderr"; echo $? > "$out/$name.rc")
    sed -i "s#$work#WORK#g; s#$here#HERE#g" "$out/$name.stdout" "$out/$name.stderr"
}

levels=$(ls samples/*.gltf samples/*.obj samples/*.map; find samples/broken -type f \( -name '*.gltf' -o -name '*.glb' -o -name '*.obj' -o -name '*.map' \) | sort;
    find tests/fixtures -type f \( -name '*.gltf' -o -name '*.glb' -o -name '*.obj' -o -name '*.map' \) | sort;
    ls "$shared"/levels/*/*.{glb,gltf,obj,map} 2> /dev/null)
for level in $levels; do
    name=$(echo "${level/#$shared/shared}" | sed 's#/#_#g')
    src=$(realpath "$level")
    work=$(mktemp -d)
    # the level's own folder holds any portcullis.toml next to it
    cp -r "$(dirname "$src")"/. "$work/" 2> /dev/null
    file=$(basename "$src")
    p=$(preset "$level")
    tags=()
    [ -n "$p" ] && tags=(--tags "$p")
    run "$name.inspect" "$bin" inspect --format json "${tags[@]}" "$file"
    run "$name.check" "$bin" check --format json --color never "${tags[@]}" "$file"
    run "$name.convert" "$bin" convert --color never "${tags[@]}" "$file" -o o.glb --prt o.prt --svg o.svg --debug o.debug.glb
    run "$name.gltf" "$bin" convert --color never "${tags[@]}" "$file" -o o.gltf
    run "$name.usda" "$bin" convert --color never "${tags[@]}" "$file" -o o.usda
    run "$name.vis" "$bin" vis --color never "${tags[@]}" "$file"
    run "$name.view" "$bin" view "${tags[@]}" "$file" -o o.html
    for f in o.glb o.prt o.svg o.debug.glb o.gltf o.usda o.html; do
        [ -f "$work/$f" ] && cp "$work/$f" "$out/$name.$f"
    done
    rm -rf "$work"
done
for prt in "$shared"/prt/*.prt tests/fixtures/prt/*.prt; do
    [ -f "$prt" ] || continue
    name=$(echo "${prt/#$shared/shared}" | sed 's#/#_#g')
    work=$(dirname "$(realpath "$prt")")
    run "$name.vis" "$bin" vis --color never "$(basename "$prt")"
    run "$name.fast" "$bin" vis --color never --method fast "$(basename "$prt")"
done
