#pragma once
// The graph stream (proto/README.md "Graph and submaps"): what a client holding one version of the
// pose graph needs to reach another, and applying it. A closed submap's grid never changes, so a client
// that holds every grid (GetSubmap, once per id) and the graph holds the whole VOG-Map; after a loop
// closure only the moved base poses travel.

#include "vog/api/domain.hpp"
#include "vog/v1/api.pb.h"

#include <array>
#include <cstdint>
#include <vector>

namespace vog::api {

// A held submap's base pose that moved, as the bits of its 12 doubles (rows 0-2 of the matrix, row-major)
// XOR the bits of the pose held at the base version: a loop closure moves poses by little, so the high
// bytes (sign, exponent, leading mantissa) mostly cancel and the wire carries the rest.
struct PoseChange {
  std::uint32_t id = 0;
  std::array<std::uint64_t, 12> bits_xor{};
};

struct GraphUpdate {
  std::uint64_t version = 0;
  std::uint64_t base_version = 0;  // 0 when full
  bool full = false;               // `submaps` and `closures` are everything: replace what you hold
  std::int64_t stamp_ns = 0;
  std::vector<SubmapPose> submaps;    // full: every pose; else the new submaps' poses; ascending id
  std::vector<PoseChange> moved;      // not full: held submaps whose pose changed in any bit; ascending id
  std::vector<ClosurePair> closures;  // new closures (appended to the held list)
  std::uint32_t n_submaps = 0;        // closed submaps at `version`
};

// What a client holding `held` needs to reach `now`: the new submaps, the held ones whose matrix differs
// in any bit (as changes), and the closures appended since. A full update when `held` is null, or when
// `now` is not `held` grown (a submap vanished or the closures are not `held`'s followed by new ones).
GraphUpdate graphUpdate(const GraphState* held, const GraphState& now);

// Applies `update` to `held` and returns the poses it set (new and moved, ascending id; every pose for
// a full one). A partial update must start from held.version and change only held submaps into valid
// poses (else an error, one that says to resynchronise, and `held` is unchanged).
Result<std::vector<SubmapPose>> applyGraphUpdate(GraphState& held, const GraphUpdate& update);

void toProto(const GraphUpdate& update, v1::GraphUpdate& out);
// Validates on the way in: 12 finite doubles per id whose rotation part is orthonormal within 1e-6,
// well-formed changes (validated as poses once applied), ids ascending, an even closure list; names
// what was wrong.
Result<GraphUpdate> fromProto(const v1::GraphUpdate& update);

}  // namespace vog::api
