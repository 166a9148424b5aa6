#pragma once
// The graph stream (proto/README.md "Graph and submaps"): what a client holding one version of the
// pose graph needs to reach another, and applying it. A closed submap's grid never changes, so a client
// that holds every grid (GetSubmap, once per id) and the graph holds the whole VOG-Map; after a loop
// closure only the moved base poses travel.

#include "vog/api/domain.hpp"
#include "vog/v1/api.pb.h"

#include <cstdint>
#include <vector>

namespace vog::api {

struct GraphUpdate {
  std::uint64_t version = 0;
  std::uint64_t base_version = 0;  // 0 when full
  bool full = false;               // `submaps` and `closures` are everything: replace what you hold
  std::int64_t stamp_ns = 0;
  std::vector<SubmapPose> submaps;    // new or moved (bitwise different) base poses, ascending id
  std::vector<ClosurePair> closures;  // new closures (appended to the held list)
  std::uint32_t n_submaps = 0;        // closed submaps at `version`
};

// What a client holding `held` needs to reach `now`: the submaps that are new or whose matrix differs
// in any bit, and the closures appended since. A full update when `held` is null, or when `now` is not
// `held` grown (a submap vanished or the closures are not `held`'s followed by new ones).
GraphUpdate graphUpdate(const GraphState* held, const GraphState& now);

// Applies `update` to `held`. A partial update must start from held.version (else an error that says
// to resynchronise, and `held` is unchanged); a full one replaces everything.
Status applyGraphUpdate(GraphState& held, const GraphUpdate& update);

void toProto(const GraphUpdate& update, v1::GraphUpdate& out);
// Validates on the way in: 12 finite doubles per id whose rotation part is orthonormal within 1e-6,
// ids ascending, an even closure list; names what was wrong.
Result<GraphUpdate> fromProto(const v1::GraphUpdate& update);

}  // namespace vog::api
