#!/usr/bin/env bash
# Style and static checks of the project's C++ sources.
#   tools/lint.sh format [--all]      clang-format check (.clang-format) of the C++
#                                     files changed since LINT_BASE (default HEAD~1),
#                                     or of every tracked C++ file with --all
#   tools/lint.sh tidy [FILE.cpp...]  clang-tidy (.clang-tidy) on the given files,
#                                     default: the src/ and drivers/ files changed
#                                     since LINT_BASE (default HEAD~1)
#   tools/lint.sh tidy --all          clang-tidy on every file of src/ and drivers/
#                                     (about 15 min on 2 cores: not for CI)
# Needs a configured build (compile_commands.json) for tidy: SITEPOSE_BUILD_DIR,
# default build/release. Exit 0 clean, 1 findings, 2 bad usage.
set -euo pipefail
cd "$(dirname "$0")/.."
build_dir=${SITEPOSE_BUILD_DIR:-build/release}

cxx_files() { git ls-files -- '*.cpp' '*.hpp' '*.h' | grep -v '^tests/unit/detect/plugins/' || true; }

# Files changed since LINT_BASE among the given pathspecs; exit 0 with a
# message when there is no base to compare against (a shallow clone).
changed_files() {
  local base=${LINT_BASE:-HEAD~1}
  if ! git rev-parse -q --verify "$base^{commit}" >/dev/null; then
    echo "lint: no base commit $base (shallow clone?): nothing to compare against" >&2
    return 0
  fi
  git diff --name-only --diff-filter=AMR "$base" -- "$@" | grep -v '^tests/unit/detect/plugins/' || true
}

case "${1:-}" in
  format)
    if [[ "${2:-}" == "--all" ]]; then
      mapfile -t files < <(cxx_files)
    else
      mapfile -t files < <(changed_files '*.cpp' '*.hpp' '*.h')
    fi
    if ((${#files[@]} == 0)); then
      echo "lint format: no changed C++ file"
      exit 0
    fi
    clang-format --dry-run -Werror "${files[@]}"
    echo "lint format: ${#files[@]} files formatted as .clang-format says"
    ;;
  tidy)
    shift
    if [[ "${1:-}" == "--all" ]]; then
      mapfile -t files < <(git ls-files -- 'src/*.cpp' 'drivers/*.cpp')
    elif (($# > 0)); then
      files=("$@")
    else
      mapfile -t files < <(changed_files 'src/*.cpp' 'drivers/*.cpp')
    fi
    if ((${#files[@]} == 0)); then
      echo "lint tidy: no changed C++ source in src/ or drivers/"
      exit 0
    fi
    if [[ ! -f "$build_dir/compile_commands.json" ]]; then
      echo "lint tidy: $build_dir/compile_commands.json missing: configure the build first" >&2
      exit 2
    fi
    printf '%s\n' "${files[@]}" | xargs -P "${SITEPOSE_JOBS:-2}" -n 4 clang-tidy -p "$build_dir" --quiet
    echo "lint tidy: ${#files[@]} files clean"
    ;;
  *)
    sed -n '2,10p' "$0" | sed 's/^# \{0,1\}//'
    exit 2
    ;;
esac
