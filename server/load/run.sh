#!/usr/bin/env bash
# Bounded loopback load test of the render service with wrk: status polling
# (GET /v1/jobs/{id} of a finished job) and submission (POST /v1/jobs of tiny CPU jobs that the
# service also renders and stores). Builds the release binary, starts it on a free port with a
# fresh data folder, runs each phase for DURATION with CONNECTIONS connections over THREADS
# wrk threads, and stops it.
#
#   server/load/run.sh            # defaults: 10s, 16 connections, 2 threads
#   DURATION=30s CONNECTIONS=64 server/load/run.sh
#
# MODE=scale-out runs the API server over PostgreSQL (GI_SERVER_DATABASE_URL, a fresh database
# is best: the run leaves its jobs there) and an object store folder, with one CPU gi-worker
# rendering the submitted jobs:
#   MODE=scale-out GI_SERVER_DATABASE_URL=postgres://gi:gi@127.0.0.1/gi_load server/load/run.sh
set -euo pipefail
cd "$(dirname "$0")/../.."

DURATION="${DURATION:-10s}"
CONNECTIONS="${CONNECTIONS:-16}"
THREADS="${THREADS:-2}"

command -v wrk >/dev/null || { echo "wrk is not installed (apt-get install wrk)" >&2; exit 1; }
MODE="${MODE:-embedded}"
cargo build --release --locked -p gi-server
binary="${CARGO_TARGET_DIR:-target}/release/gi-server"

work="$(mktemp -d)"
scale_out=()
worker=""
if [ "$MODE" = scale-out ]; then
    [ -n "${GI_SERVER_DATABASE_URL:-}" ] || { echo "MODE=scale-out needs GI_SERVER_DATABASE_URL" >&2; exit 1; }
    scale_out=(--database-url "$GI_SERVER_DATABASE_URL" --store-url "$work/store")
    "${CARGO_TARGET_DIR:-target}/release/gi-worker" --database-url "$GI_SERVER_DATABASE_URL" \
        --store-url "$work/store" --work-dir "$work/worker" --cache-dir "$work/cache" --no-gpu \
        --poll-ms 50 >"$work/worker.log" 2>&1 &
    worker=$!
elif [ "$MODE" != embedded ]; then
    echo "MODE is embedded or scale-out" >&2
    exit 1
fi
# Room for every submission of the run: this measures the service, not its 429 answers.
"$binary" --bind 127.0.0.1:0 --data-dir "$work/data" --cache-dir "$work/cache" --no-gpu \
    --max-queue 1000000 --max-jobs 100000000 "${scale_out[@]}" >"$work/stdout" 2>"$work/stderr" &
server=$!
trap 'kill "$server" $worker 2>/dev/null; wait "$server" $worker 2>/dev/null; rm -rf "$work"' EXIT
for _ in $(seq 100); do
    grep -q listening "$work/stdout" 2>/dev/null && break
    sleep 0.1
done
url="$(sed -n 's/^gi-server listening on //p' "$work/stdout")"
[ -n "$url" ] || { cat "$work/stderr" >&2; exit 1; }

# One finished job to poll.
id="$(curl -sf -H 'Content-Type: application/json' \
    -d '{"scene": "cornell-box", "tier": "reference", "width": 8, "height": 6, "spp": 1}' \
    "$url/v1/jobs" | sed 's/.*"id":"\([0-9]*\)".*/\1/')"
for _ in $(seq 100); do
    curl -sf "$url/v1/jobs/$id" | grep -q '"state":"done"' && break
    sleep 0.1
done

echo "== mode: $MODE"
echo "== machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs)"
echo "== GET /v1/jobs/$id (status polling), $DURATION, $CONNECTIONS connections, $THREADS threads"
wrk -t"$THREADS" -c"$CONNECTIONS" -d"$DURATION" --latency "$url/v1/jobs/$id"
echo "== POST /v1/jobs (submission of 8x6 reference jobs, rendered as they come), $DURATION, $CONNECTIONS connections, $THREADS threads"
wrk -t"$THREADS" -c"$CONNECTIONS" -d"$DURATION" --latency -s server/load/submit.lua "$url/v1/jobs"
echo "== after the run"
curl -sf "$url/metrics" | grep -E '^gi_(queue_depth|jobs\{|jobs_submitted_total)'
