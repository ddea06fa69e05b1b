#!/usr/bin/env bash
# Installs the Debian packages the project builds and tests with. Idempotent: it asks apt only for
# packages that are missing, so a second run costs a dpkg query. --tests adds what only the test
# suite needs (the browser the viewer's tests drive, and the servers the store, cache and cluster
# tests start throwaway instances of: PostgreSQL, Redis, nginx; the build needs only their
# client libraries), and wrk and curl, which the HTTP benchmarks (bench/*.sh) drive them with.
set -euo pipefail

packages=(
  build-essential cmake ninja-build pkg-config
  nlohmann-json3-dev libssl-dev libopenimageio-dev openimageio-tools
  libgtest-dev libgmock-dev libbenchmark-dev
  libdraco-dev libgeographiclib-dev zlib1g-dev libtiff-dev libpng-dev
  libboost1.81-dev libtomlplusplus-dev libsqlite3-dev libpq-dev libhiredis-dev
  gdal-bin jq nodejs clang libclang-rt-14-dev
  libegl-dev libgles-dev libegl-mesa0 libgl1-mesa-dri
)
[ "${1:-}" = "--tests" ] && packages+=(chromium postgresql redis-server nginx-light wrk curl)

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done

# Node.js from some other source (NodeSource) ships its own npm, which Debian's npm conflicts with.
command -v npm >/dev/null 2>&1 || missing+=(npm)

if [ ${#missing[@]} -gt 0 ]; then
  echo "Installing: ${missing[*]}"
  sudo_cmd=""
  [ "$(id -u)" -ne 0 ] && sudo_cmd="sudo"
  $sudo_cmd apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo_cmd apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi

# JavaScript tools the tests use (the glTF validator, playwright-core driving Debian's chromium),
# pinned by package-lock.json; installed again only when the lock file is newer than the install.
repo_root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
installed_lock="$repo_root/node_modules/.package-lock.json"
if [ -f "$repo_root/package-lock.json" ] &&
  { [ ! -f "$installed_lock" ] || [ "$repo_root/package-lock.json" -nt "$installed_lock" ]; }; then
  (cd "$repo_root" && PLAYWRIGHT_SKIP_BROWSER_DOWNLOAD=1 npm ci --no-audit --no-fund --loglevel=error)
fi
