// Command-line argument checks (see arguments.h).
#include "app/arguments.h"

#include <sys/stat.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>

#include "app/commands.h"
#include "blocks/image.h"
#include "common/files.h"
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

void fail(const std::string& msg, int code) {
  std::fprintf(stderr, "%s\n", msg.c_str());
  throw CLI::RuntimeError(code);
}

CLI::Validator positive_seconds() {
  return CLI::Validator([](std::string& s) { return check_seconds(s, 0); }, "SECONDS>0");
}

CLI::Validator seconds_at_least(double min_s) {
  return CLI::Validator([min_s](std::string& s) { return check_seconds(s, min_s); }, "SECONDS");
}

CLI::Validator seconds_between(double min_s, double max_s) {
  return CLI::Validator(
      [min_s, max_s](std::string& s) -> std::string {
        std::string e = check_seconds(s, 0);
        if (!e.empty()) return e;
        const double v = std::stod(s);
        if (v < min_s || v > max_s) {
          char b[96];
          std::snprintf(b, sizeof b, "must be %g to %g s, not %s", min_s, max_s, s.c_str());
          return b;
        }
        return "";
      },
      "SECONDS");
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
  if (!S_ISREG(st.st_mode)) return InputKind::kSpecial;
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
    case InputKind::kSpecial:
      why = "is not a regular file (a FIFO, device or socket); give a program file";
      break;
    case InputKind::kConfig:
      if (config_ok) return;
      why = "is a runtime configuration (YAML), not an FBD program; `rtplc check` and "
            "`rtplc run` take configurations";
      break;
    case InputKind::kTaskImage:
      // Verified on load wherever a program is accepted; only compiling it again makes no sense.
      if (std::strcmp(cmd, "compile") != 0) return;
      why = "is already a compiled task image (.img); give the program it was compiled from";
      break;
    case InputKind::kProgram:
      return;
  }
  std::fprintf(stderr, "rtplc %s: %s: %s\n", cmd, path.c_str(), why);
  throw CLI::RuntimeError(kExitUsage);
}

void require_output_path(const std::string& path, const char* cmd, const char* option,
                         const std::vector<std::string>& inputs) {
  std::string why;
  struct stat st{};
  const std::string dir = folder_of(path);
  struct stat dst{};
  if (path.empty()) {
    why = "is empty";
  } else if (stat(path.c_str(), &st) == 0 && S_ISDIR(st.st_mode)) {
    why = "is a folder; give a file name inside it";
  } else if (stat(dir.c_str(), &dst) != 0) {
    why = "cannot be written: the folder " + dir + " does not exist";
  } else if (!S_ISDIR(dst.st_mode)) {
    why = "cannot be written: " + dir + " is not a folder";
  } else if (access(dir.c_str(), W_OK) != 0) {
    why = "cannot be written: the folder " + dir + " is not writable (" + std::strerror(errno) + ")";
  } else if (stat(path.c_str(), &st) == 0 && !S_ISREG(st.st_mode)) {
    why = "exists and is not a regular file";
  } else {
    for (const std::string& in : inputs) {
      if (same_file(in, path)) {
        why = "is the input " + in + "; refusing to overwrite a source";
        break;
      }
    }
  }
  if (why.empty()) return;
  std::fprintf(stderr, "rtplc %s: %s %s %s\n", cmd, option, path.c_str(), why.c_str());
  throw CLI::RuntimeError(kExitUsage);
}

}  // namespace rtplc::app
