#!/usr/bin/env bash
# Builds the Debian packages sitepose and sitepose-dev (CPack, see
# cmake/SiteposePackaging.cmake) from the release build tree.
# Usage: tools/package.sh [OUT_DIR]   (default build/package)
# Prints the paths of the .deb files. Install on the target machine with
#   apt install ./sitepose_<version>_<arch>.deb
set -euo pipefail
cd "$(dirname "$0")/.."
build_dir=${SITEPOSE_BUILD_DIR:-build/release}
out_dir=${1:-build/package}
# The two commands (siteposed pulls in the detector plugins and the C++ LCM
# types) and the C, Python and Java LCM bindings of sitepose-dev.
bash tools/build.sh --target sitepose siteposed sitepose_lcm_bindings_c sitepose_lcm_bindings_python \
  sitepose_lcm_bindings_java
rm -f "$out_dir"/*.deb
cpack -G DEB --config "$build_dir/CPackConfig.cmake" -B "$out_dir" > "$out_dir.log" 2>&1 || {
  cat "$out_dir.log" >&2
  exit 1
}
ls -1 "$out_dir"/*.deb
