#!/usr/bin/env bash
# Installs every build and test dependency of sitepose from Debian 12 packages.
# Idempotent and non-interactive; run as root (or with sudo) on a fresh machine.
# This list and the find_package/pkg_check_modules calls in CMake are the whole
# dependency list of the project.
set -euo pipefail

packages=(
  # toolchain
  build-essential cmake ninja-build pkg-config ccache git clang-format clang-tidy
  # numerics and vision
  libeigen3-dev libopencv-dev libceres-dev
  # config, logging, command line
  libyaml-cpp-dev libspdlog-dev libfmt-dev libcli11-dev nlohmann-json3-dev
  # tests and benchmarks
  libgtest-dev libgmock-dev libbenchmark-dev
  # geodesy
  libgeographiclib-dev
  # the EGM96 geoid grid (egm96_15.gtx) for heights above mean sea level
  proj-data
  # middleware and devices
  liblcm-dev liblcm-bin libaravis-dev aravis-tools libusb-1.0-0-dev
  # LCM's Java classes (lcm.jar) and a JDK: the Java LCM bindings are built
  # and their subscriber example run (examples/lcm)
  liblcm-java default-jdk-headless
  libsystemd-dev systemd libv4l-dev
  # test helpers: network namespaces, CAN log decoding, rendering the run
  # report (sitepose report) in a headless browser
  iproute2 python3 python3-can python3-numpy chromium
  # packaging: dpkg-shlibdeps (dpkg-dev) for Depends:, lintian checks the .deb
  dpkg-dev lintian
)

need_install=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    need_install+=("$p")
  fi
done

if ((${#need_install[@]} == 0)); then
  echo "install-deps: all ${#packages[@]} packages already installed"
  exit 0
fi

SUDO=""
if [[ $(id -u) -ne 0 ]]; then SUDO="sudo"; fi
export DEBIAN_FRONTEND=noninteractive
echo "install-deps: installing ${#need_install[@]} packages: ${need_install[*]}"
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${need_install[@]}"
echo "install-deps: done"
