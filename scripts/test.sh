#!/usr/bin/env bash
# The whole test suite, as the README gives it and .ci/run calls it.
# Sets up what the tests need (the npm Khronos glTF-Validator, Debian's chromium with the npm
# playwright-core for the browser tests, Pixar's usd-core in a Python venv for the `usd`
# feature, and Blender's bpy module in another for the add-on's tests) and caches them in
# ignored folders, then runs formatting, lint (with and without the feature) and every test
# with the feature on. Needs the Rust toolchain,
# Node (npm) and Python 3 built with a shared libpython (python3 -m venv, pip).
set -euo pipefail
cd "$(dirname "$0")/.."

# Khronos glTF-Validator (npm package, pinned by tools/gltf-validate/package-lock.json).
if command -v npm >/dev/null 2>&1; then
  if [ ! -d tools/gltf-validate/node_modules/gltf-validator ]; then
    echo "== installing the Khronos glTF-Validator (npm ci, cached in tools/gltf-validate/node_modules)"
    (cd tools/gltf-validate && npm ci --no-audit --no-fund --loglevel=error)
  fi
else
  echo "warning: npm not found; tests that run the glTF validator will fail under CI=true and skip otherwise" >&2
fi

# Browser tests (tests/viewer.rs): Debian's chromium, driven by playwright-core (npm, pinned by
# tools/browser-test/package-lock.json, cached in tools/browser-test/node_modules).
if [ ! -x /usr/bin/chromium ] && command -v apt-get >/dev/null 2>&1; then
  echo "== installing Debian's chromium for the browser tests"
  SUDO=""
  [ "$(id -u)" -ne 0 ] && command -v sudo >/dev/null 2>&1 && SUDO="sudo"
  $SUDO env DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends chromium >/dev/null \
    || { $SUDO apt-get update >/dev/null && $SUDO env DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends chromium >/dev/null; } \
    || echo "warning: could not install chromium; the browser tests fail under CI=true and skip otherwise" >&2
fi
if command -v npm >/dev/null 2>&1 && [ ! -d tools/browser-test/node_modules/playwright-core ]; then
  echo "== installing playwright-core (npm ci, cached in tools/browser-test/node_modules)"
  (cd tools/browser-test && npm ci --no-audit --no-fund --loglevel=error)
fi

# The JavaScript runtime and three.js plugin (js/portcullis-three): three from npm, pinned by
# js/portcullis-three/package-lock.json, cached in js/portcullis-three/node_modules.
if command -v npm >/dev/null 2>&1 && [ ! -d js/portcullis-three/node_modules ]; then
  echo "== installing three for js/portcullis-three (npm ci, cached in js/portcullis-three/node_modules)"
  (cd js/portcullis-three && npm ci --no-audit --no-fund --loglevel=error)
fi

# usd-core (PyPI, pinned; the same version as USD_CORE_VERSION in src/import/usd.rs), cached in
# .venv. The embedded interpreter finds it there (its fallback when neither --python-venv nor
# VIRTUAL_ENV is given), and pyo3 is configured against the venv's interpreter so the versions
# match.
USD_CORE="usd-core==26.11"
if ! .venv/bin/python -c "import importlib.metadata as m, sys; sys.exit(m.version('usd-core') != '${USD_CORE#usd-core==}')" 2>/dev/null; then
  echo "== installing $USD_CORE into .venv"
  python3 -m venv .venv
  .venv/bin/pip install --quiet --disable-pip-version-check "$USD_CORE"
