#!/bin/sh
# Runs a VM step script (gpio.sh, can.sh) in the PREEMPT_RT VM with a gpio-sim
# module built for the guest kernel and gpio-sim-lib.sh and rtplc-run-lib.sh beside
# it (ctest -R 'rt_vm_(gpio|can)' does this); the other options go to scripts/rt-vm after the script:
#   tests/rt_vm/gpio-vm.sh CACHE RTPLC SCRIPT [--add FILE | --run CMD ...]
# Exit: scripts/rt-vm's (0 passed, 1 a check failed, 77 skipped: the kernel or
# module sources cannot be downloaded and nothing is cached).
set -e
here="$(cd "$(dirname "$0")" && pwd)"
repo="$(cd "$here/../.." && pwd)"
usage="usage: gpio-vm.sh CACHE RTPLC SCRIPT [--add FILE | --run CMD ...]"
cache="${1:?$usage}"
rtplc="${2:?$usage}"
script="${3:?$usage}"
shift 3
# The module build needs the unpacked kernel: a first (trivial) boot fetches it.
if ! ls -d "$cache"/linux-image-*/ >/dev/null 2>&1; then
  "$repo/scripts/rt-vm" --cache "$cache" --timeout 300 --run true "$rtplc" || exit $?
fi
status=0
ko="$("$repo/scripts/lib/rt-vm/gpio-sim-build.sh" "$cache")" || status=$?
[ $status -eq 0 ] || exit $status
exec "$repo/scripts/rt-vm" --cache "$cache" --timeout 300 --module configfs --add "$ko" \
  --add "$here/gpio-sim-lib.sh" --add "$here/rtplc-run-lib.sh" --script "$script" "$@" "$rtplc"
