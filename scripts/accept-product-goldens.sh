#!/usr/bin/env bash
# Rewrites the product goldens (tests/terrain/goldens/scene_products.json and
# tests/planet/goldens/planet_products.json: the SHA-256 of every example scene's and the default
# planet's tiles in every format) from what the code makes now. Changed bytes of a product already
# pinned are refused until terrain::kProductGeneration (terrain/tile_products.hpp) is raised:
# servers of one generation share caches and ETags, so they must make the same bytes. The files
# also record each scene's hash and the planet's id: products of an example that was edited are
# new products (new versions and URLs) and are accepted under the same generation.
# Usage: scripts/accept-product-goldens.sh
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/build.sh dev > /dev/null
mkdir -p tests/terrain/goldens tests/planet/goldens
export TERRAIN_ACCEPT_GOLDENS=1
build/dev/tests/terrain_tests --gtest_filter='ProductGoldens.*'
build/dev/tests/planet_tests --gtest_filter='ProductGoldens.*'
git status --short tests/terrain/goldens tests/planet/goldens
