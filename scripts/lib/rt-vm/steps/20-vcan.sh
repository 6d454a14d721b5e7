#!/bin/sh
# SocketCAN works here (the host has no PF_CAN): the modules load and a vcan device comes up.
modprobe vcan
modprobe can-raw
ip link add dev vcan0 type vcan
ip link set vcan0 up
ip link show vcan0
lsmod
# /proc/net/can appears once the CAN protocol family is registered.
test -d /proc/net/can
echo "OK: vcan0 is up and PF_CAN is registered"
