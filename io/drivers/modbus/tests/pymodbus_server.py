#!/usr/bin/env python3
"""A Modbus TCP server from python3-pymodbus, an implementation independent of
ours, for the modbus driver's tests: holding register 0 starts at 17.
Usage: pymodbus_server.py PORT   (listens on 127.0.0.1 only)."""
import sys

from pymodbus.datastore import (ModbusSequentialDataBlock, ModbusServerContext,
                                ModbusSlaveContext)

try:
    from pymodbus.server import StartTcpServer
except ImportError:  # pymodbus 2.x
    from pymodbus.server.sync import StartTcpServer


def main():
    port = int(sys.argv[1])
    block = ModbusSequentialDataBlock(0, [17] + [0] * 199)
    slave = ModbusSlaveContext(di=ModbusSequentialDataBlock(0, [0] * 200),
                               co=ModbusSequentialDataBlock(0, [0] * 200),
                               hr=block,
                               ir=ModbusSequentialDataBlock(0, [0] * 200),
                               zero_mode=True)  # protocol address 0 = block index 0
    context = ModbusServerContext(slaves=slave, single=True)
    StartTcpServer(context=context, address=("127.0.0.1", port))


if __name__ == "__main__":
    main()
