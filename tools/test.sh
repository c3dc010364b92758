#!/usr/bin/env bash
# Command (2) of the README: installs what is missing, builds if needed and
# runs every test (unit, integration, regression) with ctest.
# Extra arguments go to ctest, e.g. tools/test.sh -L unit
# Sweeps (ctest label sweep, minutes each) are left out unless
# SITEPOSE_SWEEPS=1, e.g. SITEPOSE_SWEEPS=1 tools/test.sh -L sweep
# Without extra arguments, clang-tidy then checks the sources the last
# commit changed (tools/lint.sh tidy; SITEPOSE_TIDY=0 skips it), and the
# tests labelled asan run again under AddressSanitizer +
# UndefinedBehaviorSanitizer (tools/asan.sh, build/asan; SITEPOSE_ASAN=0
# skips that).
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/install-deps.sh
bash tools/build.sh
build_dir=${SITEPOSE_BUILD_DIR:-build/release}
labels=(-LE sweep)
if [[ "${SITEPOSE_SWEEPS:-0}" == 1 ]]; then labels=(); fi
ctest --test-dir "$build_dir" --output-on-failure -j "${SITEPOSE_JOBS:-2}" "${labels[@]}" "$@"
if [[ $# -eq 0 && "${SITEPOSE_TIDY:-1}" != 0 ]]; then
  SITEPOSE_BUILD_DIR=$build_dir bash tools/lint.sh tidy
fi
if [[ $# -eq 0 && "${SITEPOSE_ASAN:-1}" != 0 ]]; then
  bash tools/asan.sh
fi
