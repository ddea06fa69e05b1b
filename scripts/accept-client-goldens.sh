#!/usr/bin/env bash
# Rewrites the browser viewer's golden screenshots (tests/client/golden/*.png) from what the
# viewer draws now in headless Chromium. Look at the new pictures (git diff shows them changed)
# before committing them. Usage: scripts/accept-client-goldens.sh [SCENE]
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/build.sh dev > /dev/null
only=()
[ $# -gt 0 ] && only=(--only "$1")
node tests/client/viewer_test.mjs build/dev/server/terrain-server "$PWD" --accept "${only[@]}"
