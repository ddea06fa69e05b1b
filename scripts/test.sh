#!/usr/bin/env bash
# Quick start "test": installs what is missing, builds the dev preset, runs the whole suite.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps.sh
preset="${TERRAIN_TEST_PRESET:-dev}"
scripts/build.sh "$preset"
ctest --preset "$preset"
