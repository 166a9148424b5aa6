#!/usr/bin/env bash
# The page against the synthetic console: operator mode with a token, observer mode without.
#   tests/console/run_mock_test.sh [OUTDIR]
# Needs node, client/console/web/node_modules (npm ci there) and Chromium (CHROMIUM, default /usr/bin/chromium).
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
root="$(cd "$here/../.." && pwd)"
out="${1:-$(mktemp -d "${TMPDIR:-/tmp}/vog-console-test.XXXXXX")}"
mkdir -p "$out"
chromium="${CHROMIUM:-/usr/bin/chromium}"

if [ ! -d "$root/client/console/web/node_modules/playwright-core" ] || [ ! -d "$root/client/console/web/node_modules/three" ]; then
  echo "run_mock_test: npm ci in client/console/web first" >&2
  exit 2
fi

mock_pid=""
cleanup() {
  if [ -n "$mock_pid" ] && kill -0 "$mock_pid" 2>/dev/null; then
    kill "$mock_pid" 2>/dev/null || true
    wait "$mock_pid" 2>/dev/null || true
  fi
  mock_pid=""
}
trap cleanup EXIT

# start_mock LOGFILE ARGS...: starts the mock, sets mock_pid and url.
start_mock() {
  local log="$1"; shift
  node "$here/mock_console.mjs" --port 0 "$@" >"$log" 2>&1 &
  mock_pid=$!
  url=""
  for _ in $(seq 1 100); do
    url="$(sed -n 's/^listening \(http:[^ ]*\)$/\1/p' "$log" | head -n 1)"
    [ -n "$url" ] && return 0
    kill -0 "$mock_pid" 2>/dev/null || break
    sleep 0.1
  done
  echo "run_mock_test: the mock console did not start:" >&2
  cat "$log" >&2
  return 1
}

status=0
token="t$(od -An -N8 -tx1 /dev/urandom | tr -d ' \n')"

echo "== operator, with a token"
start_mock "$out/mock-operator.log" --operator --host 127.0.0.1 --token "$token"
node "$here/browser_test.mjs" --url "$url" --token "$token" --mode operator --expect-start \
  --chromium "$chromium" --screenshot "$out/operator.png" --json "$out/operator.json" || status=1
cleanup

echo "== observer, without a token"
start_mock "$out/mock-observer.log" --host 127.0.0.1
node "$here/browser_test.mjs" --url "$url" --mode observer \
  --chromium "$chromium" --screenshot "$out/observer.png" --json "$out/observer.json" || status=1
cleanup

echo "results in $out"
if [ "$status" -ne 0 ]; then echo "run_mock_test: FAIL"; else echo "run_mock_test: PASS"; fi
exit "$status"
