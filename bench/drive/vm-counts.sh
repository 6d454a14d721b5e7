#!/bin/sh
# bench_drive's VM half (`scripts/bench drive --vm`, through tests/rt_vm/gpio-vm.sh;
# issue 10, item 5): counts, not timing, on the real kernel interfaces in the
# PREEMPT_RT VM (software emulation: a guest second is not a host second, so no
# rate is claimed as reached; the gaps below are what the peers were asked for).
# One runtime, its own config (below): a can driver on vcan0 and a gpio
# counter on a gpio-sim line.
#   CAN   cangen puts N frames of 0x181 on vcan0 with a given gap; candump
#         (an independent listener) counts what was on the bus, the can
#         driver's received-frame counter (`rtplc stats --json`, the vcan0
#         link's polls_completed) what rtplc took.
#   GPIO  N pulses driven through gpio-sim's `pull` attribute with a given
#         pause (none: back to back from the shell); the dpi channel's count
#         against N.
# Prints one line per run; fails only when the harness itself does (a count
# below the sent one is a finding, reported, not a failure).
fail() { echo "FAILED: $*"; exit 1; }
shipped() { find / -name "$1" -type f -not -path '/proc/*' -not -path '/sys/*' 2>/dev/null | head -n1; }
for t in cangen candump; do command -v $t >/dev/null || fail "$t missing (package can-utils, --add it)"; done
# shellcheck source=tests/rt_vm/gpio-sim-lib.sh
. "$(shipped gpio-sim-lib.sh)"
# shellcheck source=tests/rt_vm/rtplc-run-lib.sh
. "$(shipped rtplc-run-lib.sh)"
gpio_sim_up IN0
pull 1 down
modprobe vcan
modprobe can-raw
ip link add dev vcan0 type vcan
ip link set vcan0 up

cat > counts.yaml <<EOF
tasks:
  - program: counts.fbd
    watchdog: 1000000
drivers:
  - kind: can
    name: drive
    period: 5ms
    interface: vcan0
    receive:
      - id: 0x181
        timeout: 100ms
        signals:
          - {channel: p0.d1.c0, byte: 0, length: 2, type: signed, scale: 0.1}
          - {channel: p0.d1.c1, byte: 2}
  - kind: gpio
    name: meter
    period: 1ms
    chip: $chip
    counters:
      - {channel: p0.d0.c0, line: 1, edge: rising}
EOF
cat > counts.fbd <<'EOF'
/* bench/drive/vm-counts.sh: reads what the two drivers count. */
%%
stime(0.01)
F1 = tra(p0, d1, c0, "Speed")
D2 = trd(p0, d1, c1, "Ready")
F3 = dpi(p0, d0, c0, "Pulses")
END
%%
EOF
rtplc run counts.yaml > run.log 2>&1 &
rtplc_up run.log "the runtime"
# A counter read until it holds still (the drivers publish theirs every 100 ms).
steady() {
  a="$($1)"
  while :; do sleep 0.4; b="$($1)"; [ "$a" = "$b" ] && break; a="$b"; done
  echo "$a"
}

# ---- CAN --------------------------------------------------------------------------
frames_rx() { rtplc stats --json | grep '"name": "vcan0"' | grep -o '"polls_completed": [0-9]*' | awk '{print $2}'; }
[ -n "$(frames_rx)" ] || { rtplc stats --json; fail "no vcan0 link in rtplc stats --json"; }
echo "counts: CAN, frames of 0x181 (3 bytes) from cangen on vcan0 to the can driver"
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
  if [ "$gap" = 0 ]; then asked="no gap, as fast as cangen can"; else asked="a ${gap} ms gap, $((1000 / gap)) frames/s asked"; fi
  echo "  $asked: sent $n, candump saw $seen, rtplc received $got, lost $((n - got))"
done

# ---- GPIO -------------------------------------------------------------------------
pulses() { rtplc monitor --once | awk '$1 == "Pulses" {print $4; exit}'; }
[ -n "$(pulses)" ] || { rtplc monitor --once; fail "no Pulses channel in rtplc monitor"; }
echo "counts: GPIO, rising edges on $chip line 1 through gpio-sim's pull attribute to the dpi counter"
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
rtplc stop
i=0
while rtplc status >/dev/null 2>&1; do i=$((i + 1)); [ $i -le 50 ] || fail "the runtime did not stop"; sleep 0.2; done
echo "OK: counts reported (no timing: the guest is emulated)"
