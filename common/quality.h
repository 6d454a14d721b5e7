// The quality of a channel's value (spec runtime.md, "The process image":
// good / stale / bad / forced): one encoding for the process image, every
// driver and every tool. Zero is bad, so memory nobody has written yet — a new
// image, a snapshot slot a writer never filled — never reads as good.
#pragma once

#include <cstdint>

namespace rtplc {

enum class Quality : uint8_t {
  kBad = 0,     // no value we can vouch for: the peer is gone, the value is not finite, ...
  kGood = 1,    // fresh from its source
  kStale = 2,   // the last good value, older than its source's update period allows
  kForced = 3,  // set by an operator, not by its source
};

const char* quality_name(Quality q);

// The worse of two qualities (bad < stale < good; forced counts as good here:
// forcing is the operator's word, shown as such).
Quality worse(Quality a, Quality b);

}  // namespace rtplc
