#!/usr/bin/env bash
# End-to-end test of the live viewer: starts `formica serve` on a free loopback port in the
# background, waits for it, runs viewer.test.mjs in headless Chromium, and stops the server.
# Needs: target/release/formica (cargo build --release), Debian's chromium, and
# `npm ci` in e2e/ (done here if node_modules is missing).
set -euo pipefail
cd "$(dirname "$0")"
BIN=${FORMICA_BIN:-../target/release/formica}
SCENARIO=${SCENARIO:-../scenarios/seed-transport.toml}
if [ ! -x "$BIN" ]; then
  echo "e2e: $BIN is missing; run cargo build --release first" >&2
  exit 2
fi
if [ ! -d node_modules/playwright-core ]; then
  npm ci --no-audit --no-fund
fi

LOG=$(mktemp)
# Port 0: the system picks a free port, and the server prints it (no race with other users).
"$BIN" serve "$SCENARIO" --port 0 >"$LOG" 2>&1 &
PID=$!
cleanup() {
  kill "$PID" 2>/dev/null || true
  wait "$PID" 2>/dev/null || true
  rm -f "$LOG"
}
trap cleanup EXIT

URL=""
for _ in $(seq 1 150); do
  URL=$(grep -o 'http://127\.0\.0\.1:[0-9]*' "$LOG" | head -n 1 || true)
  if [ -n "$URL" ]; then break; fi
  if ! kill -0 "$PID" 2>/dev/null; then
    echo "e2e: the server exited:" >&2
    cat "$LOG" >&2
    exit 1
  fi
  sleep 0.1
done
if [ -z "$URL" ]; then
  echo "e2e: the server did not start within 15 s" >&2
  cat "$LOG" >&2
  exit 1
fi
PORT=${URL##*:}
for _ in $(seq 1 50); do
  if (exec 3<>"/dev/tcp/127.0.0.1/$PORT") 2>/dev/null; then break; fi
  sleep 0.1
done
echo "e2e: formica serve is up on $URL (pid $PID)"

FORMICA_URL="$URL" node --test --test-reporter=tap viewer.test.mjs
