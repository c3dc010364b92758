#!/usr/bin/env bash
# Extracts the built sitepose-dev .deb into a scratch root and uses it as an
# integrator would: the LCM bindings are where the README says, the C, C++
# and Java subscriber examples it ships build against its files alone (plus
# liblcm-dev / liblcm-java), and its Python package encodes and decodes a
# pose_t without any lcm module.
# Usage: check_dev_deb.sh PACKAGE_DIR
set -euo pipefail
pkg_dir=$1

fail() {
  echo "FAIL: $*" >&2
  exit 1
}

shopt -s nullglob
debs=("$pkg_dir"/sitepose-dev_*.deb)
((${#debs[@]} == 1)) || fail "expected one sitepose-dev_*.deb in $pkg_dir, found ${#debs[@]}"
root=$(mktemp -d /tmp/sitepose-dev-deb.XXXXXX)
trap 'rm -rf "$root"' EXIT
dpkg-deb -x "${debs[0]}" "$root"
echo "extracted $(basename "${debs[0]}")"

examples=$root/usr/share/doc/sitepose-dev/examples
for f in usr/include/sitepose/pose_t.hpp usr/include/sitepose/health_t.hpp \
  usr/include/sitepose/sitepose_pose_t.h usr/include/sitepose/sitepose_health_t.h \
  usr/include/sitepose/sitepose_gnss_fix_t.h usr/lib/libsitepose_lcmtypes.a \
  usr/lib/python3/dist-packages/sitepose/__init__.py usr/lib/python3/dist-packages/sitepose/pose_t.py \
  usr/share/java/sitepose-lcmtypes.jar; do
  [[ -f $root/$f ]] || fail "sitepose-dev lacks /$f"
done
for f in README.md pose_subscriber.c pose_subscriber.cpp pose_subscriber.py PoseSubscriber.java; do
  [[ -f $examples/$f ]] || fail "sitepose-dev lacks the example $f"
done
[[ -z $(find "$root" -name __pycache__) ]] || fail "sitepose-dev ships __pycache__"
echo "bindings and examples: present"

out=$root/build
mkdir -p "$out"
cc -Wall -Wextra -Werror -I"$root/usr/include" "$examples/pose_subscriber.c" -L"$root/usr/lib" \
  -lsitepose_lcmtypes -llcm -o "$out/pose_subscriber_c" || fail "the C example does not build"
g++ -std=c++17 -Wall -Wextra -Werror -I"$root/usr/include" "$examples/pose_subscriber.cpp" -llcm \
  -o "$out/pose_subscriber_cpp" || fail "the C++ example does not build"
javac -cp "/usr/share/java/lcm.jar:$root/usr/share/java/sitepose-lcmtypes.jar" -d "$out" \
  "$examples/PoseSubscriber.java" || fail "the Java example does not build"
echo "C, C++ and Java examples: built against the package"

PYTHONDONTWRITEBYTECODE=1 PYTHONPATH=$root/usr/lib/python3/dist-packages python3 - << 'PY' ||
import sys
from sitepose import pose_t, health_t, gnss_fix_t
assert "lcm" not in sys.modules, "the generated classes imported an lcm module"
m = pose_t()
m.seq, m.utime, m.state, m.position = 7, 1780000000123456, pose_t.STATE_OK, [1.5, -2.0, 0.25]
back = pose_t.decode(m.encode())
assert (back.seq, back.utime, back.state, list(back.position)) == (7, 1780000000123456, 0, [1.5, -2.0, 0.25])
print("python: pose_t round trip without an lcm module")
PY
  fail "the Python package does not round-trip a pose_t"
PYTHONDONTWRITEBYTECODE=1 PYTHONPATH=$root/usr/lib/python3/dist-packages \
  python3 "$examples/pose_subscriber.py" --help > /dev/null || fail "pose_subscriber.py does not start"
echo "PASS"
