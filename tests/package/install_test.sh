#!/usr/bin/env bash
# Installs the Debian packages on this machine (as root, as CI runs) and checks them as an operator
# would use them, then removes them: README "Running on a vehicle" and packaging/README.md.
#   1. an older vogd (the same files, a lower version) installed, its configuration edited and a
#      mission stored; then the packages installed over it: the edit and the mission are kept;
#   2. the installed files: user vogd in dialout, /var/lib/vogd (0750, vogd), the service neither
#      enabled nor started, `vogd --check-config` on /etc/vogd/vogd.yaml as the vogd user,
#      `systemd-analyze verify` (prints nothing) and `security` (exposure <= 3.0) on the installed unit;
#   3. the installed vogd run as the vogd user on the simulator (the installed scenes) for a few
#      submaps, queried with the installed vogctl (status, a map snapshot) and watched with the
#      installed vog-console (its installed page and three.js served, its mirror filled), stopped with SIGTERM;
#   4. the service enabled, then dpkg --purge: no file of the packages and nothing vogd made is left, except the missions.
# Usage: install_test.sh PACKAGE_DIR (vogd_*.deb, vog-tools_*.deb, vog-sim_*.deb)
set -euo pipefail
[ "$(id -u)" -eq 0 ] || { echo "install_test: needs root (dpkg -i)"; exit 1; }
dir=$(cd "$1" && pwd)
vogd_deb=$(ls "$dir"/vogd_*.deb)
debs=("$vogd_deb" "$(ls "$dir"/vog-tools_*.deb)" "$(ls "$dir"/vog-sim_*.deb)")
fail() { echo "install_test: FAILED: $*" >&2; exit 1; }
step() { echo "-- $*"; }

work=$(mktemp -d)
chmod 755 "$work"
vogd_pid=""
console_pid=""
cleanup() {
  [ -n "$vogd_pid" ] && kill "$vogd_pid" 2> /dev/null || true
  [ -n "$console_pid" ] && kill "$console_pid" 2> /dev/null || true
  dpkg --purge vogd vog-tools vog-sim > /dev/null 2>&1 || true
  rm -rf /var/lib/vogd/missions/package-test /var/lib/vogd/missions/older
  rmdir /var/lib/vogd/missions /var/lib/vogd 2> /dev/null || true
  userdel vogd 2> /dev/null || true
  rm -f /etc/systemd/system/multi-user.target.wants/vogd.service
  rm -rf "$work"
}
trap cleanup EXIT
for p in vogd vog-tools vog-sim; do
  if dpkg-query -W -f='${Status}' "$p" 2> /dev/null | grep -q installed; then
    fail "$p is already installed on this machine; the test installs and purges it"
  fi
done

step "an older vogd, its configuration edited, a mission stored"
dpkg-deb -R "$vogd_deb" "$work/older"
sed -i 's/^Version: .*/Version: 0.0.1-1/' "$work/older/DEBIAN/control"
dpkg-deb --root-owner-group -b "$work/older" "$work/vogd_0.0.1-1.deb" > /dev/null
dpkg -i "$work/vogd_0.0.1-1.deb" > "$work/dpkg-older.log" 2>&1 || { cat "$work/dpkg-older.log"; fail "installing the older vogd"; }
sed -i 's/^  max_submaps: 156 /  max_submaps: 77  /' /etc/vogd/vogd.yaml
grep -q '^  max_submaps: 77 ' /etc/vogd/vogd.yaml || fail "could not edit /etc/vogd/vogd.yaml"
install -d -o vogd -g vogd -m 0750 /var/lib/vogd/missions/older
echo "journal of an older mission" > /var/lib/vogd/missions/older/journal.bin

step "the packages installed over it"
dpkg -i "${debs[@]}" > "$work/dpkg.log" 2>&1 || { cat "$work/dpkg.log"; fail "dpkg -i"; }
[ "$(dpkg-query -W -f='${Version}' vogd)" != 0.0.1-1 ] || fail "vogd was not upgraded"
grep -q '^  max_submaps: 77 ' /etc/vogd/vogd.yaml || fail "the upgrade replaced the operator's configuration"
[ ! -e /etc/vogd/vogd.yaml.dpkg-dist ] || fail "the upgrade left vogd.yaml.dpkg-dist"
[ -s /var/lib/vogd/missions/older/journal.bin ] || fail "the upgrade lost a mission"

