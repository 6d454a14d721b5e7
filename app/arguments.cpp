// Command-line argument checks (see arguments.h).
#include "app/arguments.h"

#include <sys/stat.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>

#include "app/commands.h"
#include "blocks/image.h"
#include "config/values.h"

namespace rtplc::app {
namespace {

std::string check_seconds(const std::string& text, double min_s) {
  double v = 0;
  size_t used = 0;
  try {
    v = std::stod(text, &used);
  } catch (const std::exception&) {
    return "'" + text + "' is not a number of seconds";
  }
  if (used != text.size()) return "'" + text + "' is not a number of seconds";
  if (!std::isfinite(v) || !(v > 0)) return "must be a positive number of seconds, not " + text;
  if (v < min_s) {
    char b[64];
    std::snprintf(b, sizeof b, "must be at least %g s, not %s", min_s, text.c_str());
    return b;
  }
  return "";
}

bool ends_with(const std::string& s, const char* e) {
  const size_t n = std::strlen(e);
  return s.size() > n && s.compare(s.size() - n, n, e) == 0;
}

}  // namespace

CLI::Validator positive_seconds() {
  return CLI::Validator([](std::string& s) { return check_seconds(s, 0); }, "SECONDS>0");
}

CLI::Validator seconds_at_least(double min_s) {
  return CLI::Validator([min_s](std::string& s) { return check_seconds(s, min_s); }, "SECONDS");
}

CLI::Validator runtime_name() {
  return CLI::Validator(
      [](std::string& s) -> std::string {
        if (config::is_valid_name(s)) return "";
        return "'" + s + "' is not a runtime name (1 to 31 letters, digits, '_' or '-')";
      },
      "NAME");
}

InputKind input_kind(const std::string& path) {
  struct stat st{};
  if (stat(path.c_str(), &st) != 0) return InputKind::kMissing;
  if (S_ISDIR(st.st_mode)) return InputKind::kFolder;
  if (ends_with(path, ".yaml") || ends_with(path, ".yml")) return InputKind::kConfig;
  std::ifstream f(path, std::ios::binary);
  char magic[sizeof kImageMagic] = {};
  f.read(magic, sizeof magic);
  if (f.gcount() == sizeof magic && std::memcmp(magic, kImageMagic, sizeof magic) == 0) {
    return InputKind::kTaskImage;
  }
  return InputKind::kProgram;
}

void require_program(const std::string& path, const char* cmd, bool config_ok) {
  const char* why = nullptr;
  switch (input_kind(path)) {
    case InputKind::kMissing:
      why = "no such file";
      break;
    case InputKind::kFolder:
      why = config_ok ? "is a folder, not a file; give one .fbd program or .yaml configuration"
                      : "is a folder, not a file; give one .fbd program";
      break;
    case InputKind::kConfig:
      if (config_ok) return;
      why = "is a runtime configuration (YAML), not an FBD program; `rtplc check` and "
            "`rtplc run` take configurations";
      break;
    case InputKind::kTaskImage:
      why = "is a compiled task image (.img), not FBD source; give the .fbd it was compiled from";
      break;
    case InputKind::kProgram:
      return;
  }
  std::fprintf(stderr, "rtplc %s: %s: %s\n", cmd, path.c_str(), why);
  throw CLI::RuntimeError(kExitUsage);
}

}  // namespace rtplc::app
