#!/usr/bin/env bash
# The layout check fails on each kind of violation: a scratch tree with one include per rule broken
# (and one allowed include of each kind) must give exactly the expected violations.
#   tests/layout/check_layout_rejects.sh CHECK_LAYOUT_SCRIPT
set -euo pipefail
check="$1"
tree=$(mktemp -d)
trap 'rm -rf "$tree"' EXIT

header() {  # folder/.../vog/name/file.hpp, include lines...
  local file="$tree/$1"
  shift
  mkdir -p "$(dirname "$file")"
  printf '#pragma once\n' > "$file"
  for inc in "$@"; do printf '#include "%s"\n' "$inc" >> "$file"; done
}
header core/base/include/vog/core/result.hpp
header drivers/dvl/include/vog/dvl/pd0.hpp "vog/core/result.hpp" "vog/map/grid.hpp"
header sim/world/include/vog/sim/world.hpp "vog/dvl/pd0.hpp" "vog/slam/graph.hpp"
header daemon/map/include/vog/map/grid.hpp "vog/core/result.hpp" "vog/sim/world.hpp" "vog/eval/score.hpp"
header daemon/slam/include/vog/slam/graph.hpp "vog/map/grid.hpp" "vog/nowhere/x.hpp"
header daemon/app/src/sim_source.cpp "vog/sim/world.hpp"
header eval/include/vog/eval/score.hpp "vog/sim/world.hpp" "vog/slam/graph.hpp"

set +e
out=$("$check" "$tree")
rc=$?
set -e
expected=$(printf '%s\n' \
  "daemon/map/include/vog/map/grid.hpp:3: sim:" \
  "daemon/map/include/vog/map/grid.hpp:4: eval:" \
  "daemon/slam/include/vog/slam/graph.hpp:3: unknown:" \
  "drivers/dvl/include/vog/dvl/pd0.hpp:3: drivers:" \
  "sim/world/include/vog/sim/world.hpp:3: sim:")
got=$(sed -n 's/^\([^:]*:[0-9]*: [a-z]*:\).*/\1/p' <<<"$out" | sort)
if [[ $rc -ne 1 || "$got" != "$expected" ]]; then
  echo "check_layout_rejects: exit $rc, violations:"
  echo "$out"
  echo "expected:"
  echo "$expected"
  exit 1
fi
echo "check_layout_rejects: ok (5 violations found, the allowed includes passed)"
