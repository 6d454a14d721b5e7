// Generators of the Model Checking Contest's scalable P/T models, to check the
// analyser against the contest's published figures (issue items 3 and 4):
//   philosophers(N)  5N places, 5N transitions: 3^N markings (N=10: 59,049 markings,
//                    459,270 edges)
//   kanban(N)        16 places, 16 transitions, N cards per station: N=1 160 markings,
//                    N=2 4,600, N=5 2,546,432 markings and 24,460,016 edges
// The nets are built from their descriptions, not read from the contest's files;
// `rtplc analyze --generate kanban-5 --write-pnml F` exports them for other tools.
#pragma once

#include <cstdint>
#include <string_view>

#include "common/result.h"
#include "lang/petri/net.h"

namespace rtplc::petri {

Net philosophers(uint32_t n);
Net kanban(uint32_t n);

// "philosophers-10", "kanban-5".
Result<Net> generate(std::string_view spec);

}  // namespace rtplc::petri
