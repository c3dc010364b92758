#!/usr/bin/env bash
# Runs one libFuzzer harness (tests/fuzz/fuzz_NAME.cpp) for SECONDS:
#   tools/fuzz.sh NAME SECONDS [extra libFuzzer flags]
#   tools/fuzz.sh --list
# Builds build/fuzz with clang-14 (ASan + UBSan + libFuzzer; Debian clang-14
# and libclang-rt-14-dev), only the harness and what it links. New inputs
# go to build/fuzz/corpus/NAME (the committed seeds in tests/fuzz/corpus/NAME
# are read, never written); a crash is saved as build/fuzz/artifacts/NAME-*
# and reproduces with build/fuzz/tests/fuzz/fuzz_NAME FILE, or through the
# gcc build with build/release/tests/fuzz/fuzz_replay_NAME FILE. Copy an input
# worth keeping (a fixed crash, a new shape) into tests/fuzz/corpus/NAME:
# ctest replays every file there (Fuzz.NAME). Runs nice'd on one core.
set -euo pipefail
cd "$(dirname "$0")/.."
if [[ "${1:-}" == --list || $# -lt 2 ]]; then
  echo "usage: tools/fuzz.sh NAME SECONDS [libFuzzer flags]; harnesses:" >&2
  ls tests/fuzz/corpus >&2
  [[ "${1:-}" == --list ]] && exit 0 || exit 2
fi
name=$1 seconds=$2
shift 2
if [[ ! -d tests/fuzz/corpus/$name ]]; then
  echo "tools/fuzz.sh: no harness '$name' (tests/fuzz/corpus/$name is missing)" >&2
  exit 2
fi
build=build/fuzz
export CCACHE_BASEDIR="$PWD"
if [[ ! -f $build/build.ninja ]]; then
  flags="-fsanitize=fuzzer-no-link,address,undefined -fno-sanitize-recover=all -fno-omit-frame-pointer"
  cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DCMAKE_C_COMPILER=clang-14 -DCMAKE_CXX_COMPILER=clang++-14 \
    -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g1" -DCMAKE_C_FLAGS_RELWITHDEBINFO="-O1 -g1" \
    -DCMAKE_CXX_FLAGS="$flags" -DCMAKE_C_FLAGS="$flags" \
    -DCMAKE_EXE_LINKER_FLAGS="-fsanitize=address,undefined" \
    -DCMAKE_SHARED_LINKER_FLAGS="-fsanitize=address,undefined" \
    -DCMAKE_MODULE_LINKER_FLAGS="-fsanitize=address,undefined" \
    -DSITEPOSE_FUZZ=ON -DSITEPOSE_WERROR=OFF > "$build.configure.log"
fi
cmake --build "$build" -j "${SITEPOSE_JOBS:-2}" --target "fuzz_$name"
mkdir -p "$build/corpus/$name" "$build/artifacts"
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-halt_on_error=1:print_stacktrace=1}
exec nice -n 10 "$build/tests/fuzz/fuzz_$name" -max_total_time="$seconds" -rss_limit_mb=2048 \
  -timeout=10 -print_final_stats=1 -artifact_prefix="$build/artifacts/$name-" "$@" \
  "$build/corpus/$name" "tests/fuzz/corpus/$name"
