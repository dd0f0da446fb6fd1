#!/usr/bin/env bash
# End-to-end test of the live viewer: starts two `formica serve` in the background on free
# loopback ports (a live scenario, and the replay of a stored trial of experiments/smoke.toml),
# waits for them, runs viewer.test.mjs in headless Chromium, and stops the servers.
# Needs: target/release/formica (cargo build --release), Debian's chromium, and
# `npm ci` in e2e/ (done here if node_modules is missing).
set -euo pipefail
cd "$(dirname "$0")"
BIN=${FORMICA_BIN:-../target/release/formica}
SCENARIO=${SCENARIO:-../scenarios/seed-transport.toml}
# The stored trial replayed: trial 3 of the smoke study (seed 4, 10 robots, occlusion).
TRIAL=${TRIAL:-3}
if [ ! -x "$BIN" ]; then
  echo "e2e: $BIN is missing; run cargo build --release first" >&2
  exit 2
fi
if [ ! -d node_modules/playwright-core ]; then
  npm ci --no-audit --no-fund
fi

WORK=$(mktemp -d)
PIDS=()
cleanup() {
  for p in "${PIDS[@]}"; do kill "$p" 2>/dev/null || true; done
  for p in "${PIDS[@]}"; do wait "$p" 2>/dev/null || true; done
  rm -rf "$WORK"
}
trap cleanup EXIT

# start NAME ARGS...: starts `formica serve ARGS --port 0` and sets URL to its address.
start() {
  local name=$1
  shift
  local log="$WORK/$name.log"
  # Port 0: the system picks a free port, and the server prints it (no race with other users).
  "$BIN" serve "$@" --port 0 >"$log" 2>&1 &
  local pid=$!
  PIDS+=("$pid")
  URL=""
  for _ in $(seq 1 150); do
    URL=$(grep -o 'http://127\.0\.0\.1:[0-9]*' "$log" | head -n 1 || true)
    if [ -n "$URL" ]; then break; fi
    if ! kill -0 "$pid" 2>/dev/null; then
      echo "e2e: the $name server exited:" >&2
      cat "$log" >&2
      exit 1
    fi
    sleep 0.1
  done
  if [ -z "$URL" ]; then
    echo "e2e: the $name server did not start within 15 s" >&2
    cat "$log" >&2
    exit 1
  fi
  local port=${URL##*:}
  for _ in $(seq 1 50); do
    if (exec 3<>"/dev/tcp/127.0.0.1/$port") 2>/dev/null; then break; fi
    sleep 0.1
  done
  echo "e2e: formica serve ($name) is up on $URL (pid $pid)"
}

start live "$SCENARIO"
LIVE_URL=$URL
"$BIN" sweep ../experiments/smoke.toml --db "$WORK/smoke.db" --quiet
start replay --db "$WORK/smoke.db" --trial "$TRIAL"
REPLAY_URL=$URL

FORMICA_URL="$LIVE_URL" FORMICA_REPLAY_URL="$REPLAY_URL" FORMICA_REPLAY_TRIAL="$TRIAL" \
  node --test --test-reporter=tap --test-concurrency=1 viewer.test.mjs
