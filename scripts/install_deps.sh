#!/usr/bin/env bash
# Installs, from this Debian 12 machine's own packages, everything needed to
# build COLMAP 4.1.1 with colmap_ext and to run its tests, benchmark and GUI
# check; then puts the source tarballs of COLMAP 4.1.1 and of the PoseLib and
# faiss revisions it builds with into third_party/: from ../shared/third_party
# where that folder holds them, otherwise downloaded from upstream. Every
# tarball is checked here and again by CMake: its SHA256, or, for a download
# that GitHub packed otherwise (another top folder, other compression), the
# digest of its sources (source_digest). Does nothing that is already done.
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

# name, SHA256, source digest, upstream address (the tags and commit COLMAP
# 4.1.1 builds with; PoseLib at a commit whose API matches COLMAP's pin).
# UPSTREAM_URL_PREFIX, if set, replaces https://github.com/ (a mirror).
TARBALLS=(
  "colmap-4.1.1.tar.gz 7ec1bf1a2ab7729c5126da1609f1c6d09bc6b5508bdf8ac8518fcf7f8da2e2d6 7b081f29e121417031adecb550a9bfa4e376905e3fa4121c96caad6c8281168f colmap/colmap/archive/refs/tags/4.1.1.tar.gz"
  "poselib-a69263d5.tar.gz a191932f12dab944c7311b22902d643a87b4e788049204d097f180a400192c83 c361d04ef441bf0aa3f61edc337fcd5efa9602ae9f81d33f53a8a296d1c01d6f PoseLib/PoseLib/archive/a69263d5d824b5de11e48756f33f6e8ebb231f0c.tar.gz"
  "faiss-1.14.1.tar.gz 258fb410f3aa78d6c1c813f1cc665e545fe8d3bcd7bfd102e7414e3b2b7d7360 7ad584910d33d4146a14ebe8052b9663a9f0f1f0679834d56be64aeb1693a707 facebookresearch/faiss/archive/refs/tags/v1.14.1.tar.gz"
)
UPSTREAM_URL_PREFIX=${UPSTREAM_URL_PREFIX:-https://github.com/}
SHARED_THIRD_PARTY=${SHARED_THIRD_PARTY:-../shared/third_party}

# The SHA-256 of the sources in a tarball of one top folder: of the listing
# "SHA256  PATH" of every file, by path, as CMakeLists.txt computes it.
source_digest() {
  local unpacked status=0
  unpacked=$(mktemp -d)
  if tar -xzf "$1" -C "$unpacked" 2>/dev/null; then
    local top=("$unpacked"/*)
    if [ ${#top[@]} -eq 1 ] && [ -d "${top[0]}" ]; then
      (cd "${top[0]}" && find . -type f -printf '%P\0' | LC_ALL=C sort -z |
         xargs -0 -r sha256sum) | sha256sum | cut -d' ' -f1
    else
      status=1
    fi
  else
    status=1
  fi
  rm -rf "$unpacked"
  return $status
}

# Whether FILE has SHA256 or, packed otherwise, the sources of DIGEST.
tarball_matches() {
  local file=$1 sha256=$2 digest=$3
  [ -f "$file" ] || return 1
  echo "$sha256  $file" | sha256sum --check --status 2>/dev/null && return 0
  [ "$(source_digest "$file" || true)" = "$digest" ] || return 1
  echo "${file%.part}: packed otherwise than the checked tarball, the same" \
    "sources"
}

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
  read -r name sha256 digest path <<<"$entry"
  target="third_party/$name"
  if tarball_matches "$target" "$sha256" "$digest"; then
    continue
  fi
  rm -f "$target"
  if [ -f "$SHARED_THIRD_PARTY/$name" ]; then
    cp "$SHARED_THIRD_PARTY/$name" "$target.part"
  else
    echo "Downloading $UPSTREAM_URL_PREFIX$path"
    curl -fL --retry 3 -o "$target.part" "$UPSTREAM_URL_PREFIX$path"
  fi
  if ! tarball_matches "$target.part" "$sha256" "$digest"; then
    rm -f "$target.part"
    echo "error: $name has neither the expected SHA256 $sha256 nor the" \
      "expected sources (digest $digest); it was not kept: check" \
      "UPSTREAM_URL_PREFIX or ../shared/third_party and try again" >&2
    exit 1
  fi
  mv "$target.part" "$target"
done
