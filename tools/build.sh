#!/usr/bin/env bash
# Configures and builds sitepose in build/release (Ninja, -j2 by default).
# Usage: tools/build.sh [extra cmake --build args]
set -euo pipefail
cd "$(dirname "$0")/.."
build_dir=${SITEPOSE_BUILD_DIR:-build/release}
jobs=${SITEPOSE_JOBS:-2}
# Paths relative to the checkout let ccache reuse objects across clones.
export CCACHE_BASEDIR="$PWD"
if [[ ! -f "$build_dir/build.ninja" ]]; then
  cmake -S . -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE=Release
fi
cmake --build "$build_dir" -j "$jobs" "$@"
