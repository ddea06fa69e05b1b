#!/usr/bin/env bash
# The share of GPU tiles byte-identical to CPU tiles over many tiles: every local tile of zooms
# 2..4 of every example scene, terrain-RGB and normal maps (4 032 tiles; about 4 minutes on a
# 2-vCPU VM with llvmpipe). The CI test runs zoom 2 only. Usage: scripts/gpu_tiles_figure.sh
# [build dir] [max zoom].
set -euo pipefail
build=${1:-build/dev}
zoom=${2:-4}
TERRAIN_GPU_TILES_MAX_ZOOM=$zoom "$build/tests/gpu_tests" \
  --gtest_filter=GpuTiles.EncodeToTheSameBytesAsCpuTiles
