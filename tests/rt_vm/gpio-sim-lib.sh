#!/bin/sh
# Sourced by the VM steps that need GPIO lines (gpio.sh, can.sh): loads the
# gpio-sim module shipped with --add (tests/rt_vm/gpio-vm.sh builds it) and
# makes one live chip of 8 lines.
#   . "$(shipped gpio-sim-lib.sh)"; gpio_sim_up NAME   # line 0 is called NAME
# Sets $chip (gpiochipN) and $sys (its sysfs folder) and defines
#   pull K up|down   drives input line K through gpio-sim's pull attribute
#   value K          what the driver drives on output line K (0/1)
#   settle K V       waits (bounded: emulation is slow, not wrong) for value K = V
gpio_sim_up() {
  ko="${GPIO_SIM_KO:-$(shipped gpio-sim.ko)}"
  [ -f "$ko" ] || fail "no gpio-sim.ko at '$ko' (run the VM with --add PATH and GPIO_SIM_KO=PATH)"
  modprobe configfs
  grep -q ' /sys/kernel/config ' /proc/mounts || mount -t configfs none /sys/kernel/config
  insmod "$ko"
  cfs=/sys/kernel/config/gpio-sim/chip0
  mkdir $cfs $cfs/bank0 $cfs/bank0/line0
  echo 8 > $cfs/bank0/num_lines
  echo "$1" > $cfs/bank0/line0/name
  echo 1 > $cfs/live
  chip="$(cat $cfs/bank0/chip_name)"
  sys="/sys/devices/platform/$(cat $cfs/dev_name)/$chip"
  [ -e "/dev/$chip" ] || fail "/dev/$chip did not appear"
  echo "ok: gpio-sim is $chip ($sys)"
}
pull() { echo "pull-$2" > "$sys/sim_gpio$1/pull"; }
value() { cat "$sys/sim_gpio$1/value"; }
settle() {
  i=0
  while [ "$(value $1)" != "$2" ]; do
    i=$((i + 1)); [ $i -le 50 ] || return 1; sleep 0.1
  done
}
