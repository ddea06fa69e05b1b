#!/usr/bin/env bash
# Quick start "run": installs what is missing, builds, and renders every built-in example scene
# (sphere-traced picture and heightmap) into out/. Extra arguments go to `terrain render`.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps.sh
scripts/build.sh release
mkdir -p out
for scene in config/scenes/*.json; do
  name="$(basename "$scene" .json)"
  build/release/tools/terrain render "$scene" -o "out/$name.png" --width 480 --height 270 "$@"
  build/release/tools/terrain grid "$scene" -o "out/$name-height.tif" --size 512
done
echo "Pictures and heightmaps are in $(pwd)/out/"
