#!/usr/bin/env python3
"""A Modbus server from python3-pymodbus, an implementation independent of
ours, for the modbus driver's tests: holding register 0 starts at 17.
Usage: pymodbus_server.py PORT        Modbus TCP on 127.0.0.1:PORT only
       pymodbus_server.py --rtu DEV   Modbus RTU on the serial device (or pty) DEV,
                                      19200 baud 8N1, answering every unit id.
Parity N: pyserial cannot set even parity on a pty here (tcsetattr EINVAL),
and a pty has no UART to use parity anyway."""
import sys

from pymodbus.datastore import (ModbusSequentialDataBlock, ModbusServerContext,
                                ModbusSlaveContext)

try:
    from pymodbus.server import StartSerialServer, StartTcpServer
except ImportError:  # pymodbus 2.x
    from pymodbus.server.sync import StartSerialServer, StartTcpServer


def main():
    block = ModbusSequentialDataBlock(0, [17] + [0] * 199)
    slave = ModbusSlaveContext(di=ModbusSequentialDataBlock(0, [0] * 200),
                               co=ModbusSequentialDataBlock(0, [0] * 200),
                               hr=block,
                               ir=ModbusSequentialDataBlock(0, [0] * 200),
                               zero_mode=True)  # protocol address 0 = block index 0
    context = ModbusServerContext(slaves=slave, single=True)
    if len(sys.argv) == 3 and sys.argv[1] == "--rtu":
        from pymodbus.transaction import ModbusRtuFramer
        StartSerialServer(context=context, framer=ModbusRtuFramer, port=sys.argv[2],
                          baudrate=19200, parity="N", bytesize=8, stopbits=1)
    elif len(sys.argv) == 2:
        StartTcpServer(context=context, address=("127.0.0.1", int(sys.argv[1])))
    else:
        sys.exit(__doc__)


if __name__ == "__main__":
    main()
