// The built-in languages. Adding one is its folder under lang/ (a library that
// rtplc_lang links, lang/CMakeLists.txt) and one entry in this list: the
// namespace of its `const FrontEnd kFrontEnd`. The order is the order in which
// a source is recognised by its content (front_end_for); the one without
// `recognises` is the fallback.
#include "lang/front_end.h"

#define RTPLC_BUILTIN_FRONT_ENDS(X) \
  X(plcopen)                        \
  X(sfc)                            \
  X(st)                             \
  X(fbd)                            \
  /* one line per language, above this one */

#define RTPLC_DECLARE_FRONT_END(ns) \
  namespace rtplc::lang::ns {       \
  extern const FrontEnd kFrontEnd;  \
  }
RTPLC_BUILTIN_FRONT_ENDS(RTPLC_DECLARE_FRONT_END)

namespace rtplc::lang {

void register_builtin_front_ends() {
#define RTPLC_REGISTER_FRONT_END(ns) register_front_end(&rtplc::lang::ns::kFrontEnd);
  RTPLC_BUILTIN_FRONT_ENDS(RTPLC_REGISTER_FRONT_END)
}

}  // namespace rtplc::lang
