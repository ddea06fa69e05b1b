#!/usr/bin/env bash
# Rewrites the browser viewer's golden screenshots (tests/client/golden/*.png) from what the
# viewer draws now in headless Chromium: one per example scene, and planet-default.png for planet
# mode. Look at the new pictures (git diff shows them changed) before committing them.
# Usage: scripts/accept-client-goldens.sh [SCENE | planet]
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/build.sh dev > /dev/null
server=build/dev/server/terrain-server
if [ "${1:-}" = planet ]; then
  node tests/client/planet_test.mjs "$server" "$PWD" --accept
  exit
fi
only=()
[ $# -gt 0 ] && only=(--only "$1")
node tests/client/viewer_test.mjs "$server" "$PWD" --accept "${only[@]}"
# All goldens: the planet's too.
[ $# -eq 0 ] && node tests/client/planet_test.mjs "$server" "$PWD" --accept
exit 0
