#!/usr/bin/env bash
# lintian on every .deb in PACKAGE_DIR: fails on any error (E:), lists the
# warnings. Exit 77 (skipped) when lintian is not installed.
# Usage: lintian_deb.sh PACKAGE_DIR
set -euo pipefail
shopt -s nullglob
debs=("$1"/*.deb)
((${#debs[@]} > 0)) || { echo "FAIL: no .deb in $1" >&2; exit 1; }
if ! command -v lintian > /dev/null; then
  echo "SKIP: lintian is not installed (tools/install-deps.sh installs it)" >&2
  exit 77
fi
# Root runs lintian too (CI does); its only complaint about that is a notice.
out=$(lintian --allow-root --no-tag-display-limit "${debs[@]}" 2>&1) || true
printf '%s\n' "$out"
if grep -q '^E: ' <<< "$out"; then
  echo "FAIL: lintian reports errors" >&2
  exit 1
fi
echo "lintian: no errors ($(grep -c '^W: ' <<< "$out" || true) warnings)"
