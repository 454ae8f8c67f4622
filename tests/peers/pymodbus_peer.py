#!/usr/bin/python3
"""pymodbus as the other side of ferrule's Modbus peer tests (tests/peers/peers_test.py).

usage: pymodbus_peer.py tcp-server PORT            serve the peer map on 127.0.0.1:PORT
       pymodbus_peer.py rtu-client TTY UNIT [--ferrule-extras]   check a server of the peer map
       pymodbus_peer.py tcp-client PORT UNIT [--ferrule-extras]

The peer map and its ferrule extras are described in libmodbus_peer.c. Runs with Debian's
python3-pymodbus (3.0), hence /usr/bin/python3. Each check prints 'ok NAME' or
'FAIL NAME: why'; the last line is 'N passed, M failed'.
"""
import logging
import sys

logging.disable(logging.CRITICAL)  # pymodbus logs every exception response it receives

MAP = 100
passed = failed = 0


def check(name, cond, why=""):
    global passed, failed
    if cond:
        passed += 1
        print(f"ok {name}", flush=True)
    else:
        failed += 1
        print(f"FAIL {name}: {why}", flush=True)


def serve_tcp(port):
    from pymodbus.datastore import ModbusSequentialDataBlock, ModbusServerContext, ModbusSlaveContext
    from pymodbus.device import ModbusDeviceIdentification
    from pymodbus.server import StartTcpServer

    store = ModbusSlaveContext(
        co=ModbusSequentialDataBlock(0, [i % 3 == 0 for i in range(MAP)]),
        di=ModbusSequentialDataBlock(0, [i % 2 == 1 for i in range(MAP)]),
        hr=ModbusSequentialDataBlock(0, [0x1000 + i for i in range(MAP)]),
        ir=ModbusSequentialDataBlock(0, [0x2000 + i for i in range(MAP)]),
        zero_mode=True)
    identity = ModbusDeviceIdentification(info_name={
        "VendorName": "ferrule", "ProductCode": "FR-PEER", "MajorMinorRevision": "1.0"})
    print("ready", flush=True)  # peers_test.py waits until the port accepts connections
    StartTcpServer(context=ModbusServerContext(slaves=store, single=True), identity=identity,
                   address=("127.0.0.1", port))


def run_client(client, unit, extras, rtu):
    from pymodbus.diag_message import ReturnBusMessageCountRequest
    from pymodbus.mei_message import ReadDeviceInformationRequest

    def ok(r):
        return r is not None and not r.isError()

    r = client.read_coils(0, 20, slave=unit)
    check("FC1 read coils 0-19", ok(r) and r.bits[:20] == [i % 3 == 0 for i in range(20)], r)
    r = client.read_discrete_inputs(3, 20, slave=unit)
    check("FC2 read discrete inputs 3-22", ok(r) and r.bits[:20] == [(i + 3) % 2 == 1 for i in range(20)], r)
    r = client.read_holding_registers(0, 10, slave=unit)
    check("FC3 read holding registers 0-9", ok(r) and r.registers == [0x1000 + i for i in range(10)], r)
    r = client.read_input_registers(90, 10, slave=unit)
    check("FC4 read input registers 90-99", ok(r) and r.registers == [0x2000 + 90 + i for i in range(10)], r)
    r = client.write_coil(10, True, slave=unit)
    r2 = client.read_coils(10, 1, slave=unit)
    check("FC5 write coil 10 on, read back", ok(r) and ok(r2) and r2.bits[0], (r, r2))
    r = client.write_register(5, 0x1234, slave=unit)
    r2 = client.read_holding_registers(5, 1, slave=unit)
    check("FC6 write register 5, read back", ok(r) and ok(r2) and r2.registers == [0x1234], (r, r2))
    pattern = [True, True, False, True, False, False, True, False, True, True]
    r = client.write_coils(20, pattern, slave=unit)
    r2 = client.read_coils(20, 10, slave=unit)
    check("FC15 write coils 20-29, read back", ok(r) and ok(r2) and r2.bits[:10] == pattern, (r, r2))
    values = [1, 2, 0xFFFF, 0x8000, 42]
    r = client.write_registers(30, values, slave=unit)
    r2 = client.read_holding_registers(30, 5, slave=unit)
    check("FC16 write registers 30-34, read back", ok(r) and ok(r2) and r2.registers == values, (r, r2))
    # pymodbus 3.0's request classes take the unit id as `unit`; its helpers' `slave` does not
    # reach them (the request would go to unit 0, the broadcast).
    r = client.readwrite_registers(read_address=39, read_count=4, write_address=40,
                                   write_registers=[0xAAAA, 0x5555], unit=unit)
    check("FC23 write 40-41 and read 39-42", ok(r) and r.registers == [0x1000 + 39, 0xAAAA, 0x5555, 0x1000 + 42], r)
    if rtu:
        r = client.diag_query_data(0xA537, unit=unit)
        check("FC8 sub-function 0 echoes the data", ok(r) and list(r.message) == [0xA537], r)
        if extras:  # pymodbus's own server does not count bus messages
            # diag_read_bus_message_count() of pymodbus 3.0 passes the unit id as the request's data.
            r = client.execute(ReturnBusMessageCountRequest(unit=unit))
            count = r.message[0] if ok(r) and isinstance(r.message, (list, tuple)) else getattr(r, "message", 0)
            check("FC8 sub-function 11 bus message count", ok(r) and isinstance(count, int) and count > 0, count)
    elif extras:  # Application Protocol V1.1b3 §6.8: diagnostics are for serial lines only
        r = client.diag_query_data(0xA537, unit=unit)
        check("FC8 over TCP is refused with exception 01", r.isError() and getattr(r, "exception_code", 0) == 1, r)
    r = client.execute(ReadDeviceInformationRequest(read_code=1, object_id=0, unit=unit))
    check("FC43/14 device identification", ok(r) and r.information.get(0) == b"ferrule"
          and r.information.get(1) == b"FR-PEER", r)
    r = client.read_holding_registers(100, 1, slave=unit)
    check("exception 02: read holding register 100", r.isError() and getattr(r, "exception_code", 0) == 2, r)
    if extras:
        r = client.write_register(99, 0xDEAD, slave=unit)
        check("exception 04: server device failure", r.isError() and getattr(r, "exception_code", 0) == 4, r)
    print(f"{passed} passed, {failed} failed")
    return 1 if failed else 0


def main():
    mode = sys.argv[1]
    if mode == "tcp-server":
        serve_tcp(int(sys.argv[2]))
        return 0
    from pymodbus.client import ModbusSerialClient, ModbusTcpClient
    if mode == "rtu-client":
        client = ModbusSerialClient(port=sys.argv[2], baudrate=19200, bytesize=8, parity="N", stopbits=1, timeout=1)
    else:
        client = ModbusTcpClient("127.0.0.1", port=int(sys.argv[2]), timeout=1)
    if not client.connect():
        print("cannot connect", file=sys.stderr)
        return 3
    try:
        return run_client(client, int(sys.argv[3]), "--ferrule-extras" in sys.argv, mode == "rtu-client")
    finally:
        client.close()


if __name__ == "__main__":
    sys.exit(main())
