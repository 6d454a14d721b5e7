#!/bin/sh
# The can driver on a real SocketCAN stack (the PREEMPT_RT VM; the host has no
# PF_CAN), against can-utils as the independent peer: cansend plays the drive's
# status frames (and cangen repeats them), candump records what rtplc sends. examples/drive.yaml runs the
# seed's PID macro in a speed loop through frame 0x181 (in) and 0x201 (out),
# with its run switch on a gpio-sim line (gpio-sim-lib.sh; gpio-vm.sh builds the module).
# Checks: an interface that does not exist fails the start clearly; frames in
# -> channel values; outputs -> frames with the right id, bytes and period; a
# peer that stops -> bad quality after the frame's timeout (and the program
# drops Enable); `rtplc stop` -> the safe values on the bus; `rtplc can dump`
# decodes by the config's mapping; the run switch off drops Enable.
# Files live under the step's work folder (the guest's /tmp is a small tmpfs).
fail() { echo "FAILED: $*"; exit 1; }
for t in cansend cangen candump; do
  command -v $t >/dev/null || fail "$t missing: run the VM with --add /usr/bin/$t (package can-utils)"
done
modprobe vcan
modprobe can-raw
ip link add dev vcan0 type vcan
ip link set vcan0 up
shipped() { find / -name "$1" -type f -not -path '/proc/*' -not -path '/sys/*' 2>/dev/null | head -n1; }
# shellcheck source=tests/rt_vm/gpio-sim-lib.sh
. "$(shipped gpio-sim-lib.sh)"
# shellcheck source=tests/rt_vm/rtplc-run-lib.sh
. "$(shipped rtplc-run-lib.sh)"
gpio_sim_up RUN
pull 0 up  # the run switch is on
# A watchdog that never fires (as in gpio.sh): under emulation on a loaded host
# a 20 ms task overruns now and then, and 3 in a row would stop it mid-test.
nowd='s/watchdog: 3/watchdog: 1000000/'
sed -e "s/chip: gpiochip0/chip: $chip/" -e "$nowd" /examples/drive.yaml > drive.yaml
cp /examples/drive.fbd .

# 1. A missing interface fails at start, saying which.
sed 's/interface: vcan0/interface: vcan9/' drive.yaml > missing.yaml
if rtplc run missing.yaml --duration 2 > missing.log 2>&1; then cat missing.log; fail "ran without its interface"; fi
grep -q "CAN interface 'vcan9' does not exist" missing.log || { cat missing.log; fail "no clear message for vcan9"; }
echo "ok: a missing interface fails the start: $(grep -o "CAN interface 'vcan9' does not exist" missing.log)"

# 2. Run the loop; candump logs every 0x201 frame with its timestamp.
candump -L vcan0,201:7FF > tx.log &
DUMP=$!
rtplc run drive.yaml > run.log 2>&1 &
RUN=$!
rtplc_up run.log "the runtime"
# (replaces gpio-sim-lib.sh's value(): here a label's value in the monitor)
value() { mon "$1" 4; }
quality() { mon "$1" 5; }
[ "$(quality Speed)" = "bad" ] || fail "Speed is $(quality Speed) before any frame came"

# The drive reports 300.0 rpm (3000 = 0x0BB8, little-endian, 0.1 rpm) and ready.
# cangen sends it every 10 ms for 3 s (one process: steadier than a cansend loop
# under emulation); a single cansend first shows the one-shot path.
# It runs until killed: under emulation on a loaded host seconds stretch, and a
# peer that ran out of frames mid-check would look like one that stopped.
cansend vcan0 181#B80B01
cangen vcan0 -I 181 -L 3 -D B80B01 -g 10 &
PEER=$!
sleep 1.5
rtplc monitor --once
[ "$(quality Speed)" = "good" ] || fail "Speed is $(quality Speed) while the drive sends"
awk -v v="$(value Speed)" 'BEGIN { exit !(v > 299.9 && v < 300.1) }' || fail "Speed reads $(value Speed), not 300"
[ "$(value Ready)" = "1" ] || fail "Ready reads $(value Ready)"
[ "$(value Enable)" = "1" ] || fail "Enable is $(value Enable) with a good speed and a ready drive"
# The run switch off drops Enable on the bus; on again, it comes back.
enable_is() {
  for i in 1 2 3 4 5 6 7 8 9 10; do [ "$(value Enable)" = "$1" ] && return 0; sleep 0.3; done
  return 1
}
pull 0 down
enable_is 0 || fail "Enable is $(value Enable) with the run switch off"
[ "$(value Run)" = "0" ] && [ "$(quality Run)" = "good" ] || fail "Run reads $(value Run) ($(quality Run))"
pull 0 up
enable_is 1 || fail "Enable is $(value Enable) with the run switch on again"
echo "ok: the run switch on gpio-sim line 0 of $chip gates Enable"
rtplc status
rtplc stats | grep -A3 '^  link' || true
rtplc can dump vcan0 --config drive.yaml --seconds 0.5 > dump.txt
head -6 dump.txt
grep -q 'in/EPC/p0.d1.c0=300' dump.txt || fail "can dump did not decode the speed"
grep -q 'out/EPC/p0.d1.c1=1' dump.txt || fail "can dump did not decode the enable bit"

