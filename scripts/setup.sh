#!/usr/bin/env bash
# Installs what is missing (Debian 12 packages), configures and builds varbo incrementally.
# Safe to re-run: installs nothing that is present; configures a new build folder, and reconfigures an existing one
# when BUILD_TYPE or VARBO_CMAKE_ARGS is given (else cmake's own checks rebuild what changed).
# Environment: BUILD_DIR (default build), BUILD_TYPE (default Release), VARBO_CMAKE_ARGS (extra cmake args, split
# at spaces: a value with spaces goes into a cache file given as -C FILE, or to cmake directly).
set -euo pipefail
cd "$(dirname "$0")/.."

PACKAGES=(build-essential cmake ninja-build pkg-config
  libeigen3-dev libceres-dev libboost-dev libtbb-dev libfmt-dev doctest-dev libyaml-cpp-dev
  libnlopt-cxx-dev libnlopt-dev libcli11-dev nlohmann-json3-dev libsqlite3-dev libnanoflann-dev
  libbenchmark-dev
  locales                       # localedef: a decimal-comma locale for tests/study/test_locale.cpp
  iproute2                      # ss: tests/dashboard checks the listen backlog
  libcpp-httplib-dev chromium   # `varbo dashboard` and its browser test (headless)
  libpqxx-dev postgresql
  python3-dev python3-pybind11 pybind11-dev python3-numpy python3-pytest python3-optuna python3-yaml)

missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "varbo setup: installing ${missing[*]}"
  SUDO=""
  if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi

BUILD_DIR=${BUILD_DIR:-build}
# Given on an existing build folder, they were ignored in silence (`BUILD_TYPE=Debug ./test.sh` tested Release).
reconfigure=0
if [ -n "${BUILD_TYPE+x}" ] || [ -n "${VARBO_CMAKE_ARGS+x}" ]; then reconfigure=1; fi
BUILD_TYPE=${BUILD_TYPE:-Release}
read -r -a extra_args <<< "${VARBO_CMAKE_ARGS:-}"
if [ ! -f "$BUILD_DIR/build.ninja" ]; then
  cmake -S . -B "$BUILD_DIR" -G Ninja -DCMAKE_BUILD_TYPE="$BUILD_TYPE" ${extra_args[@]+"${extra_args[@]}"}
elif [ "$reconfigure" = 1 ]; then
  cmake -S . -B "$BUILD_DIR" -DCMAKE_BUILD_TYPE="$BUILD_TYPE" ${extra_args[@]+"${extra_args[@]}"}
fi
cmake --build "$BUILD_DIR" -j "$(nproc)"
