# Warnings we keep clean (style.md, practice 8).
add_library(rtplc_warnings INTERFACE)
target_compile_options(rtplc_warnings INTERFACE
  -Wall -Wextra -Wshadow -Wconversion -Wsign-conversion -Wnon-virtual-dtor
  -Wold-style-cast -Woverloaded-virtual -Wformat=2)
if(RTPLC_WERROR)
  target_compile_options(rtplc_warnings INTERFACE -Werror)
endif()
