#!/usr/bin/env bash
# Checks that #include "vog/..." lines follow the layering core <- drivers <- sim, daemon <- eval:
#   core:    core/ includes only headers of core/;
#   drivers: drivers/ includes only headers of core/ and drivers/;
#   sim:     sim/ (the simulated world and vehicle) includes only core/, drivers/ and sim/;
#   daemon:  daemon/ includes neither the evaluation (eval/) nor the simulator (sim/), except vogd's
#            simulator source, daemon/app/src/sim_source.cpp and its header.
# Which folder owns an include prefix vog/<name>/ is read from the tree: the top-level folder of every
# directory named vog/<name> that holds headers or .proto files (an unknown prefix is an error too).
#   tests/layout/check_layout.sh [SOURCE_ROOT]      (default: the repository holding this script)
# Prints one line per violation, FILE:LINE: rule: what, and exits 1 if there is any.
set -euo pipefail

root="${1:-$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)}"
cd "$root"

# The top-level folders that hold sources; build trees and git metadata are not looked at.
top_dirs=(core drivers sim daemon eval client proto)
sim_exceptions=(daemon/app/src/sim_source.cpp daemon/app/include/vog/app/sim_source.hpp)

# prefix -> owning top-level folder.
declare -A owner
while IFS= read -r dir; do
  name="${dir##*/vog/}"
  top="${dir%%/*}"
  folder="$top"
  if [[ -n "${owner[$name]:-}" && "${owner[$name]}" != "$folder" ]]; then
    echo "$dir: layout: vog/$name/ is provided by both ${owner[$name]} and $folder" >&2
    exit 1
  fi
  owner[$name]="$folder"
done < <(find "${top_dirs[@]}" -type d -path '*/vog/*' -not -path '*/vog/*/*' 2>/dev/null |
         while IFS= read -r d; do
           if compgen -G "$d/*.hpp" >/dev/null || compgen -G "$d/*.h" >/dev/null || compgen -G "$d/*.proto" >/dev/null; then
             echo "$d"
           fi
         done | sort)

if [[ ${#owner[@]} -eq 0 ]]; then
  echo "check_layout: no vog/<name> header folders found under $root" >&2
  exit 2
fi

violations=0
report() {  # file line rule text
  echo "$1:$2: $3: $4"
  violations=$((violations + 1))
}

while IFS= read -r hit; do
  file="${hit%%:*}"
  rest="${hit#*:}"
  line="${rest%%:*}"
  text="${rest#*:}"
  [[ "$text" =~ ^[[:space:]]*#[[:space:]]*include[[:space:]]*[\"\<]vog/([A-Za-z0-9_]+)/ ]] || continue
  name="${BASH_REMATCH[1]}"
  inc="vog/$name/"
  from="${file%%/*}"
  to="${owner[$name]:-}"
  if [[ -z "$to" ]]; then
    report "$file" "$line" "unknown" "includes $inc, which no folder provides"
    continue
  fi
  case "$from" in
    core)
      [[ "$to" == core ]] || report "$file" "$line" "core" "core/ includes $inc of $to/ (core depends on nothing of ours)" ;;
    drivers)
      [[ "$to" == core || "$to" == drivers ]] ||
        report "$file" "$line" "drivers" "drivers/ includes $inc of $to/ (drivers depend on core only)" ;;
    sim)
      [[ "$to" == core || "$to" == drivers || "$to" == sim ]] ||
        report "$file" "$line" "sim" "sim/ includes $inc of $to/ (the simulator depends on core and drivers only)" ;;
    daemon)
      if [[ "$to" == eval ]]; then
        report "$file" "$line" "eval" "daemon/ includes the evaluation's $inc"
      elif [[ "$to" == sim ]]; then
        allowed=0
        for e in "${sim_exceptions[@]}"; do [[ "$file" == "$e" ]] && allowed=1; done
        [[ $allowed -eq 1 ]] ||
          report "$file" "$line" "sim" "daemon/ includes the simulator's $inc (only vogd's sim_source may)"
      fi ;;
  esac
done < <(grep -rnE '^[[:space:]]*#[[:space:]]*include[[:space:]]*["<]vog/' core drivers sim daemon \
           --include='*.hpp' --include='*.h' --include='*.cpp' --include='*.cc' 2>/dev/null | sort)

if [[ $violations -gt 0 ]]; then
  echo "check_layout: $violations violation(s)" >&2
  exit 1
fi
echo "check_layout: ok (${#owner[@]} include prefixes: $(printf '%s ' "${!owner[@]}" | tr ' ' '\n' | sort | tr '\n' ' '))"
