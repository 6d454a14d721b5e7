# Capacities of every static RT-side array, as cache variables (SOEM's ec_options
# idea): a deployment can raise them at configure time and nothing in a cycle
# ever grows.
set(RTPLC_MAX_TASKS 16 CACHE STRING "Most tasks the scheduler runs")
set(RTPLC_MAX_BLOCKS 65536 CACHE STRING "Most primitive blocks in one task image")
set(RTPLC_MAX_MACRO_BLOCKS 50 CACHE STRING "Most primitive blocks in one macro definition (seed limit)")
set(RTPLC_MAX_MACRO_DEPTH 16 CACHE STRING "Deepest macro-call nesting")
set(RTPLC_MAX_DELAY_SAMPLES 10000 CACHE STRING "Largest n of dely(a, n)")
set(RTPLC_MAX_CHANNELS 16384 CACHE STRING "Most channels in the process image")
configure_file(${CMAKE_CURRENT_LIST_DIR}/../common/capacities.h.in
               ${CMAKE_BINARY_DIR}/generated/common/capacities.h @ONLY)