# 3. The drive stops talking: after 100 ms (the frame timeout, which is the
# channel's max age) the speed is stale, its last value kept, and the program
# drops Enable on the bus.
kill $PEER; wait $PEER || true
sleep 0.5
rtplc monitor --once
[ "$(quality Speed)" = "stale" ] || fail "Speed is $(quality Speed) 0.5 s after the drive went quiet"
awk -v v="$(value Speed)" 'BEGIN { exit !(v > 299.9 && v < 300.1) }' || fail "Speed lost its last value: $(value Speed)"
[ "$(value Enable)" = "0" ] || fail "Enable is $(value Enable) with a bad speed"
tail -1 tx.log | grep -Eq '201#[0-9A-F]{4}00' || { tail -3 tx.log; fail "the last frame does not carry Enable 0"; }
grep -q 'frame 181 not received for 100 ms' run.log || { cat run.log; fail "the timeout is not in the log"; }

# 4. The drive talks again with a nonzero torque command going out, then
# `rtplc stop`: the last frame on the bus is the safe values (0 torque, disabled).
cangen vcan0 -I 181 -L 3 -D E80301 -g 10 &
PEER=$!
for i in 1 2 3 4 5 6 7 8 9 10; do [ "$(quality Speed)" = "good" ] && break; sleep 0.5; done
[ "$(quality Speed)" = "good" ] || fail "Speed did not come back"
rtplc stop
wait $RUN || true
kill $PEER; wait $PEER || true
sleep 0.2
kill $DUMP
tail -3 tx.log
tail -1 tx.log | grep -q '201#0000000000000000' || fail "the last frame after stop is not the safe values"
grep -q 'vcan0 201#' tx.log || fail "no 0x201 frames at all"
grep -v '201#0000000000000000' tx.log | grep -Eq '201#[0-9A-F]{4}01' || fail "no frame ever carried Enable 1"
# Frames carry 8 data bytes and come about every 20 ms (the frame's period;
# the PID changes its output every task cycle, 20 ms too). Emulation is slow:
# accept a mean interval from 10 to 60 ms.
awk -F'[()]' '{ t = $2 + 0; if (n++ > 0) { d = t - last; sum += d }; last = t }
  END { m = sum / (n - 1); printf "0x201: %d frames, mean interval %.1f ms\n", n, m * 1000;
        exit !(n > 20 && m > 0.010 && m < 0.060) }' tx.log || fail "0x201 is not sent at its period"
awk '{ split($3, p, "#"); if (length(p[2]) != 16) bad++ } END { exit bad > 0 }' tx.log || fail "a 0x201 frame without 8 bytes"

