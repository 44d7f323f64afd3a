#!/usr/bin/env bash
# Installs the Debian packages ShapeSLAM needs to build, test and benchmark, and only those
# that are missing: on a machine that has them all it does nothing. Uses sudo when not root.
set -euo pipefail

PACKAGES=(
  cmake ninja-build g++ make pkg-config zlib1g-dev
  libmrpt-dev mrpt-apps mrpt-common          # MRPT 2.5.8: libraries, icp-slam & co, sample logs
  libceres-dev libeigen3-dev libopencv-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  python3-matplotlib                         # bench/run_all plots
)

missing=()
for package in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$package" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$package")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all ${#PACKAGES[@]} packages are installed"
else
  echo "setup: installing ${missing[*]}"
  SUDO=""
  if [ "$(id -u)" -ne 0 ]; then
    command -v sudo >/dev/null || { echo "setup: need root or sudo to install packages" >&2; exit 1; }
    SUDO="sudo"
  fi
  export DEBIAN_FRONTEND=noninteractive
  $SUDO apt-get update -qq
  $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
  echo "setup: done"
fi

mrpt_version=$(dpkg-query -W -f='${Version}' libmrpt-dev 2>/dev/null || true)
case "$mrpt_version" in
  *2.5.8*) ;;
  *) echo "setup: warning: libmrpt-dev is '$mrpt_version', ShapeSLAM is tested with MRPT 2.5.8" >&2 ;;
esac
