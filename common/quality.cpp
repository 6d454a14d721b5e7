// Names and ordering of channel qualities (see quality.h).
#include "common/quality.h"

namespace rtplc {

const char* quality_name(Quality q) {
  switch (q) {
    case Quality::kGood: return "good";
    case Quality::kStale: return "stale";
    case Quality::kBad: return "bad";
    case Quality::kForced: return "forced";
  }
  return "?";
}

namespace {
int rank(Quality q) {
  switch (q) {
    case Quality::kBad: return 0;
    case Quality::kStale: return 1;
    case Quality::kGood:
    case Quality::kForced: return 2;
  }
  return 0;
}
}  // namespace

Quality worse(Quality a, Quality b) { return rank(a) <= rank(b) ? a : b; }

}  // namespace rtplc