fi
# Blender as a Python module (PyPI `bpy`, pinned; wheels for CPython 3.11 only) for the add-on's
# tests (tests/blender.rs), cached in .venv-blender.
BPY="bpy==4.5.15"
if ! .venv-blender/bin/python -c "import importlib.metadata as m, sys; sys.exit(m.version('bpy') != '${BPY#bpy==}')" 2>/dev/null; then
  PY311=$(command -v python3.11 || command -v python3)
  if "$PY311" -c 'import sys; sys.exit(sys.version_info[:2] != (3, 11))'; then
    echo "== installing $BPY into .venv-blender (Blender as a Python module, ~370 MB)"
    "$PY311" -m venv .venv-blender
    .venv-blender/bin/pip install --quiet --disable-pip-version-check "$BPY" \
      || echo "warning: could not install $BPY; the Blender tests fail under CI=true and skip otherwise" >&2
  else
    echo "warning: bpy needs CPython 3.11; the Blender tests fail under CI=true and skip otherwise" >&2
  fi
fi

export PYO3_PYTHON="$PWD/.venv/bin/python"
unset VIRTUAL_ENV
# A clean CI build gains nothing from incremental caches, which would take gigabytes of its disk.
if [ "${CI:-}" = "true" ]; then export CARGO_INCREMENTAL=0; fi

echo "== cargo fmt --check"
cargo fmt --all -- --check
# The converter and the engine side (crates/portcullis-runtime); the Bevy plugin comes last.
CRATES=(-p portcullis -p portcullis-runtime)
echo "== cargo clippy (default features, then --features usd)"
cargo clippy "${CRATES[@]}" --all-targets --locked -- -D warnings
cargo clippy "${CRATES[@]}" --all-targets --locked --features portcullis/usd -- -D warnings
echo "== cargo test --features usd"
cargo test "${CRATES[@]}" --all-targets --locked --features portcullis/usd
echo "== the docs: links resolve, examples (the crate's, the guide's) compile and run"
RUSTDOCFLAGS="-D warnings" cargo doc "${CRATES[@]}" --no-deps --lib --locked
cargo test "${CRATES[@]}" --doc --locked --features portcullis/usd
# The binary the cargo tests built, wherever cargo puts it (CARGO_TARGET_DIR may move it).
PORTCULLIS="$(cd "${CARGO_TARGET_DIR:-target}" && pwd)/debug/portcullis"
export PORTCULLIS
# Levels the JavaScript tests convert, reused by the Bevy plugin's tests (fresh each run).
PORTCULLIS_LEVEL_CACHE="$(cd "${CARGO_TARGET_DIR:-target}" && pwd)/level-cache"
rm -rf "$PORTCULLIS_LEVEL_CACHE"
export PORTCULLIS_LEVEL_CACHE
echo "== js/portcullis-three: the JavaScript runtime against portcullis cull, and the three.js plugin"
(cd js/portcullis-three && npm test)
echo "== the runtime's test vectors, checked against the JavaScript port (scripts/check_vectors.py)"
# The levels converted once, for the three implementations checked against the vectors.
VECTOR_LEVELS="$(cd "${CARGO_TARGET_DIR:-target}" && pwd)/vector-levels"
rm -rf "$VECTOR_LEVELS"
python3 scripts/check_vectors.py --levels "$VECTOR_LEVELS" node js/portcullis-three/cli.js
echo "== the runtime's test vectors, checked against the port written from the spec alone (tests/tools/spec_port.py)"
python3 scripts/check_vectors.py --levels "$VECTOR_LEVELS" python3 tests/tools/spec_port.py
# Bevy and its dependencies unoptimised (the bevy-test profile): a quarter of the build time.
echo "== crates/portcullis-bevy: clippy, the plugin in a headless Bevy app, its cull example against the vectors"
cargo clippy -p portcullis-bevy --all-targets --locked --profile bevy-test -- -D warnings
# (without --all-targets: the examples are built as programs, for the vector check below)
cargo test -p portcullis-bevy --locked --profile bevy-test
RUSTDOCFLAGS="-D warnings" cargo doc -p portcullis-bevy --no-deps --lib --locked --profile bevy-test
python3 scripts/check_vectors.py --levels "$VECTOR_LEVELS" "$(cd "${CARGO_TARGET_DIR:-target}" && pwd)/bevy-test/examples/cull"
