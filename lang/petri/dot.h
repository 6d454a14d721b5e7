// Graphviz drawings (issue item 3, `rtplc analyze --dot F`): the net (places as
// circles with their initial tokens, transitions as boxes, weights on arcs, read
// arcs as one double-headed arc) and, when it was kept, the reachability graph
// beside it (markings as boxes, dead markings in red, M0 in bold).
// Render with `dot -Tsvg F -o F.svg` (Debian package graphviz).
#pragma once

#include <string>

#include "lang/petri/net.h"
#include "lang/petri/reachability.h"

namespace rtplc::petri {

std::string write_dot(const Net& net, const ReachabilityGraph* graph = nullptr);

}  // namespace rtplc::petri
