#!/bin/sh
# Sourced by the VM steps that start `rtplc run` in the background (gpio.sh,
# can.sh, bench/drive/vm-counts.sh); shipped beside gpio-sim-lib.sh by
# gpio-vm.sh, found the same way:
#   . "$(shipped rtplc-run-lib.sh)"
#   rtplc run my.yaml > run.log 2>&1 &
#   rtplc_up run.log "the runtime"   # or fail, showing run.log
# Uses the step's fail(). Defines
#   rtplc_up LOG [WHAT]  waits until `rtplc status` answers; after 150 tries
#                        0.2 s apart (emulation is slow, not wrong) shows LOG
#                        and fails "WHAT did not come up"
#   rtplc_down           waits until `rtplc status` no longer answers (after
#                        `rtplc stop`); after 50 tries fails
#   mon LABEL COLUMN     the COLUMNth field of LABEL's row in `rtplc monitor
#                        --once` (4: value, 5: quality)
rtplc_up() {
  i=0
  until rtplc status >/dev/null 2>&1; do
    i=$((i + 1))
    [ $i -le 150 ] || { cat "$1"; fail "${2:-the runtime} did not come up"; }
    sleep 0.2
  done
}
rtplc_down() {
  i=0
  while rtplc status >/dev/null 2>&1; do
    i=$((i + 1))
    [ $i -le 50 ] || fail "the runtime did not stop"
    sleep 0.2
  done
}
mon() { rtplc monitor --once | awk -v l="$1" -v c="$2" '$1 == l {print $c; exit}'; }
