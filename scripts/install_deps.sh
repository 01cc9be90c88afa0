#!/usr/bin/env bash
# Installs, from this Debian 12 machine's own packages, everything needed to
# build COLMAP 3.10 with colmap_ext and to run its tests, benchmark and GUI
# check; then fetches COLMAP 3.10's release tarball from Debian's source
# package (trixie suite; apt verifies its checksum, CMake checks it again)
# into third_party/. Does nothing that is already done.
set -euo pipefail
cd "$(dirname "$0")/.."

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi

PACKAGES=(
  build-essential cmake ninja-build ccache pkg-config patch dpkg-dev
  libeigen3-dev libceres-dev libsuitesparse-dev
  libboost-program-options-dev libboost-graph-dev libboost-system-dev
  libboost-filesystem-dev libboost-test-dev
  libcgal-dev qtbase5-dev libqt5opengl5-dev libflann-dev libfreeimage-dev
  libglew-dev libmetis-dev libsqlite3-dev libgoogle-glog-dev libgflags-dev
  libgtest-dev libigraph-dev
  python3 python3-numpy python3-matplotlib python3-pil time
  xvfb xauth libgl1-mesa-dri imagemagick
  slurmctld slurmd slurm-client munge
)

SRC_LIST=/etc/apt/sources.list.d/colmap-community-src.sources
TARBALL=third_party/colmap_3.10.orig.tar.gz

missing=()
for package in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$package" 2>/dev/null |
    grep -q "install ok installed" || missing+=("$package")
done

need_update=0
if [ ! -f "$SRC_LIST" ]; then
  $SUDO tee "$SRC_LIST" >/dev/null <<'SOURCES'
Types: deb-src
URIs: http://deb.debian.org/debian
Suites: trixie
Components: main
Signed-By: /usr/share/keyrings/debian-archive-keyring.gpg
SOURCES
  need_update=1
fi
if [ ${#missing[@]} -gt 0 ] || [ ! -f "$TARBALL" ]; then
  need_update=1
fi

export DEBIAN_FRONTEND=noninteractive
if [ "$need_update" -eq 1 ]; then
  $SUDO apt-get update -qq
fi
if [ ${#missing[@]} -gt 0 ]; then
  echo "Installing: ${missing[*]}"
  $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi

if [ ! -f "$TARBALL" ]; then
  rm -rf third_party/download
  mkdir -p third_party/download
  (cd third_party/download &&
   apt-get source --download-only --tar-only colmap=3.10-2)
  mv third_party/download/colmap_3.10.orig.tar.gz "$TARBALL"
  rm -rf third_party/download
fi
