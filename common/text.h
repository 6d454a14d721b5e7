// Small text helpers shared by the compiler's messages, the docs generators, the
// plant descriptions and the runtime's shared-memory tables.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

namespace rtplc {

// A number as a person writes it: "%g" (0.1, 50, 1e-06).
std::string format_number(double v);

// `s` widened with spaces to `width` characters (left-aligned table cells).
std::string pad_right(std::string s, size_t width);

// Copies `s` into a fixed, NUL-terminated field of `cap` bytes (truncating),
// zero-filling the rest so no stale bytes reach shared memory.
void copy_text(char* dst, size_t cap, std::string_view s);

// Appends code point `cp` (at most U+10FFFF) to `out` in UTF-8; a lone UTF-16
// surrogate half (U+D800..U+DFFF) as its own three bytes.
void append_utf8(std::string& out, uint32_t cp);

}  // namespace rtplc
