#!/usr/bin/env bash
# Command (1) of the README: installs dependencies, builds and runs
# `sitepose demo` (simulate a site, track it, print the accuracy).
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/install-deps.sh
# Only what the demo needs: the sitepose command (tests are built by tools/test.sh).
bash tools/build.sh --target sitepose
exec "${SITEPOSE_BUILD_DIR:-build/release}/tools/sitepose/sitepose" demo "$@"
