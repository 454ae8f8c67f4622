"""examples/firmware/modbus_server in QEMU, unit 17 on USART2, served to three masters on the
same pty: the ferrule CLI, mbpoll and libmodbus (tests/peers/libmodbus_peer). What one of them
writes, the others read back; the coils a master sets reach the application's outputs (the
console's coils= line); the device identification and an out-of-map read come back as the
example defines them."""
import json
import re
import subprocess

from qemu import Firmware, args, check, require, summary

a = args("ferrule", "libmodbus_peer")
require(programs=["mbpoll"])
UNIT = "17"


def ferrule(*argv, first=False):
    """`ferrule modbus …` on the firmware's line; its last JSON line. The first request of a
    test may go out before QEMU listens on the pty (it looks once a second) and be lost: it
    is sent again."""
    patience = ["--timeout", "3000", "--retries", "2"] if first else []
    r = subprocess.run([a.ferrule, "modbus", *argv, "--port", pty, "--unit", UNIT, "--json",
                        *patience], capture_output=True, text=True, timeout=60)
    lines = [line for line in r.stdout.splitlines() if line.startswith("{")]
    return json.loads(lines[-1]) if lines else {"stderr": r.stderr}


def mbpoll(table, start, count=1, write=()):
    """mbpoll over RTU (19200 8E1, PDU addresses): the values it read, or None."""
    size = [] if write else ["-c", str(count)]  # a write's count is that of its values
    r = subprocess.run(["mbpoll", "-m", "rtu", "-b", "19200", "-P", "even", "-a", UNIT, "-0",
                        "-1", "-t", table, "-r", str(start), *size, pty, *map(str, write)],
                       capture_output=True, text=True, timeout=60)
    if r.returncode != 0:
        return None
    if write:
        return list(write) if f"Written {len(write)} references" in r.stdout else None
    return [int(v) for v in re.findall(r"^\[\d+\]:\s+(-?\d+)", r.stdout, re.M)]


def libmodbus(start, count, write=()):
    """libmodbus: writes `write` from `start` (FC 16), reads `count` back (FC 3); or None."""
    r = subprocess.run([a.libmodbus_peer, "rtu-registers", pty, UNIT, str(start), str(count),
                        *map(str, write)], capture_output=True, text=True, timeout=60)
    return [int(v) for v in r.stdout.split()] if r.returncode == 0 else None


fw = Firmware(a.elf, usart2="pty")
pty = fw.pty["usart2"]
try:
    check("boots", fw.wait_for(r"^boot: STM32F405") is not None, "no boot line")
    r = ferrule("read", "-t", "holding", "-r", "0", "-c", "4", first=True)
    check("ferrule reads holding registers 0-3 (zero at reset)", r.get("values") == [0] * 4, r)

    values = [1000, 2000, 0xBEEF, 65535]
    r = ferrule("write", "-t", "holding", "-r", "10", *map(str, values))
    check("ferrule writes holding registers 10-13 (FC 16)", r.get("ok") is True, r)
    got = mbpoll("4", 10, 4)
    check("mbpoll reads ferrule's values back", got == values, got)
    got = libmodbus(10, 4)
    check("libmodbus reads ferrule's values back", got == values, got)

    got = mbpoll("4", 20, write=(4660, 22136))
    check("mbpoll writes holding registers 20-21", got is not None, "mbpoll failed")
    r = ferrule("read", "-t", "holding", "-r", "20", "-c", "2")
    check("ferrule reads mbpoll's values back", r.get("values") == [4660, 22136], r)
    got = libmodbus(20, 2)
    check("libmodbus reads mbpoll's values back", got == [4660, 22136], got)

    got = libmodbus(61, 3, write=(7, 0x8000, 63))
    check("libmodbus writes holding registers 61-63, the map's last", got == [7, 0x8000, 63], got)
    r = ferrule("read", "-t", "holding", "-r", "60", "-c", "4")
    check("ferrule reads libmodbus's values back", r.get("values") == [0, 7, 0x8000, 63], r)
    got = mbpoll("4", 61, 3)
    check("mbpoll reads libmodbus's values back", got == [7, 0x8000, 63], got)

    r = ferrule("read", "-t", "holding", "-r", "62", "-c", "3")
    check("a read past holding register 63 is refused: exception 02",
          r.get("ok") is False and r.get("exception") == 2, r)

    start = len(fw.lines)
    pattern = [1, 0, 1, 1, 0, 0, 0, 1]
    r = ferrule("write", "-t", "coil", "-r", "0", *map(str, pattern))
    check("ferrule writes coils 0-7 (FC 15)", r.get("ok") is True, r)
    m = fw.wait_for(r"^coils=(\d+) stack=(\d+)$", start=start)
    check("the application's outputs follow the coils (0b10001101)",
          m is not None and int(m.group(1)) == 0x8D, m.group(0) if m else fw.lines[-3:])
    got = mbpoll("0", 0, 8)
    check("mbpoll reads ferrule's coils back", got == pattern, got)

    start = len(fw.lines)
    got = mbpoll("0", 31, write=(1,))
    check("mbpoll sets coil 31 (FC 5)", got is not None, "mbpoll failed")
    m = fw.wait_for(r"^coils=(\d+) stack=(\d+)$", start=start)
    check("the application's outputs get bit 31",
          m is not None and int(m.group(1)) == 0x8000008D, m.group(0) if m else fw.lines[-3:])
    r = ferrule("read", "-t", "coil", "-r", "30", "-c", "2")
    check("ferrule reads mbpoll's coil back", r.get("values") == [0, 1], r)

    r = ferrule("id")
    check("device identification (FC 43/14) is the example's",
          r.get("objects") == {"VendorName": "ferrule", "ProductCode": "fw-server",
                               "MajorMinorRevision": "1.0"}, r)
    check("stack high-water mark measured", m is not None and 0 < int(m.group(2)) < 8192,
          m.group(0) if m else "none")
finally:
    fw.stop()

raise SystemExit(summary())
