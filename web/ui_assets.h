// The console's front end (web/ui/), built into the binary by
// web/embed_ui.cmake, so `rtplc web` needs no files beside it and no Node.
#pragma once

#include <cstddef>

namespace rtplc::web {

struct UiAsset {
  const char* path;  // "/index.html", "/app.js", ...
  const char* type;  // its Content-Type
  const char* body;
};

extern const UiAsset kUiAssets[];
extern const size_t kUiAssetCount;

}  // namespace rtplc::web
