#!/usr/bin/env bash
# Runs every command of the user guide's Getting started page (docs/src/getting-started.md), as
# written: each line of its ```sh blocks, in order, failing on the first that fails.
#
#   bash docs/getting-started.sh [FORMICA_BIN]
#
# - `cargo ...` lines run at the root of the repository. `cargo test --release --workspace` is
#   skipped (CI has just run it); `cargo install --path ...` installs into a scratch folder
#   (CARGO_INSTALL_ROOT), reusing the build in target/ (CARGO_TARGET_DIR), and that `formica`
#   is the one the later lines find first on PATH.
# - Every other line runs in a scratch copy of scenarios/ and experiments/, so that the files
#   the commands write (stores, reports, pictures) never land in the repository.
# - `formica serve ...` gets `--port 0` (a free port), runs in the background until its page
#   answers, and is stopped.
set -euo pipefail
ROOT="$(cd "$(dirname "$0")/.." && pwd)"
PAGE="$ROOT/docs/src/getting-started.md"
BIN="${1:-$ROOT/target/release/formica}"
WORK="$(mktemp -d)"
SERVER=""
cleanup() {
  if [ -n "$SERVER" ]; then kill "$SERVER" 2>/dev/null || true; wait "$SERVER" 2>/dev/null || true; fi
  rm -rf "$WORK"
}
trap cleanup EXIT

mkdir -p "$WORK/bin" "$WORK/run"
cp -r "$ROOT/scenarios" "$ROOT/experiments" "$WORK/run/"
rm -f "$WORK/run/experiments/"*.db "$WORK/run/experiments/"*.db-*
# Until `cargo install` runs, `formica` is the build under test.
ln -s "$BIN" "$WORK/bin/formica"
export PATH="$WORK/bin:$PATH"

# The commands: lines of ```sh blocks, comments and blank lines dropped.
mapfile -t COMMANDS < <(awk '
  /^```sh[[:space:]]*$/ { inblock = 1; next }
  /^```/ { inblock = 0; next }
  inblock && $0 !~ /^[[:space:]]*(#|$)/ { print }
' "$PAGE")
[ "${#COMMANDS[@]}" -ge 10 ] || { echo "getting-started: only ${#COMMANDS[@]} commands found in $PAGE" >&2; exit 1; }

serve() {
  # serve CMD: starts `CMD --port 0`, waits for its page, checks it, stops it.
  local log="$WORK/serve.log"
  bash -c "exec $1 --port 0" >"$log" 2>&1 &
  SERVER=$!
  local url=""
  for _ in $(seq 1 100); do
    url="$(grep -o 'http://[0-9.]*:[0-9]*/' "$log" | head -1 || true)"
    [ -n "$url" ] && break
    kill -0 "$SERVER" 2>/dev/null || { cat "$log" >&2; return 1; }
    sleep 0.1
  done
  [ -n "$url" ] || { echo "getting-started: the server printed no address" >&2; cat "$log" >&2; return 1; }
  python3 - "$url" <<'EOF'
import sys, urllib.request
with urllib.request.urlopen(sys.argv[1], timeout=10) as r:
    page = r.read().decode()
    assert r.status == 200 and "<html" in page.lower(), "not the viewer page"
with urllib.request.urlopen(sys.argv[1] + "api/state", timeout=10) as r:
    assert r.status == 200
print("  viewer answered at", sys.argv[1])
EOF
  kill "$SERVER"
  wait "$SERVER" 2>/dev/null || true
  SERVER=""
}

n=0
for cmd in "${COMMANDS[@]}"; do
  n=$((n + 1))
  echo "getting-started [$n/${#COMMANDS[@]}]: $cmd"
  case "$cmd" in
    "cargo test --release --workspace")
      echo "  (skipped: .ci/run has just run it)" ;;
    "cargo install "*)
      (cd "$ROOT" && CARGO_INSTALL_ROOT="$WORK/install" CARGO_TARGET_DIR="$ROOT/target" \
        bash -c "${cmd/ --locked/} --locked --quiet")
      export PATH="$WORK/install/bin:$PATH" ;;
    cargo\ *)
      (cd "$ROOT" && bash -c "$cmd" >/dev/null) ;;
    "formica serve "*)
      cd "$WORK/run"
      serve "$cmd"
      cd "$ROOT" ;;
    *)
      (cd "$WORK/run" && bash -c "$cmd" >"$WORK/out.txt") || { cat "$WORK/out.txt" >&2; exit 1; }
      head -c 300 "$WORK/out.txt" | sed 's/^/  /'; echo ;;
  esac
done
echo "getting-started: ${#COMMANDS[@]} commands ran"