# 5. The same loop on a fieldbus plan (examples/drive_plan.yaml, T_1 = 10 ms,
# L_n = 1.554 ms = at most 5 frames of 270 us): 0x201 in every frame, the
# enable frame 0x0A0 urgent, drive_params.txt as a non-RT transfer on 0x5F0.
# Checked from candump's log by counts and order, not durations: the transfer
# arrives whole and in order, and between two 0x201 frames (one T_1 frame)
# there are at most 5 bulk frames; `rtplc stats` shows the three classes.
cp /examples/drive_plan.fbd /examples/drive_bus_plan.yaml /examples/drive_params.txt .
sed "$nowd" /examples/drive_plan.yaml > drive_plan.yaml
candump -L vcan0 > plan.log &
DUMP=$!
rtplc run drive_plan.yaml > planrun.log 2>&1 &
RUN=$!
rtplc_up planrun.log "the planned runtime"
cansend vcan0 181#B80B01   # the drive is ready for 100 ms: Enable goes 1, then 0 (urgent both times)
sleep 3
rtplc stats > planstats.txt || { cat planrun.log; fail "rtplc stats failed during the planned run"; }
rtplc stats --json > planstats.json
rtplc stop
wait $RUN || { cat planrun.log; fail "the planned run failed"; }
sleep 0.2
kill $DUMP
sed -n '/^L:/,$p' planstats.txt
for c in periodic urgent non-RT; do
  grep -q "^    $c: [0-9]* sent" planstats.txt || fail "rtplc stats shows no $c class for the planned link"
done
grep -q '"name": "non-RT", "count": [1-9]' planstats.json || fail "no non-RT fragment counted in the stats JSON"
n201=$(grep -c 'vcan0 201#' plan.log || true)
n5f0=$(grep -c 'vcan0 5F0#' plan.log || true)
echo "planned run: $n201 frames 0x201, $n5f0 frames 0x5F0, $(grep -c 'vcan0 0A0#' plan.log || true) frames 0x0A0"
[ "$n201" -gt 50 ] || fail "only $n201 periodic frames in a 4 s run at T_1 = 10 ms"
grep -q 'vcan0 0A0#' plan.log || fail "no urgent enable frame at all"
# (Enable 1 needs a task cycle inside the 100 ms the drive is ready: under
# emulation on a loaded host that is likely, not certain, so only shown.)
grep -q 'vcan0 0A0#01' plan.log && echo "the urgent enable frame carried 1, then 0" || echo "note: Enable never reached 1 here"
# A periodic frame the scheduler missed (it counts them, `rtplc stats`; under
# emulation on a loaded host some are) leaves two T_1 frames between two 0x201:
# the bound is 5 per T_1 frame that passed, counted from candump's timestamps.
# A guest starved by its host sends a late frame's bulk and the next frame's
# close together, so the timestamps undercount the frames that passed exactly
# when the scheduler reports missed periodic frames: bulk frames over the bound
# are then allowed up to 5 per missed periodic frame, never more, and none
# when it missed none.
missed=$(grep -o '"name": "periodic", "count": [0-9]*, "missed": [0-9]*' planstats.json | head -1 | grep -o '[0-9]*$' || echo 0)
awk -F'[ ()]+' -v missed="${missed:-0}" '{ split($4, p, "#"); id = p[1]; t = $2 + 0 }
  id == "201" { if (open) { n = int((t - t0) / 0.010 + 0.5); if (n < 1) n = 1;
                            if (run > 5 * n) { bad++; excess += run - 5 * n }
                            if (run > max) max = run; if (n == 1 && run > max1) max1 = run }
                open = 1; run = 0; t0 = t }
  id == "5F0" { run++ }
  END { printf "bulk frames between two periodic frames one T_1 apart: at most %d (L_n allows 5); %d runs over the bound by %d frames in all, with %d periodic frames missed by the scheduler\n", max1, bad, excess, missed;
        exit excess > 5 * missed }' plan.log \
  || fail "more than L_n of bulk frames in one T_1 frame"
# Reassemble the first transfer: the file's bytes, in order.
size=$(wc -c < drive_params.txt)
grep 'vcan0 5F0#' plan.log | awk '{ split($3, p, "#"); printf "%s", p[2] }' | cut -c1-$((size * 2)) > got.hex
od -An -v -tx1 drive_params.txt | tr -d ' \n' | tr a-f A-F > want.hex
[ "$(cat got.hex)" = "$(cat want.hex)" ] || { head -c 64 got.hex; echo; head -c 64 want.hex; echo; fail "the non-RT transfer did not arrive whole and in order"; }
echo "ok: a planned CAN link on vcan0: periodic every frame, urgent on change, the transfer whole and cut to L_n"

echo "OK: the can driver exchanges frames with can-utils on vcan0: values, timeout, period, safe values at stop, on a plan"
