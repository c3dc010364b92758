#!/usr/bin/env bash
# Fails when `systemd-analyze security --offline=yes` scores UNIT above
# MAX_EXPOSURE (the scale runs from 0, locked down, to 10; "OK" is <= 4.9,
# the project keeps siteposed.service at <= 2.5).
# Usage: unit_security.sh UNIT [MAX_EXPOSURE]
set -euo pipefail
unit=$1
max_exposure=${2:-2.5}
report=$(systemd-analyze security --offline=yes "$unit" 2>&1) || {
  echo "FAIL: systemd-analyze security failed: $report" >&2
  exit 1
}
score=$(grep 'Overall exposure level' <<< "$report" | sed -E 's/.*: ([0-9.]+).*/\1/')
if [[ -z $score ]]; then
  echo "FAIL: no score in: $report" >&2
  exit 1
fi
echo "systemd-analyze security $(basename "$unit"): $score (at most $max_exposure)"
if ! awk -v s="$score" -v m="$max_exposure" 'BEGIN { exit !(s <= m) }'; then
  grep -E '^✗' <<< "$report" >&2 || true
  echo "FAIL: exposure $score above $max_exposure" >&2
  exit 1
fi
