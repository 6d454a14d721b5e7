#!/bin/sh
# The gpio driver on real GPIO lines (the PREEMPT_RT VM, against gpio-sim as
# the independent peer; the host has no /dev/gpiochip). The module is built out
# of tree by scripts/lib/rt-vm/gpio-sim-build.sh and shipped with --add; its
# path is found (or given in $GPIO_SIM_KO); gpio-sim-lib.sh makes the chip. examples/gpio.yaml: a button (line BTN = 0) lights a
# lamp (line 2) and clears an idle light (line 3); line 1 counts pulses.
# Checks: a line name the chip lacks fails the start naming the entry;
# the button read, the outputs read back from gpio-sim's `value`; 1,000 rising
# edges driven through the `pull` attribute -> exactly 1,000 pulses; after
# `rtplc stop` and after a watchdog stop the outputs at their safe values.
# Files live under the step's work folder (the guest's /tmp is a small tmpfs).
fail() { echo "FAILED: $*"; exit 1; }
# --add ships files at their host paths: find the module and the unit test there.
shipped() { find / -name "$1" -type f -not -path '/proc/*' -not -path '/sys/*' 2>/dev/null | head -n1; }
GPIO_UNIT_TEST="${GPIO_UNIT_TEST:-$(shipped test_gpio)}"
# shellcheck source=tests/rt_vm/gpio-sim-lib.sh
. "$(shipped gpio-sim-lib.sh)"
# shellcheck source=tests/rt_vm/rtplc-run-lib.sh
. "$(shipped rtplc-run-lib.sh)"
gpio_sim_up BTN
# A watchdog that never fires: under emulation a 10 ms task overruns now and
# then, and 3 in a row would stop it (driving the safe values) mid-test.
sed -e "s/chip: gpiochip0/chip: $chip/" -e 's/watchdog: 3/watchdog: 1000000/' /examples/gpio.yaml > gpio.yaml
cp /examples/gpio.fbd .
# The outputs' pulls are their safe values (gpio-sim returns a released line
# to its pull; see docs/gpio.md).
pull 2 down
pull 3 up

# 1. Commissioning: the config's lines against the chip; a bad name refused
# with its position, at check and at start.
rtplc gpio info "$chip"
rtplc gpio info --config gpio.yaml || fail "gpio info --config refused a good config"
sed 's/line: BTN/line: NOPE/' gpio.yaml > bad.yaml
ln="$(grep -n 'line: NOPE' bad.yaml | cut -d: -f1)"
if rtplc gpio info --config bad.yaml > bad.log 2>&1; then cat bad.log; fail "a missing line name passed the check"; fi
grep -q "bad.yaml:$ln:[0-9]*: error: chip $chip has no line named 'NOPE'" bad.log || { cat bad.log; fail "no positioned error"; }
if rtplc run bad.yaml --duration 2 > badrun.log 2>&1; then cat badrun.log; fail "ran without its line"; fi
grep -q "inputs entry p0.d0.c0 at line $ln:.*no line named 'NOPE'" badrun.log || { cat badrun.log; fail "no clear start error"; }
echo "ok: a missing line is refused: $(grep -o "no line named 'NOPE'" bad.log | head -1)"
pull 0 down
rtplc gpio get "$chip" BTN | grep -q "line 0 = 0" || fail "gpio get BTN"
rtplc gpio set "$chip" 4=1
echo "ok: gpio get/set work on $chip"

# 2. Run: the button drives the lamp and the idle light.
rtplc run gpio.yaml > run.log 2>&1 &
rtplc_up run.log "the runtime"
settle 2 0 || fail "lamp reads $(value 2) with the button up"
settle 3 1 || fail "idle reads $(value 3) with the button up"
pull 0 up
settle 2 1 || fail "lamp reads $(value 2) with the button pressed"
settle 3 0 || fail "idle reads $(value 3) with the button pressed"
[ "$(mon Button 5)" = "good" ] || { rtplc monitor --once; fail "Button is $(mon Button 5)"; }
echo "ok: button -> lamp $(value 2), idle $(value 3) (read back from gpio-sim's value)"

# 3. 1,000 rising edges through the pull attribute, 2 ms apart: several per
# task cycle (10 ms). Paced because unpaced (back-to-back writes from the
# shell) about 1 edge in 70 never reached the driver under emulation: either
# gpio-sim dropped it (its simulated interrupt is masked while the previous
# edge is handled, and a masked one is not latched, unlike a real
# controller's), or the line's 16-event kernel queue overflowed while the I/O
# thread (below the task band) waited for the CPU. See docs/gpio.md.
[ "$(mon Pulses 4)" = "0" ] || fail "Pulses starts at $(mon Pulses 4)"
n=0
while [ $n -lt 1000 ]; do
  echo pull-up > "$sys/sim_gpio1/pull"
  sleep 0.002
  echo pull-down > "$sys/sim_gpio1/pull"
  sleep 0.002
  n=$((n + 1))
done
i=0
until [ "$(mon Pulses 4)" = "1000" ]; do
  i=$((i + 1)); [ $i -le 50 ] || break; sleep 0.1
done
rtplc monitor --once
[ "$(mon Pulses 4)" = "1000" ] || fail "1000 edges counted as $(mon Pulses 4)"
[ "$(mon Pulses 5)" = "good" ] || { rtplc monitor --once; fail "Pulses is $(mon Pulses 5)"; }
echo "ok: 1000 edges -> Pulses = $(mon Pulses 4)"
rtplc status

# 4. Stop: the safe values (lamp 0, idle 1) with the button still pressed.
rtplc stop
rtplc_down
[ "$(value 2)" = "0" ] || fail "lamp is $(value 2) after stop"
[ "$(value 3)" = "1" ] || fail "idle is $(value 3) after stop"
echo "ok: after rtplc stop: lamp $(value 2), idle $(value 3)"

# 5. The watchdog: a 20 us task overruns at once under emulation and watchdog 1
# stops it; the runtime goes on holding the lines, so what gpio-sim shows now is
# what the driver drives. The pulls and the entries' own `safe` levels (the
# request's initial level) are the opposite of the task's safe values, so only
# the task's safe values driven by the driver read Lamp 0, Idle 1.
pull 2 up
pull 3 down
sed -e 's/watchdog: 1000000/watchdog: 1\n    period: 20us/' -e 's/line: 2, safe: 0/line: 2, safe: 1/' \
    -e 's/line: 3, safe: 1/line: 3, safe: 0/' gpio.yaml > wd.yaml
rtplc run wd.yaml > wd.log 2>&1 &
i=0
until rtplc status 2>/dev/null | grep -q 'STOPPED (watchdog)'; do
  i=$((i + 1))
  [ $i -le 100 ] || { rtplc status; cat wd.log; fail "the watchdog did not stop the 20 us task"; }
  sleep 0.2
done
settle 2 0 || fail "lamp reads $(value 2) after the watchdog stop (safe 0)"
settle 3 1 || fail "idle reads $(value 3) after the watchdog stop (safe 1)"
echo "ok: watchdog stop -> lamp $(value 2), idle $(value 3) while the runtime holds the lines"
rtplc stop

# 6. The host's libgpiod unit test runs here against a real chip, if shipped.
if [ -n "$GPIO_UNIT_TEST" ]; then
  "$GPIO_UNIT_TEST" --gtest_filter='GpiodChip.*' > unit.txt 2>&1 || { cat unit.txt; fail "unit tests"; }
  cat unit.txt
  ! grep -q SKIPPED unit.txt || fail "the chip test skipped with a chip present"
fi
