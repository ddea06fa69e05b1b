#!/usr/bin/env bash
# Quick start "test": installs what is missing, builds the dev preset and runs the whole suite,
# then the concurrency tests under ThreadSanitizer and each libFuzzer target for a bounded time.
# TERRAIN_TEST_PRESET=asan (say) runs the suite in another preset and skips the extra stages.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps.sh --tests
preset="${TERRAIN_TEST_PRESET:-dev}"
scripts/build.sh "$preset"
ctest --preset "$preset"
if [ -z "${TERRAIN_TEST_PRESET:-}" ]; then
  cmake --preset tsan > /dev/null
  cmake --build --preset tsan --target server_tests terrain_server -j "$(nproc)"
  ctest --preset tsan
  scripts/fuzz.sh "${TERRAIN_FUZZ_SECONDS:-30}"
fi
