#!/usr/bin/env bash
# Installs the built sitepose .deb into a scratch root (dpkg-deb -x) and
# checks it as a fresh machine would see it:
#   1. the control data: Depends from dpkg-shlibdeps, the conffile, scripts;
#   2. every file the installed unit names exists in the package, and the
#      detector host siteposed starts;
#   3. `systemd-analyze verify` on the installed unit prints nothing;
#   4. the unit's own ExecStartPre (`siteposed --check-config` on the
#      installed default config) exits 0 with the installed binaries, given
#      the replay data the config names - made by the installed `sitepose
#      sim` in a private mount namespace, so the host's /var/lib is untouched
#      (needs root for the namespace; exit 77 = skipped otherwise);
#   5. `systemd-analyze security --offline=yes` scores the installed unit
#      at most MAX_EXPOSURE.
# Usage: check_deb.sh PACKAGE_DIR SOURCE_DIR [MAX_EXPOSURE]
set -euo pipefail
pkg_dir=$1
src_dir=$2
max_exposure=${3:-2.5}

fail() {
  echo "FAIL: $*" >&2
  exit 1
}

shopt -s nullglob
debs=("$pkg_dir"/sitepose_*.deb)
((${#debs[@]} == 1)) || fail "expected one sitepose_*.deb in $pkg_dir, found ${#debs[@]}"
deb=${debs[0]}
root=$(mktemp -d /tmp/sitepose-deb-root.XXXXXX)
trap 'rm -rf "$root"' EXIT
dpkg-deb -x "$deb" "$root"
echo "extracted $(basename "$deb") into $root"

# 1. Control data.
depends=$(dpkg-deb -f "$deb" Depends)
echo "Depends: $depends"
for lib in libc6 libstdc++6 libopencv-core liblcm libyaml-cpp libsystemd0 libgeographiclib; do
  [[ $depends == *"$lib"* ]] || fail "Depends lacks $lib (shlibdeps): $depends"
done
control=$(mktemp -d /tmp/sitepose-deb-control.XXXXXX)
trap 'rm -rf "$root" "$control"' EXIT
dpkg-deb -e "$deb" "$control"
grep -qx /etc/sitepose/siteposed.yaml "$control/conffiles" ||
  fail "/etc/sitepose/siteposed.yaml is not a conffile"
for script in postinst prerm postrm; do
  [[ -x $control/$script ]] || fail "no executable $script"
done
grep -q -- "--check-config" "$control/postinst" || fail "postinst does not check the config"

# 2. Every file the unit names.
unit=$root/usr/lib/systemd/system/siteposed.service
[[ -f $unit ]] || fail "no unit at /usr/lib/systemd/system/siteposed.service"
cmp -s "$unit" "$src_dir/systemd/siteposed.service" || fail "installed unit differs from systemd/"
named=$(grep -E '^(ExecStart|ExecStartPre|ExecStartPost|ExecReload|ExecStop|Documentation)=' "$unit" |
  grep -oE '(file://)?/[A-Za-z0-9._/-]+' | sed 's|^file://||' | sort -u)
[[ -n $named ]] || fail "the unit names no files"
for path in $named; do
  [[ -e $root$path ]] || fail "the unit names $path, which the package does not install"
  echo "unit names $path: present"
done

# siteposed runs detector plugins in this child (dynamic.detector_isolation),
# found relative to /usr/bin/siteposed.
host=$root/usr/lib/sitepose/sitepose-detector-host
[[ -x $host ]] || fail "no executable /usr/lib/sitepose/sitepose-detector-host"
echo "detector host /usr/lib/sitepose/sitepose-detector-host: present"

# The unit with its paths moved into the scratch root.
mapped=$(mktemp -d /tmp/sitepose-unit.XXXXXX)
trap 'rm -rf "$root" "$control" "$mapped"' EXIT
sed -e "s#/usr/bin/#$root/usr/bin/#g" -e "s#/etc/sitepose/#$root/etc/sitepose/#g" "$unit" \
  > "$mapped/siteposed.service"

# 3. systemd-analyze verify: nothing at all on stdout or stderr.
verify=$(systemd-analyze verify "$mapped/siteposed.service" 2>&1) ||
  fail "systemd-analyze verify failed: $verify"
[[ -z $verify ]] || fail "systemd-analyze verify printed: $verify"
echo "systemd-analyze verify: no messages"

# 5. Hardening score.
bash "$(dirname "$0")/unit_security.sh" "$unit" "$max_exposure" || fail "unit hardening"

# 4. ExecStartPre, run as systemd would, on the installed files.
pre=$(grep -E '^ExecStartPre=' "$mapped/siteposed.service" | head -n 1 | sed 's/^ExecStartPre=//')
[[ $pre == *--check-config* ]] || fail "ExecStartPre does not check the config: $pre"
sequence=$(grep -E '^[[:space:]]+sequence:' "$root/etc/sitepose/siteposed.yaml" | head -n 1 |
  awk '{print $2}')
[[ $sequence == /var/lib/* ]] || fail "default replay sequence not under /var/lib: $sequence"
if ! unshare --mount --propagation private true 2> /dev/null; then
  echo "SKIP: check-config needs a private mount namespace (root): unshare --mount failed" >&2
  exit 77
fi
export ROOT=$root SEQUENCE=$sequence PRE=$pre
out=$(unshare --mount --propagation private bash -c '
  set -e
  mount -t tmpfs sitepose-test /var/lib
  mount -t tmpfs sitepose-test-logs /var/log
  # What StateDirectory= and LogsDirectory= create before ExecStartPre runs.
  mkdir -p /var/lib/siteposed /var/log/siteposed
  "$ROOT/usr/bin/sitepose" sim --scenario static --frames 4 --out "$SEQUENCE" > /dev/null
  $PRE' 2>&1) || fail "ExecStartPre failed on the installed default config: $out"
grep -q "configuration ok" <<< "$out" || fail "no 'configuration ok' from check-config: $out"
echo "ExecStartPre (siteposed --check-config on /etc/sitepose/siteposed.yaml): exit 0"
echo "PASS"
