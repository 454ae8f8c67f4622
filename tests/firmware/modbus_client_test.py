"""examples/firmware/modbus_client in QEMU against `ferrule-sim modbus`: two of the example's
three units are on the line (1 and 2, both started by the host CLI, unit 2 at 12.34 Hz). The
firmware's start-up setpoint (FC 6, 25.00 Hz) arrives at unit 1, which then runs at it; unit
3 stays offline; the registers the firmware polls are those `ferrule modbus read` then reads
from the same simulated VFDs."""
import json
import subprocess
import time

from qemu import Firmware, Sim, args, check, summary

a = args("ferrule", "sim")
CONTROL_WORD = 0xC800  # then frequency setpoint, status word, output frequency
START = 0x0025  # run | enable | setpoint enable
READS = (r"^reads=(\d+) online=(\d+) unit1=([\d,]+) unit2=([\d,]+) unit3=([\d,]+) "
         r"stack=(\d+)$")


def modbus(command, unit, *rest):
    """`ferrule modbus <command> --unit <unit> …` on the simulator's line: (rc, JSON lines)."""
    p = subprocess.run([a.ferrule, "modbus", command, "--port", sim.link, "--unit", str(unit),
                        "--json", *rest], capture_output=True, text=True, timeout=30)
    return p.returncode, [json.loads(line) for line in p.stdout.splitlines() if line.strip()]


def at_speed(fw, timeout=60):
    """The first reads report with units 1 and 2 at their setpoints: (online, units, stack)."""
    deadline = time.monotonic() + timeout
    start = 0
    while True:
        m = fw.wait_for(READS, timeout=max(0.0, deadline - time.monotonic()), start=start)
        if m is None:
            return None
        units = [[int(v) for v in m.group(i).split(",")] for i in (3, 4, 5)]
        if all(u[1] != 0 and u[3] == u[1] for u in units[:2]):
            return int(m.group(2)), units, int(m.group(6))
        start = fw.matched_at + 1


sim = Sim(a.sim, "modbus", "vfds", "--unit", "1", "--unit", "2")
try:
    rc1, _ = modbus("write", 1, "--start", str(CONTROL_WORD), str(START))
    rc2, _ = modbus("write", 2, "--start", str(CONTROL_WORD), str(START), "1234")
    check("host starts units 1 and 2", rc1 == 0 and rc2 == 0, f"rc {rc1}, {rc2}")
    fw = Firmware(a.elf, usart2=sim.link)
    try:
        check("boots", fw.wait_for(r"^boot: STM32F405") is not None, "no boot line")
        write = fw.wait_for(r"^write unit=1 register=(\d+) value=(\d+) (ok|failed)$",
                            timeout=30)
        check("start-up setpoint written with FC 6 and acknowledged",
              write is not None and write.groups() == (str(CONTROL_WORD + 1), "2500", "ok"),
              write.group(0) if write else "\n".join(fw.lines[-5:]))
        report = at_speed(fw)
        check("units 1 and 2 reach their setpoints in the firmware's polls", report is not None,
              "\n".join(fw.lines[-5:]))
        online, units, stack = report if report else (0, [[], [], []], 0)
        check("units 1 and 2 online, unit 3 offline", online == 0b011, str(online))
        check("unit 1 runs at the firmware's setpoint", units[0][1:4:2] == [2500, 2500],
              repr(units[0]))
        check("unit 3's registers stay 0 (never answered)", units[2] == [0, 0, 0, 0],
              repr(units[2]))
        check("stack high-water mark measured", 0 < stack < 4096, str(stack))
    finally:
        fw.stop()

    # The same simulated VFDs, read by the host CLI once QEMU has let go of the line (with
    # resends: QEMU may have left half a frame on it).
    host = {}
    for unit in (1, 2, 3):
        rc, out = modbus("read", unit, "--start", str(CONTROL_WORD), "--count", "4",
                         "--retries", "2")
        host[unit] = out[-1]["registers"] if rc == 0 and out and out[-1].get("ok") else None
    check("firmware's registers of units 1 and 2 equal the host's readings",
          host[1] == units[0] and host[2] == units[1],
          f"firmware {units[:2]}, host {host[1]}, {host[2]}")
    check("unit 3 does not answer the host either", host[3] is None, repr(host[3]))
finally:
    sim.stop()

raise SystemExit(summary())
