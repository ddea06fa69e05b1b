#!/usr/bin/env bash
# HTTP benchmarks on loopback (release build): cached tile requests/s against nginx serving the
# same bytes as a static file, side by side with the same wrk settings; then uncached tile latency
# (p50/p99) over distinct addresses. Installs wrk and nginx from Debian when missing.
# Usage: bench/http_bench.sh [SECONDS per run]   (HTTP_BENCH_ROUNDS=6 rounds by default)
# Like with like: the server's I/O threads and nginx's worker processes are both
# HTTP_BENCH_WORKERS (default 2, this VM's vCPUs); nginx keeps its defaults otherwise (sendfile
# on, tcp_nodelay on, keepalive_requests 1000). HTTP_BENCH_SERVER names another server binary
# (an older build, say; default build/release/server/terrain-server).
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-5}"
workers="${HTTP_BENCH_WORKERS:-2}"
scripts/install-deps.sh --tests > /dev/null  # wrk, nginx, Redis, curl: the test servers
scripts/build.sh release > /dev/null

work="$(mktemp -d)"
cleanup() {
  [ -n "${server_pid:-}" ] && kill "$server_pid" 2> /dev/null || true
  [ -f "$work/nginx.pid" ] && kill "$(cat "$work/nginx.pid")" 2> /dev/null || true
  rm -rf "$work"
}
trap cleanup EXIT

"${HTTP_BENCH_SERVER:-build/release/server/terrain-server}" --config /dev/null --port 0 \
  --data-dir "$work/data" --io-threads "$workers" --log-level warn \
  > "$work/server.out" 2> "$work/server.err" &
server_pid=$!
for _ in $(seq 100); do grep -q listening "$work/server.out" 2> /dev/null && break; sleep 0.1; done
port="$(sed -n 's/.*:\([0-9]*\) .*/\1/p' "$work/server.out" | head -1)"
base="http://127.0.0.1:$port/api/v1/scenes/winding-road@1"
tile="$base/tiles/13/4261/2988.png"
curl -sf -o "$work/tile.png" "$tile"

mkdir -p "$work/www"
cp "$work/tile.png" "$work/www/tile.png"
# mktemp -d makes a 0700 directory, which nginx's workers (user nobody when started as root)
# cannot enter: they answered 403 (153 bytes), and earlier versions of this script measured that
# error page instead of the tile. The checks below make sure nginx sends the tile.
chmod 755 "$work" "$work/www"
chmod 644 "$work/www/tile.png"
cat > "$work/nginx.conf" <<NGINX
worker_processes $workers;
pid $work/nginx.pid;
error_log $work/nginx-error.log;
events { worker_connections 1024; }
http {
  access_log off;
  sendfile on;
  server {
    listen 127.0.0.1:18099;
    root $work/www;
  }
}
NGINX
nginx -c "$work/nginx.conf"
sleep 0.5
if ! curl -sf http://127.0.0.1:18099/tile.png | cmp -s - "$work/tile.png"; then
  echo "nginx does not serve the tile's bytes: $(curl -s -o /dev/null -w '%{http_code}' \
    http://127.0.0.1:18099/tile.png)" >&2
  exit 1
fi
# Requests per second of one wrk run; any non-2xx answer (an error page is no tile) fails.
rate() {
  local out
  out="$(wrk -t2 -c32 -d"${seconds}s" "$1")"
  if grep -q "Non-2xx" <<< "$out"; then
    echo "$1: $(grep "Non-2xx" <<< "$out")" >&2
    exit 1
  fi
  awk '/Requests\/sec/ {print $2}' <<< "$out"
}

rounds="${HTTP_BENCH_ROUNDS:-6}"
echo "## Cached tile ($(stat -c %s "$work/tile.png") bytes), wrk -t2 -c32, $rounds alternating rounds of ${seconds}s, $workers server I/O threads and nginx workers"
echo
# Client and servers share this VM's cores and its neighbours' noise: single runs swing by 2x.
# The servers therefore take turns, round after round, and the ratio is the median of the
# rounds' ratios (each round's two runs are seconds apart).
echo "| Round | terrain-server req/s | nginx req/s | ratio |"
echo "|---|---|---|---|"
: > "$work/ratios"
for round in $(seq "$rounds"); do
  ours="$(rate "$tile")"
  theirs="$(rate http://127.0.0.1:18099/tile.png)"
  ratio="$(awk -v a="$ours" -v b="$theirs" 'BEGIN {printf "%.2f", a / b}')"
  echo "$ratio" >> "$work/ratios"
  echo "| $round | $ours | $theirs | $ratio |"
done
echo
echo "Median ratio: $(sort -n "$work/ratios" | awk '{a[NR]=$1} END {print a[int((NR+1)/2)]}')"
echo
echo "## Uncached 256² terrain-RGB tiles, one at a time (200 distinct addresses per scene)"
echo
echo "| Scene | p50 | p99 |"
echo "|---|---|---|"
for scene in winding-road mountain-range hills-river; do
  : > "$work/times"
  for i in $(seq 0 199); do
    x=$((i % 20)); y=$((i / 20))
    curl -s -o /dev/null -w '%{time_total}\n' \
      "http://127.0.0.1:$port/api/v1/scenes/$scene@1/tiles/5/$x/$y.png?scheme=local" >> "$work/times"
  done
  sort -n "$work/times" | awk -v s="$scene" '{a[NR]=$1} END {
    printf "| %s | %.1f ms | %.1f ms |\n", s, a[int(NR*0.5)]*1000, a[int(NR*0.99)]*1000 }'
done
