#!/usr/bin/env bash
# The console end to end in a real browser: vogd on the simulator (idle, waiting for a Start), vog-console
# with the operator secret on every address (so with a token), headless Chromium driven by
# tests/console/browser_test.mjs: the page's voxel count equals the mirror's, the vehicle moves after
# Start from the page, a command vogd refuses shows as refused, bad page messages are refused; then an
# observer console (no secret) whose controls are off. Screenshots and summaries stay in OUTDIR.
#   tests/console/run_browser_test.sh BUILD_DIR [OUTDIR]
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
root="$(cd "$here/../.." && pwd)"
build="$(cd "${1:?usage: run_browser_test.sh BUILD_DIR [OUTDIR]}" && pwd)"
out="${2:-$build/tests/console}"
rm -rf "$out" && mkdir -p "$out"
chromium="${CHROMIUM:-/usr/bin/chromium}"
[ -d "$root/client/console/web/node_modules/playwright-core" ] || { echo "run_browser_test: run scripts/setup (npm ci)" >&2; exit 2; }

pids=()
cleanup() { for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; wait "$p" 2>/dev/null || true; done; }
trap cleanup EXIT

# wait_file FILE PID WHAT: the port a child wrote.
wait_file() {
  for _ in $(seq 1 200); do
    [ -s "$1" ] && { cat "$1"; return 0; }
    kill -0 "$2" 2>/dev/null || break
    sleep 0.05
  done
  echo "run_browser_test: $3 did not start" >&2
  return 1
}

printf 'browser-test-operator-secret\n' > "$out/secret"
chmod 600 "$out/secret"
cat > "$out/vogd.yaml" <<YAML
source: sim
sim:
  scene: $root/config/scenes/pilings.yaml
  seed: 1
  speedup: 4
mission:
  box_min_m: [-6, -4, -4]
  box_max_m: [6, 4, 0]
  max_submaps: 12
api:
  port: 0
  secret_file: $out/secret
log:
  level: warning
YAML
"$build/bin/vogd" --config "$out/vogd.yaml" --mission-dir "$out/mission" --port-file "$out/vogd.port" 2> "$out/vogd.log" &
pids+=($!)
port=$(wait_file "$out/vogd.port" "${pids[-1]}" vogd)

status=0
token="t$(od -An -N12 -tx1 /dev/urandom | tr -d ' \n')"
echo "== operator console on 0.0.0.0 (token), Start from the page"
"$build/bin/vog-console" --port "$port" --secret-file "$out/secret" --listen 0.0.0.0:0 --token "$token" \
  --port-file "$out/operator.port" > "$out/console-operator.log" 2>&1 &
pids+=($!)
web=$(wait_file "$out/operator.port" "${pids[-1]}" vog-console)
node "$here/browser_test.mjs" --url "http://127.0.0.1:$web/" --token "$token" --mode operator --expect-start \
  --chromium "$chromium" --screenshot "$out/operator.png" --json "$out/operator.json" || status=1

echo "== observer console on loopback, no secret: the controls are off"
"$build/bin/vog-console" --port "$port" --listen 127.0.0.1:0 --port-file "$out/observer.port" \
  > "$out/console-observer.log" 2>&1 &
pids+=($!)
web=$(wait_file "$out/observer.port" "${pids[-1]}" vog-console)
node "$here/browser_test.mjs" --url "http://127.0.0.1:$web/" --mode observer \
  --chromium "$chromium" --screenshot "$out/observer.png" --json "$out/observer.json" || status=1

# The consoles ran through everything the pages sent them: both still serving.
curl -sf -o /dev/null "http://127.0.0.1:$(cat "$out/operator.port")/api/state?token=$token" ||
  { echo "run_browser_test: the operator console stopped serving" >&2; status=1; }
curl -sf -o /dev/null "http://127.0.0.1:$(cat "$out/observer.port")/api/state" ||
  { echo "run_browser_test: the observer console stopped serving" >&2; status=1; }
echo "screenshots and summaries in $out"
[ "$status" -eq 0 ] && echo "run_browser_test: PASS" || echo "run_browser_test: FAIL"
exit "$status"
