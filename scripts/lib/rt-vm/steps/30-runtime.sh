#!/bin/sh
# The runtime on the PREEMPT_RT kernel: 16 tasks at assorted periods with the sim
# plants, `rtplc stats` while they run, a set-point change, a hot swap and a
# rollback, then a clean stop. (Timing under emulation means nothing; this
# checks that every part works on the real RT kernel.)
mkdir -p /tmp/rt && cd /tmp/rt
cp -r /examples/. .
rtplc check seed_pid.fbd
rtplc run sixteen.yaml --duration 60 > run16.log 2>&1 &
RUN=$!
# Wait for the control socket (the runtime is up when it answers).
i=0
until rtplc status >/dev/null 2>&1; do
  i=$((i + 1))
  if [ $i -gt 100 ]; then cat run16.log; echo "FAILED: the runtime did not come up"; exit 1; fi
  sleep 0.2
done
sleep 3
rtplc status
rtplc stats
rtplc stats --json > stats.json
grep -q '"tasks"' stats.json
n=$(rtplc stats | grep -c '^T:')
[ "$n" -eq 16 ] || { echo "FAILED: stats shows $n tasks, not 16"; exit 1; }
rtplc stats | grep '^T:' | grep -q 'FIFO\|P:' || true

# A set-point of the first loop, then a swap of its code and back.
first_sp=$(rtplc monitor --once | awk '$2 == "setpoint" {print $1; exit}')
rtplc set "$first_sp" 12.5
rtplc monitor --once --filter "$first_sp" | grep -q '12.5'
task=$(rtplc status | awk '/^  task / {sub(":", "", $2); print $2; exit}')
prog=$(rtplc status | awk '/^  task / {gsub(",", "", $4); print $4; exit}')
sed 's/^END/\/\/ swapped in the VM\nEND/' "$prog" > swapped.fbd
rtplc swap "$task" swapped.fbd | tee swap.txt
grep -q 'applied at a cycle boundary' swap.txt
rtplc status | grep -q "swapped.fbd"
rtplc swap --rollback "$task"
rtplc status | grep "task $task"
# A broken program changes nothing.
printf '%%%%\nF1 = nope(F2)\nEND\n' > broken.fbd
if rtplc swap "$task" broken.fbd; then echo "FAILED: a broken program was swapped in"; exit 1; fi
rtplc stop
wait $RUN || true
cat run16.log | tail -25
grep -q '^T:15' run16.log
echo "OK: 16 tasks ran on PREEMPT_RT; stats, set, swap, rollback and stop work"
