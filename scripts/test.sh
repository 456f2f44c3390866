#!/usr/bin/env bash
# The whole test suite, as the README gives it and .ci/run calls it.
# Sets up what the tests need (the npm Khronos glTF-Validator) and caches it in ignored folders,
# then runs formatting, lint and every test. Needs the Rust toolchain and Node (npm).
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

echo "== cargo fmt --check"
cargo fmt --all -- --check
echo "== cargo clippy"
cargo clippy --all-targets --locked -- -D warnings
echo "== cargo test"
cargo test --all-targets --locked
