#!/usr/bin/env bash
# scripts/install_deps.sh on a machine without ../shared/third_party: it
# downloads the source tarballs from upstream, where GitHub packs a
# revision with its own top folder and compression. Served here from a
# local mirror (UPSTREAM_URL_PREFIX=file://...) that repacks the checked
# tarballs so: the same sources are accepted, changed sources refused with
# nothing left behind.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
repo=$here/..
work=$(mktemp -d /tmp/third_party_test.XXXXXX)
trap 'rm -rf "$work"' EXIT

# NAME SHA256 DIGEST PATH of every tarball, as the script lists them.
mapfile -t entries < <(sed -n 's/^  "\([^ ]*\) \([^ ]*\) \([^ ]*\) \([^ ]*\)"$/\1 \4/p' \
  "$repo/scripts/install_deps.sh")
[ ${#entries[@]} -eq 3 ] || { echo "expected 3 tarballs, found ${#entries[@]}"; exit 1; }

# Repacks tarball $1 with top folder $2 into $3, with a change if $4 is set.
repack() {
  local unpacked
  unpacked=$(mktemp -d "$work/unpack.XXXXXX")
  tar -xzf "$1" -C "$unpacked"
  mv "$unpacked"/* "$unpacked/tmp_top" && mv "$unpacked/tmp_top" "$unpacked/$2"
  if [ -n "${4:-}" ]; then echo "# changed" >>"$unpacked/$2/CMakeLists.txt"; fi
  mkdir -p "$(dirname "$3")"
  tar -C "$unpacked" -cf - "$2" | gzip -1 >"$3"
  rm -rf "$unpacked"
}
for entry in "${entries[@]}"; do
  read -r name path <<<"$entry"
  repack "$repo/third_party/$name" "upstream-${name%.tar.gz}" \
    "$work/mirror/$path"
  repack "$repo/third_party/$name" "upstream-${name%.tar.gz}" \
    "$work/changed/$path" changed
done

run_install() {  # MIRROR
  SHARED_THIRD_PARTY=/nonexistent UPSTREAM_URL_PREFIX="file://$work/$1/" \
    bash "$work/repo/scripts/install_deps.sh" >"$work/$1.log" 2>&1
}
mkdir -p "$work/repo"
cp -r "$repo/scripts" "$work/repo/"

# The same sources, packed otherwise: accepted.
if ! run_install mirror; then
  cat "$work/mirror.log"; echo "FAIL: the repacked tarballs were refused"; exit 1
fi
for entry in "${entries[@]}"; do
  read -r name path <<<"$entry"
  [ -f "$work/repo/third_party/$name" ] || { echo "FAIL: $name missing"; exit 1; }
  cmp -s "$work/repo/third_party/$name" "$work/mirror/$path" ||
    { echo "FAIL: $name is not the download"; exit 1; }
done
grep -q "the same sources" "$work/mirror.log" ||
  { cat "$work/mirror.log"; echo "FAIL: no word of the repacking"; exit 1; }

# Changed sources: refused, naming the tarball, and nothing left behind.
rm -rf "$work/repo/third_party"
if run_install changed; then
  cat "$work/changed.log"; echo "FAIL: changed sources were accepted"; exit 1
fi
first_name=${entries[0]%% *}
grep -q "error: $first_name has neither the expected SHA256" "$work/changed.log" ||
  { cat "$work/changed.log"; echo "FAIL: no clear error"; exit 1; }
if ls "$work/repo/third_party/" 2>/dev/null | grep -q .; then
  ls -la "$work/repo/third_party"; echo "FAIL: a refused tarball was kept"; exit 1
fi
echo "PASS"
