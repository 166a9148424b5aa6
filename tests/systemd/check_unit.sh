#!/bin/sh
# Checks the systemd files with systemd's own tools: `systemd-analyze verify` of the unit must print
# nothing (it exits 0 even for unknown keys, so its output is the verdict), its offline security
# exposure must stay at or below the limit, and the sysusers and tmpfiles files, applied to an empty
# root, must create the vogd user and its state directory (mode 0750, owned by vogd). The unit's
# /usr/bin/vogd is replaced by the built binary so that verify checks a real executable.
# Usage: check_unit.sh SYSTEMD_DIR VOGD_BINARY MAX_EXPOSURE
set -eu
dir=$(cd "$1" && pwd)
unit=$dir/vogd.service
sysusers=$dir/vogd.sysusers
tmpfiles=$dir/vogd.tmpfiles
vogd=$2
max_exposure=$3
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
sed "s|/usr/bin/vogd|$vogd|g" "$unit" > "$work/vogd.service"
if ! systemd-analyze verify "$work/vogd.service" > "$work/verify.out" 2>&1; then
  echo "systemd-analyze verify failed:"; cat "$work/verify.out"; exit 1
fi
if [ -s "$work/verify.out" ]; then
  echo "systemd-analyze verify reported problems:"; cat "$work/verify.out"; exit 1
fi
systemd-analyze security --offline=true --no-pager "$work/vogd.service" > "$work/security.out" 2>&1 || true
exposure=$(sed -n 's/.*Overall exposure level for vogd.service: \([0-9.]*\).*/\1/p' "$work/security.out")
if [ -z "$exposure" ]; then
  echo "no exposure level in systemd-analyze security output:"; cat "$work/security.out"; exit 1
fi
echo "exposure $exposure (limit $max_exposure)"
awk -v e="$exposure" -v m="$max_exposure" 'BEGIN { exit !(e <= m) }' || { echo "exposure $exposure above $max_exposure"; exit 1; }

root="$work/root"
mkdir -p "$root/etc"
printf 'root:x:0:0::/root:/bin/sh\n' > "$root/etc/passwd"
printf 'root:x:0:\ndialout:x:20:\n' > "$root/etc/group"
systemd-sysusers --root="$root" "$sysusers" > "$work/sysusers.out" 2>&1 || { cat "$work/sysusers.out"; exit 1; }
uid=$(awk -F: '$1 == "vogd" { print $3 }' "$root/etc/passwd")
[ -n "$uid" ] || { echo "sysusers did not create the vogd user"; exit 1; }
grep -q '^dialout:.*vogd' "$root/etc/group" || { echo "vogd is not in dialout"; exit 1; }
if [ "$(id -u)" -ne 0 ]; then echo "tmpfiles not applied (needs root to chown)"; exit 0; fi
systemd-tmpfiles --root="$root" --create "$tmpfiles" > "$work/tmpfiles.out" 2>&1 || { cat "$work/tmpfiles.out"; exit 1; }
state=$(stat -c '%a %u' "$root/var/lib/vogd/missions")
[ "$state" = "750 $uid" ] || { echo "/var/lib/vogd/missions is '$state', expected '750 $uid'"; exit 1; }
echo "sysusers and tmpfiles ok (vogd uid $uid)"
