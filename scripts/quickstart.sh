#!/usr/bin/env bash
# The main job on a fresh Debian 12 machine: installs the packages rost needs,
# builds it, fetches real footage (diver.mov, from the Debian package
# pd-extendedview) and runs `rost run` on it. Prints where the outputs are.
#   scripts/quickstart.sh [extra `rost run` options, e.g. --sampler uni+now -K 16]
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
jobs=$(nproc 2>/dev/null || echo 2)
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release -DROST_VISION=ON
cmake --build build -j "$jobs" --target rost
video=$(bash scripts/fetch-footage.sh pd-extendedview | tail -n 1)
out=out/diver
./build/rost run "$video" --out "$out" "$@"
echo
echo "rost ran on $video; its outputs are in $(pwd)/$out:"
ls -1 "$out" | sed 's/^/  /'
echo "Open $out/summary.png for perplexity and surprise over the frames."
