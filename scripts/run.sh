#!/usr/bin/env bash
# Quick start "run": installs what is missing, builds the release preset, and starts
# terrain-server on its embedded defaults (config/server.toml: http://127.0.0.1:8080, SQLite
# store in data/, the built-in example scenes loaded on first start). Extra arguments go to the
# server (terrain-server --help lists them); Ctrl-C stops it gracefully.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps.sh
scripts/build.sh release
exec build/release/server/terrain-server "$@"
