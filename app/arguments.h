// Checks shared by the subcommands' command lines: numbers that must be positive
// and finite, runtime names, and what kind of file an argument really is, so a
// wrong argument is refused with one clear line and exit code 2 instead of being
// ignored or failing deep inside a library.
#pragma once

#include <CLI/CLI.hpp>

#include <string>
#include <vector>

#include "common/exit_codes.h"

namespace rtplc::app {

// A number of seconds > 0 and finite (rejects 0, negatives, nan, inf).
CLI::Validator positive_seconds();
// Like positive_seconds, and at least `min_s` (refresh periods: no busy loop).
CLI::Validator seconds_at_least(double min_s);
// A runtime name: 1 to 31 letters, digits, '_' or '-' (it names files and shared memory).
// A positive number of seconds within [min_s, max_s], with one message.
CLI::Validator seconds_between(double min_s, double max_s);
CLI::Validator runtime_name();

// Prints `msg` on stderr and ends the subcommand with exit code `code`
// (docs/runtime.md, "Exit codes").
[[noreturn]] void fail(const std::string& msg, int code = kExitFailure);

// kSpecial: a FIFO, a device or a socket; never opened (a FIFO would block,
// /dev/zero would never end).
enum class InputKind { kMissing, kFolder, kSpecial, kConfig, kTaskImage, kProgram };
InputKind input_kind(const std::string& path);

// Refuses (exit 2, with what the file is and what to give instead) any input
// that is not one of the kinds `cmd` accepts: an FBD program always, a
// configuration when `config_ok`.
void require_program(const std::string& path, const char* cmd, bool config_ok = false);

// Refuses (exit 2, naming the path and the reason) an output path a command
// could not write or must not write, before any work is done: its folder is
// missing or not writable, it is a folder, or it is one of the command's
// `inputs` (same file: a compile never truncates its own source).
void require_output_path(const std::string& path, const char* cmd, const char* option,
                         const std::vector<std::string>& inputs = {});

}  // namespace rtplc::app
