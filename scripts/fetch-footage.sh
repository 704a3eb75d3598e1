#!/usr/bin/env bash
# Fetches the real footage rost's tests, examples and benchmarks use, from Debian 12
# packages, without installing them: `apt-get download` then `dpkg -x` into DIR
# (default: data/ at the top of the repository, which git ignores).
#
#   scripts/fetch-footage.sh [--dir DIR] [PACKAGE...]
#
# PACKAGE is one or more of: pd-extendedview (diver.mov), visp-images-data (mire-2),
# opencv-doc (vtest.avi). Default: all three. Idempotent: a package already unpacked
# (its marker file exists) is skipped, so this is cheap to call before every test run.
# Prints the path of each footage file it provides. Exit status: 0 when everything
# asked for is there, 1 when a download failed (offline, no apt sources), 2 on bad usage.
set -euo pipefail

here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
dir="$here/data"
pkgs=()
while [ $# -gt 0 ]; do
  case "$1" in
    --dir) [ $# -ge 2 ] || { echo "fetch-footage: --dir needs a directory" >&2; exit 2; }; dir=$2; shift 2 ;;
    --dir=*) dir=${1#--dir=}; shift ;;
    -h|--help) sed -n '2,12p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    -*) echo "fetch-footage: unknown option '$1'" >&2; exit 2 ;;
    *) pkgs+=("$1"); shift ;;
  esac
done
[ ${#pkgs[@]} -gt 0 ] || pkgs=(pd-extendedview visp-images-data opencv-doc)

# The file each package is fetched for (relative to the unpacked tree).
footage() {
  case "$1" in
    pd-extendedview) echo "usr/share/doc/pd-extendedview/media/diver.mov" ;;
    visp-images-data) echo "usr/share/visp-images-data/ViSP-images/mire-2/image.0001.pgm" ;;
    opencv-doc) echo "usr/share/doc/opencv-doc/examples/data/vtest.avi" ;;
    *) return 1 ;;
  esac
}

mkdir -p "$dir"
dir=$(cd "$dir" && pwd)
# One fetch at a time (tests running in parallel may all ask for the footage).
if command -v flock >/dev/null 2>&1; then
  exec 9>"$dir/.fetch.lock"
  flock 9
fi
status=0
for p in "${pkgs[@]}"; do
  file=$(footage "$p") || { echo "fetch-footage: unknown package '$p' (known: pd-extendedview visp-images-data opencv-doc)" >&2; exit 2; }
  dest="$dir/$p"
  if [ -f "$dest/.unpacked" ] && [ -e "$dest/$file" ]; then
    echo "$dest/$file"
    continue
  fi
  # Download into a private temporary directory and unpack there, then move the tree
  # into place: an interrupted run never leaves a tree that looks complete.
  tmp=$(mktemp -d "$dir/.fetch-$p.XXXXXX")
  trap 'rm -rf "$tmp"' EXIT
  if ! (cd "$tmp" && apt-get download "$p" >/dev/null 2>"$tmp/apt.log"); then
    # Package lists may be missing on a fresh machine or container.
    if [ "$(id -u)" = 0 ] && apt-get update >/dev/null 2>&1 &&
       (cd "$tmp" && apt-get download "$p" >/dev/null 2>"$tmp/apt.log"); then :; else
      echo "fetch-footage: cannot download $p: $(tail -n 1 "$tmp/apt.log" 2>/dev/null)" >&2
      rm -rf "$tmp"; trap - EXIT; status=1; continue
    fi
  fi
  deb=$(ls "$tmp"/"$p"_*.deb)
  mkdir "$tmp/tree"
  dpkg -x "$deb" "$tmp/tree"
  if [ ! -e "$tmp/tree/$file" ]; then
    echo "fetch-footage: $deb does not contain $file" >&2
    rm -rf "$tmp"; trap - EXIT; status=1; continue
  fi
  basename "$deb" > "$tmp/tree/.unpacked"
  rm -rf "$dest"
  mv "$tmp/tree" "$dest"
  rm -rf "$tmp"; trap - EXIT
  echo "$dest/$file"
done
exit $status