step "installed files, user, directories, service state"
for f in /usr/bin/vogd /usr/bin/vogctl /usr/bin/vog-console /usr/bin/vogsim; do [ -x "$f" ] || fail "$f missing"; done
[ -s /usr/share/vog/scenes/pilings.yaml ] || fail "scenes missing"
[ -s /usr/share/vog/console/index.html ] || fail "the console's page missing"
id -nG vogd | grep -qw dialout || fail "user vogd is not in dialout"
[ "$(stat -c '%a %U %G' /var/lib/vogd)" = "750 vogd vogd" ] || fail "/var/lib/vogd is $(stat -c '%a %U %G' /var/lib/vogd)"
[ "$(systemctl is-enabled vogd.service 2>&1 || true)" = disabled ] \
  || fail "vogd.service is '$(systemctl is-enabled vogd.service 2>&1)', expected disabled until configured"
grep -q '^source: devices' /etc/vogd/vogd.yaml || fail "/etc/vogd/vogd.yaml is not set to source: devices"
setpriv --reuid=vogd --regid=vogd --init-groups vogd --config /etc/vogd/vogd.yaml --check-config > "$work/check.log" 2>&1 \
  || { cat "$work/check.log"; fail "vogd --check-config on the installed configuration"; }
systemd-analyze verify /usr/lib/systemd/system/vogd.service > "$work/verify.log" 2>&1 || true
[ ! -s "$work/verify.log" ] || { cat "$work/verify.log"; fail "systemd-analyze verify reported problems"; }
systemd-analyze security --offline=true --no-pager /usr/lib/systemd/system/vogd.service > "$work/security.log" 2>&1 || true
exposure=$(sed -n 's/.*Overall exposure level for vogd.service: \([0-9.]*\).*/\1/p' "$work/security.log")
[ -n "$exposure" ] || { cat "$work/security.log"; fail "no exposure level from systemd-analyze security"; }
awk -v e="$exposure" 'BEGIN { exit !(e <= 3.0) }' || fail "exposure $exposure above 3.0"
echo "   check-config ok, verify silent, exposure $exposure"

step "the installed vogd on the simulator, queried with the installed vogctl"
cat > "$work/vogd.yaml" <<YAML
source: sim
sim:
  scene: /usr/share/vog/scenes/pilings.yaml
  seed: 1
  speedup: 0
mission:
  box_min_m: [-6, -4, -4]
  box_max_m: [6, 4, 0]
  start_on_launch: true
  max_submaps: 4
  directory: /var/lib/vogd/missions
  name: package-test
api:
  bind_address: 127.0.0.1
  port: 0
YAML
setpriv --reuid=vogd --regid=vogd --init-groups vogd --config "$work/vogd.yaml" --port-file /var/lib/vogd/port 2> "$work/vogd.log" &
vogd_pid=$!
for _ in $(seq 1 100); do [ -s /var/lib/vogd/port ] && break; sleep 0.1; done
[ -s /var/lib/vogd/port ] || { tail -20 "$work/vogd.log"; fail "vogd did not start"; }
port=$(cat /var/lib/vogd/port)
submaps=0
for _ in $(seq 1 240); do
  kill -0 "$vogd_pid" 2> /dev/null || { tail -20 "$work/vogd.log"; fail "vogd exited"; }
  line=$(vogctl status --json --port "$port" | head -1)
  submaps=$(sed -n 's/.*"n_submaps":\([0-9]*\).*/\1/p' <<< "$line")
  [ "${submaps:-0}" -ge 3 ] && break
  sleep 0.5
done
[ "${submaps:-0}" -ge 3 ] || { echo "$line"; fail "vogd made ${submaps:-0} submaps in 120 s"; }
vogctl snapshot --out "$work/map.bt" --port "$port" > /dev/null
head -c 64 "$work/map.bt" | grep -q "Octomap" || fail "the snapshot is not an OctoMap file"

