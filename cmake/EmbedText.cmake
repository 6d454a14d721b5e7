# Writes OUT, a C++ file defining one `extern const char NAME[]` in namespace
# NAMESPACE per entry of FILES (with NAMES beside it), holding that file's text.
# Run as a build step (cmake -P), so the text follows its file on every build.
# Used for the sources rtplc compiles into a task's native code (blocks/native.cpp).
# FILES and NAMES are separated by `|` (a `;` would split the command line).
string(REPLACE "|" ";" FILES "${FILES}")
string(REPLACE "|" ";" NAMES "${NAMES}")
set(_out "// Generated at build time by cmake/EmbedText.cmake; do not edit.\nnamespace ${NAMESPACE} {\n")
list(LENGTH FILES _n)
math(EXPR _last "${_n} - 1")
foreach(_i RANGE ${_last})
  list(GET FILES ${_i} _file)
  list(GET NAMES ${_i} _name)
  file(READ "${_file}" _text)
  string(FIND "${_text}" ")RTPLC_TEXT\"" _clash)
  if(NOT _clash EQUAL -1)
    message(FATAL_ERROR "${_file} holds the raw string delimiter )RTPLC_TEXT\"")
  endif()
  string(APPEND _out "extern const char ${_name}[];\nconst char ${_name}[] = R\"RTPLC_TEXT(${_text})RTPLC_TEXT\";\n")
endforeach()
string(APPEND _out "}  // namespace ${NAMESPACE}\n")
file(WRITE "${OUT}.tmp" "${_out}")
file(COPY_FILE "${OUT}.tmp" "${OUT}" ONLY_IF_DIFFERENT)
