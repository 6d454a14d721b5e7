#!/bin/sh
# bench_drive's VM half (`scripts/bench drive --vm`; issue 10, item 5): counts,
# not timing, on the real kernel interfaces in the PREEMPT_RT VM (software
# emulation: a guest second is not a host second, so no rate is claimed as
# reached; the rates below are what the peers were asked for).
#   CAN   cangen puts N frames of 0x181 on vcan0 with a given gap; candump
#         (an independent listener) counts what was on the bus, the can
#         driver's received-frame counter (`rtplc stats --json`,
#         polls_completed) what rtplc took.
#   GPIO  N pulses driven through gpio-sim's `pull` attribute with a given
#         pause (none: back to back from the shell); the dpi channel's count
#         against N.
# Prints one line per run; fails only when the harness itself does (a count
# below the sent one is a finding, reported, not a failure).
# Needs: cansend/cangen/candump and gpio-sim.ko shipped with --add (scripts/bench does).
fail() { echo "FAILED: $*"; exit 1; }
for t in cangen candump; do command -v $t >/dev/null || fail "$t missing (package can-utils)"; done
up() {  # waits for the runtime's control socket
  i=0
  until rtplc status >/dev/null 2>&1; do
    i=$((i + 1)); [ $i -le 150 ] || { cat "$1"; fail "the runtime did not come up"; }
    sleep 0.2
  done
}
down() {
  rtplc stop >/dev/null 2>&1 || true
  i=0
  while rtplc status >/dev/null 2>&1; do i=$((i + 1)); [ $i -le 50 ] || fail "the runtime did not stop"; sleep 0.2; done
}
# A counter read until it holds still (the driver publishes it every 100 ms).
steady() {
  a="$($1)"
  while :; do sleep 0.4; b="$($1)"; [ "$a" = "$b" ] && break; a="$b"; done
  echo "$a"
}

# ---- CAN --------------------------------------------------------------------------
modprobe vcan
modprobe can-raw
ip link add dev vcan0 type vcan
ip link set vcan0 up
cp /examples/drive.yaml /examples/drive.fbd .
rtplc run drive.yaml > can-run.log 2>&1 &
up can-run.log
frames_rx() { rtplc stats --json | grep -o '"polls_completed": [0-9]*' | head -n1 | awk '{print $2}'; }
echo "counts: CAN, frames of 0x181 (3 bytes) from cangen on vcan0 to the can driver of examples/drive.yaml"
for run in "10 300" "1 2000" "0 5000"; do
  set -- $run
  gap=$1 n=$2
  candump -L vcan0,181:7FF > dump.log &
  DUMP=$!
  sleep 0.3
  before="$(steady frames_rx)"
  cangen vcan0 -I 181 -L 3 -D B80B01 -g "$gap" -n "$n" || echo "  (cangen exited $?)"
  after="$(steady frames_rx)"
  kill $DUMP; wait $DUMP 2>/dev/null || true
  seen="$(wc -l < dump.log)"
  got=$((after - before))
  echo "  gap ${gap} ms (asked $( [ "$gap" = 0 ] && echo 'as fast as cangen can' || echo "$((1000 / gap)) frames/s")):" \
       "sent $n, candump saw $seen, rtplc received $got, lost $((n - got))"
done
down

# ---- GPIO -------------------------------------------------------------------------
GPIO_SIM_KO="${GPIO_SIM_KO:-$(find / -name gpio-sim.ko -type f -not -path '/proc/*' -not -path '/sys/*' 2>/dev/null | head -n1)}"
[ -f "$GPIO_SIM_KO" ] || fail "no gpio-sim.ko shipped (--add PATH)"
modprobe configfs
grep -q ' /sys/kernel/config ' /proc/mounts || mount -t configfs none /sys/kernel/config
insmod "$GPIO_SIM_KO"
cfs=/sys/kernel/config/gpio-sim/chip0
mkdir $cfs $cfs/bank0 $cfs/bank0/line0
echo 8 > $cfs/bank0/num_lines
echo BTN > $cfs/bank0/line0/name
echo 1 > $cfs/live
chip="$(cat $cfs/bank0/chip_name)"
sys="/sys/devices/platform/$(cat $cfs/dev_name)/$chip"
sed -e "s/chip: gpiochip0/chip: $chip/" -e 's/watchdog: 3/watchdog: 1000000/' /examples/gpio.yaml > gpio.yaml
cp /examples/gpio.fbd .
echo pull-down > "$sys/sim_gpio2/pull"
echo pull-up > "$sys/sim_gpio3/pull"
echo pull-down > "$sys/sim_gpio1/pull"
rtplc run gpio.yaml > gpio-run.log 2>&1 &
up gpio-run.log
pulses() { rtplc monitor --once | awk '$1 == "Pulses" {print $4; exit}'; }
echo "counts: GPIO, rising edges on $chip line 1 through gpio-sim's pull attribute to the dpi counter of examples/gpio.yaml"
for run in "0.002 500" "0.0005 500" "none 500"; do
  set -- $run
  pause=$1 n=$2
  before="$(steady pulses)"
  k=0
  while [ $k -lt "$n" ]; do
    echo pull-up > "$sys/sim_gpio1/pull"
    [ "$pause" = none ] || sleep "$pause"
    echo pull-down > "$sys/sim_gpio1/pull"
    [ "$pause" = none ] || sleep "$pause"
    k=$((k + 1))
  done
  after="$(steady pulses)"
  got=$((after - before))
  if [ "$pause" = none ]; then what="no pause (back to back)"; else what="a ${pause} s pause after each edge"; fi
  echo "  $what: generated $n, counted $got, lost $((n - got))"
done
down
echo "OK: counts reported (no timing: the guest is emulated)"