# The installed vog-console (as an unprivileged user) serves its installed page and mirrors the map.
install -d -o nobody "$work/console"
setpriv --reuid=nobody --regid=nogroup --clear-groups vog-console --port "$port" --listen 127.0.0.1:0 \
  --port-file "$work/console/port" > "$work/console.log" 2>&1 &
console_pid=$!
for _ in $(seq 1 100); do [ -s "$work/console/port" ] && break; sleep 0.1; done
[ -s "$work/console/port" ] || { tail -20 "$work/console.log"; fail "vog-console did not start"; }
console_check=$(/usr/bin/python3 - "$(cat "$work/console/port")" <<'PY'
import json, sys, time, urllib.request
base = f"http://127.0.0.1:{sys.argv[1]}"
def get(path):
    with urllib.request.urlopen(base + path, timeout=5) as r:
        return r.status, r.read()
for path in ("/", "/app.js", "/node_modules/three/build/three.module.js",
             "/node_modules/three/build/three.core.js", "/node_modules/three/examples/jsm/controls/OrbitControls.js"):
    status, body = get(path)
    if status != 200 or not body:
        sys.exit(f"{path}: HTTP {status}, {len(body)} bytes")
for _ in range(100):
    state = json.loads(get("/api/state")[1])
    if state["mirror"]["submaps"] >= 1 and state["mirror"]["occupied"] > 0:
        print(f"page served, mirror {state['mirror']['submaps']} submaps, {state['mirror']['occupied']} occupied voxels")
        sys.exit(0)
    time.sleep(0.2)
sys.exit(f"the mirror holds nothing after 20 s: {state}")
PY
) || { tail -20 "$work/console.log"; kill "$console_pid"; fail "the installed vog-console: $console_check"; }
kill -TERM "$console_pid"
wait "$console_pid" || { tail -20 "$work/console.log"; fail "vog-console did not stop cleanly on SIGTERM"; }
console_pid=""
echo "   vog-console: $console_check"
kill -TERM "$vogd_pid"
wait "$vogd_pid" || { tail -20 "$work/vogd.log"; fail "vogd did not stop cleanly on SIGTERM"; }
vogd_pid=""
console_pid=""
rm -f /var/lib/vogd/port
ls /var/lib/vogd/missions/package-test/ | grep -q . || fail "the mission folder is empty"
echo "   $submaps submaps, snapshot $(stat -c %s "$work/map.bt") bytes, mission in /var/lib/vogd/missions/package-test"

step "dpkg --purge (of a service the operator had enabled)"
systemctl enable vogd.service > /dev/null 2>&1
[ "$(systemctl is-enabled vogd.service)" = enabled ] || fail "systemctl enable vogd.service"
dpkg -L vogd vog-tools vog-sim > "$work/files.txt"
dpkg --purge vogd vog-tools vog-sim > "$work/purge.log" 2>&1 || { cat "$work/purge.log"; fail "dpkg --purge"; }
left=()
while read -r f; do
  if [ -f "$f" ] || [ -L "$f" ]; then left+=("$f"); fi
  if [ -d "$f" ] && [[ $f == */vog* ]]; then left+=("$f"); fi
done < "$work/files.txt"
[ ${#left[@]} -eq 0 ] || fail "purge left ${left[*]}"
[ ! -e /etc/vogd ] || fail "purge left /etc/vogd: $(ls -A /etc/vogd)"
wants=/etc/systemd/system/multi-user.target.wants/vogd.service
[ ! -L "$wants" ] && [ ! -e "$wants" ] || fail "purge left the service enabled ($wants)"
others=$(find /var/lib/vogd -mindepth 1 ! -path '/var/lib/vogd/missions' ! -path '/var/lib/vogd/missions/package-test*' \
  ! -path '/var/lib/vogd/missions/older*')
[ -z "$others" ] || fail "purge left $others"
[ -d /var/lib/vogd/missions/package-test ] && [ -d /var/lib/vogd/missions/older ] || fail "purge removed the missions"
echo "install_test: ok"
