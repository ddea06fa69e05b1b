#!/usr/bin/env bash
# Renders deploy/nginx.conf for a set of replicas.
# Usage: deploy/render-nginx.sh LISTEN RUN_DIR CACHE_DIR CACHE_MAX_SIZE REPLICA... > nginx.conf
#   e.g. deploy/render-nginx.sh 80 /run/terrain-nginx /var/cache/terrain 10g 127.0.0.1:8081 127.0.0.1:8082
# TERRAIN_NGINX_CACHE=off renders it without nginx's own cache (benchmarks of the replicas).
set -euo pipefail
[ $# -ge 5 ] || { sed -n '2,4p' "$0" >&2; exit 2; }
listen="$1" run_dir="$2" cache_dir="$3" cache_max="$4"
shift 4
servers=""
for replica in "$@"; do
  servers+="    server ${replica} max_fails=1 fail_timeout=2s;"$'\n'
done
template="$(dirname "$0")/nginx.conf"
while IFS= read -r line; do
  case "$line" in
    *@UPSTREAM_SERVERS@*) printf '%s' "$servers" ;;
    *)
      line="${line//@LISTEN@/$listen}"
      line="${line//@RUN_DIR@/$run_dir}"
      line="${line//@CACHE_DIR@/$cache_dir}"
      line="${line//@CACHE_MAX_SIZE@/$cache_max}"
      line="${line//@PROXY_CACHE@/${TERRAIN_NGINX_CACHE:-terrain_products}}"
      printf '%s\n' "$line"
      ;;
  esac
done < "$template"
