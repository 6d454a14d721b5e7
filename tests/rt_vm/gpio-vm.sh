#!/bin/sh
# Runs tests/rt_vm/gpio.sh in the PREEMPT_RT VM with a gpio-sim module built for
# the guest kernel (ctest -R rt_vm_gpio does this):
#   tests/rt_vm/gpio-vm.sh CACHE RTPLC [--add FILE...]
# Exit: scripts/rt-vm's (0 passed, 1 a check failed, 77 skipped: the kernel or
# module sources cannot be downloaded and nothing is cached).
set -e
here="$(cd "$(dirname "$0")" && pwd)"
repo="$(cd "$here/../.." && pwd)"
cache="${1:?usage: gpio-vm.sh CACHE RTPLC [--add FILE...]}"
rtplc="${2:?usage: gpio-vm.sh CACHE RTPLC [--add FILE...]}"
shift 2
# The module build needs the unpacked kernel: a first (trivial) boot fetches it.
if ! ls -d "$cache"/linux-image-*/ >/dev/null 2>&1; then
  "$repo/scripts/rt-vm" --cache "$cache" --timeout 300 --run true "$rtplc" || exit $?
fi
status=0
ko="$("$repo/scripts/lib/rt-vm/gpio-sim-build.sh" "$cache")" || status=$?
[ $status -eq 0 ] || exit $status
exec "$repo/scripts/rt-vm" --cache "$cache" --timeout 300 --module configfs --add "$ko" "$@" \
  --script "$here/gpio.sh" "$rtplc"
