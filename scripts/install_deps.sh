#!/usr/bin/env bash
# Installs, from this Debian 12 machine's own packages, everything needed to
# build COLMAP 4.1.1 with colmap_ext and to run its tests, benchmark and GUI
# check; then puts the source tarballs of COLMAP 4.1.1 and of the PoseLib and
# faiss revisions it builds with into third_party/: from ../shared/third_party
# where that folder holds them, otherwise downloaded from upstream. Every
# tarball's SHA256 is checked here and again by CMake. Does nothing that is
# already done.
set -euo pipefail
cd "$(dirname "$0")/.."

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi

PACKAGES=(
  build-essential cmake ninja-build ccache pkg-config patch dpkg-dev
  libeigen3-dev libceres-dev libsuitesparse-dev
  libboost-program-options-dev libboost-graph-dev libboost-system-dev
  libboost-filesystem-dev libboost-test-dev
  libcgal-dev qtbase5-dev libqt5opengl5-dev libqt5svg5-dev libflann-dev
  libfreeimage-dev libopenimageio-dev openimageio-tools curl
  libglew-dev libmetis-dev libsqlite3-dev libgoogle-glog-dev libgflags-dev
  libgtest-dev libigraph-dev
  python3 python3-numpy python3-matplotlib python3-pil time
  xvfb xauth libgl1-mesa-dri imagemagick
  slurmctld slurmd slurm-client munge
)

# name, SHA256, upstream address (the tags and commit COLMAP 4.1.1 builds
# with; PoseLib at a commit whose API matches COLMAP's pin).
TARBALLS=(
  "colmap-4.1.1.tar.gz 7ec1bf1a2ab7729c5126da1609f1c6d09bc6b5508bdf8ac8518fcf7f8da2e2d6 https://github.com/colmap/colmap/archive/refs/tags/4.1.1.tar.gz"
  "poselib-a69263d5.tar.gz a191932f12dab944c7311b22902d643a87b4e788049204d097f180a400192c83 https://github.com/PoseLib/PoseLib/archive/a69263d5d824b5de11e48756f33f6e8ebb231f0c.tar.gz"
  "faiss-1.14.1.tar.gz 258fb410f3aa78d6c1c813f1cc665e545fe8d3bcd7bfd102e7414e3b2b7d7360 https://github.com/facebookresearch/faiss/archive/refs/tags/v1.14.1.tar.gz"
)
SHARED_THIRD_PARTY=../shared/third_party

missing=()
for package in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$package" 2>/dev/null |
    grep -q "install ok installed" || missing+=("$package")
done

export DEBIAN_FRONTEND=noninteractive
if [ ${#missing[@]} -gt 0 ]; then
  echo "Installing: ${missing[*]}"
  $SUDO apt-get update -qq
  $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi

mkdir -p third_party
for entry in "${TARBALLS[@]}"; do
  read -r name sha256 url <<<"$entry"
  target="third_party/$name"
  if [ -f "$target" ] && echo "$sha256  $target" | sha256sum --check --quiet 2>/dev/null; then
    continue
  fi
  rm -f "$target"
  if [ -f "$SHARED_THIRD_PARTY/$name" ]; then
    cp "$SHARED_THIRD_PARTY/$name" "$target.part"
  else
    echo "Downloading $url"
    curl -fL --retry 3 -o "$target.part" "$url"
  fi
  if ! echo "$sha256  $target.part" | sha256sum --check --quiet; then
    rm -f "$target.part"
    echo "error: $name does not have the expected SHA256 $sha256" >&2
    exit 1
  fi
  mv "$target.part" "$target"
done
