#!/usr/bin/env bash
# Throughput through nginx with one and with two terrain-server replicas (docs/scaling.md): the
# deployment of deploy/ on loopback — replicas on one store, one Redis (shared products and live
# fan-out), nginx balancing with its own cache switched off, so that the replicas answer every
# request. Cached: one tile asked again and again (from the replicas' memory). Uncached: every
# request a different tile of zoom 10 (generated, then shared through Redis).
# Usage: bench/cluster_bench.sh [SECONDS per run]
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-5}"
scripts/install-deps.sh --tests > /dev/null  # wrk, nginx, Redis, curl: the test servers
scripts/build.sh release > /dev/null

work="$(mktemp -d)"
pids=()
cleanup() {
  [ -f "$work/nginx/nginx.pid" ] && kill "$(cat "$work/nginx/nginx.pid")" 2> /dev/null || true
  for pid in "${pids[@]}"; do kill "$pid" 2> /dev/null || true; done
  wait 2> /dev/null || true
  rm -rf "$work"
}
trap cleanup EXIT

free_port() { python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])'; }

redis_port="$(free_port)"
redis-server --port "$redis_port" --bind 127.0.0.1 --save '' --appendonly no --loglevel warning \
  --maxmemory 1gb --maxmemory-policy allkeys-lru > /dev/null &
pids+=($!)
for _ in $(seq 100); do redis-cli -p "$redis_port" ping > /dev/null 2>&1 && break; sleep 0.05; done

start_replica() {  # port → starts a replica on the shared store
  build/release/server/terrain-server --config /dev/null --port "$1" --data-dir "$work/data" \
    --redis-url "redis://127.0.0.1:$redis_port" --live-redis-url "redis://127.0.0.1:$redis_port" \
    --log-level warn > "$work/replica-$1.out" 2>&1 &
  pids+=($!)
  for _ in $(seq 200); do grep -q listening "$work/replica-$1.out" 2> /dev/null && return; sleep 0.05; done
  echo "replica on $1 did not start" >&2; exit 1
}

cat > "$work/uncached.lua" <<'LUA'
-- Every request a different tile of zoom 10 of the local scheme (1,048,576 tiles).
counter = 0
request = function()
  counter = counter + 1
  local id = (counter * 7919 + math.random(0, 1000000)) % 1048576
  local x, y = id % 1024, math.floor(id / 1024)
  return wrk.format("GET", "/api/v1/scenes/hills-river@1/tiles/10/" .. x .. "/" .. y .. ".png?scheme=local&size=256")
end
LUA

run_wrk() {  # url-or-script → "requests/s p50"
  local out
  if [ "$1" = uncached ]; then
    out="$(wrk -t2 -c32 -d"${seconds}s" --latency -s "$work/uncached.lua" "http://127.0.0.1:$nginx_port" 2>&1)"
  else
    out="$(wrk -t2 -c64 -d"${seconds}s" --latency "http://127.0.0.1:$nginx_port$1" 2>&1)"
  fi
  local rps p50 errors
  rps="$(awk '/Requests\/sec/ {print $2}' <<< "$out")"
  p50="$(awk '$1 == "50%" {print $2}' <<< "$out")"
  errors="$(awk '/Non-2xx|Socket errors/ {print}' <<< "$out" | tr '\n' ' ')"
  echo "${rps} ${p50} ${errors:-}"
}

ports=()
echo "| replicas | cached tile, req/s (p50) | uncached tiles, req/s (p50) |"
echo "|---|---|---|"
for n in 1 2; do
  while [ "${#ports[@]}" -lt "$n" ]; do
    port="$(free_port)"
    start_replica "$port"
    ports+=("$port")
  done
  nginx_port="$(free_port)"
  mkdir -p "$work/nginx"
  upstreams=()
  for p in "${ports[@]}"; do upstreams+=("127.0.0.1:$p"); done
  TERRAIN_NGINX_CACHE=off deploy/render-nginx.sh "127.0.0.1:$nginx_port" "$work/nginx" \
    "$work/nginx/cache" 1g "${upstreams[@]}" > "$work/nginx/nginx.conf"
  nginx -c "$work/nginx/nginx.conf" -p "$work/nginx"
  for _ in $(seq 100); do curl -sf "http://127.0.0.1:$nginx_port/healthz" > /dev/null && break; sleep 0.05; done
  cached="/api/v1/scenes/hills-river@1/tiles/3/2/5.png?scheme=local"
  for _ in 1 2 3 4; do curl -sf -o /dev/null "http://127.0.0.1:$nginx_port$cached"; done
  read -r c_rps c_p50 c_err <<< "$(run_wrk "$cached")"
  read -r u_rps u_p50 u_err <<< "$(run_wrk uncached)"
  echo "| $n | $c_rps ($c_p50) ${c_err:-} | $u_rps ($u_p50) ${u_err:-} |"
  kill "$(cat "$work/nginx/nginx.pid")"
  sleep 0.5
done
echo
echo "Machine: $(nproc) CPUs ($(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs)); wrk, replicas, nginx and Redis share them."
