#!/usr/bin/env bash
# The AddressSanitizer + UndefinedBehaviorSanitizer part of the tests
# (CMakePresets.json preset asan): configures build/asan, builds only the
# test targets the build preset names and runs the tests labelled asan.
# tools/test.sh runs it after the release tests; extra arguments go to ctest.
set -euo pipefail
cd "$(dirname "$0")/.."
# Paths relative to the checkout let ccache reuse objects across clones.
export CCACHE_BASEDIR="$PWD"
jobs=${SITEPOSE_JOBS:-2}
if [[ ! -f build/asan/build.ninja ]]; then
  cmake --preset asan
fi
cmake --build --preset asan -j "$jobs"
ctest --preset asan -j "$jobs" "$@"
