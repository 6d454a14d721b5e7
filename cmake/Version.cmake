# What `rtplc version` prints: the project version, the git commit the tree was
# configured from, and the build type. Taken at configure time (re-run cmake to
# refresh the commit); outside a git checkout the commit is "unknown".
set(RTPLC_GIT_COMMIT "unknown")
find_package(Git QUIET)
if(GIT_FOUND)
  execute_process(COMMAND ${GIT_EXECUTABLE} rev-parse --short HEAD
                  WORKING_DIRECTORY ${PROJECT_SOURCE_DIR}
                  OUTPUT_VARIABLE _rtplc_commit OUTPUT_STRIP_TRAILING_WHITESPACE
                  RESULT_VARIABLE _rtplc_git_rc ERROR_QUIET)
  if(_rtplc_git_rc EQUAL 0 AND _rtplc_commit)
    set(RTPLC_GIT_COMMIT "${_rtplc_commit}")
    execute_process(COMMAND ${GIT_EXECUTABLE} status --porcelain --untracked-files=no
                    WORKING_DIRECTORY ${PROJECT_SOURCE_DIR}
                    OUTPUT_VARIABLE _rtplc_dirty OUTPUT_STRIP_TRAILING_WHITESPACE ERROR_QUIET)
    if(_rtplc_dirty)
      string(APPEND RTPLC_GIT_COMMIT "-dirty")
    endif()
  endif()
endif()
set(RTPLC_BUILD_TYPE_NAME "${CMAKE_BUILD_TYPE}")
if(NOT RTPLC_BUILD_TYPE_NAME)
  set(RTPLC_BUILD_TYPE_NAME "unspecified")
endif()
configure_file(${CMAKE_CURRENT_LIST_DIR}/../common/version.h.in
               ${CMAKE_BINARY_DIR}/generated/common/version.h @ONLY)
