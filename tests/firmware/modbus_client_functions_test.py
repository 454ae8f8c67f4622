"""examples/firmware/modbus_client_functions in QEMU against `ferrule-sim modbus` (a simulated
drive, unit 1): the scan list of ten function codes goes round without a failure, its writes
start the drive (control word 0x0025 from FC 15 + FC 5, setpoint 25.00 Hz by FC 6, parameters
by FC 16 / FC 23), and what the firmware reports it read is what the ferrule CLI reads from the
same drive over the simulator's Modbus TCP side."""
import json
import re
import subprocess

from qemu import Firmware, Sim, args, check, summary

a = args("ferrule", "sim")
sim = Sim(a.sim, "modbus", "drive", "--tcp", "0")
tcp = sim.proc.stdout.readline().strip()  # the simulator's second line: 127.0.0.1:PORT
REPORT = (r"^rounds=(\d+) failures=(\d+) coils=(\d+) inputs=(\d+) live=([\d,]+) "
          r"parameters=([\d,]+) vendor_length=(\d+) stack=(\d+)$")
AT_SPEED = 0x0013  # ready | running | at speed (vfd.hpp status bits)


def host_read(start, count):
    """The drive's holding registers from `start`, read by `ferrule modbus` over TCP."""
    r = subprocess.run([a.ferrule, "modbus", "read", "--host", tcp, "-r", str(start), "-c",
                        str(count), "--json"], capture_output=True, text=True, timeout=30)
    lines = [line for line in r.stdout.splitlines() if line.startswith("{")]
    return json.loads(lines[-1]).get("values") if lines else r.stderr


def few_failures(report):
    """Whether fewer than one in ten of a report's transactions failed. The guest runs on the
    host's clock: on a loaded machine a reply now and then misses the example's 100 ms
    response timeout twice (one resend), and the scan list counts it and goes on."""
    if report is None:
        return False
    transactions = int(report.group(1)) * 10
    return int(report.group(2)) * 10 < transactions


def ints(text):
    return [int(v) for v in text.split(",")]


fw = Firmware(a.elf, usart2=sim.link)
try:
    check("boots", fw.wait_for(r"^boot: STM32F405") is not None, "no boot line")
    first = fw.wait_for(REPORT, timeout=30)
    check("the scan list goes round (20 rounds of ten function codes)", first is not None,
          "\n".join(fw.lines[-5:]))
    if first is None:
        raise SystemExit(summary())
    # The drive ramps from 0 to 25 Hz in 0.5 s: wait for a report that sees it there.
    m = first
    while m is not None and ints(m.group(5))[2] != AT_SPEED:
        m = fw.wait_for(REPORT, timeout=30, start=fw.matched_at + 1)
    check("the drive reports at speed (status 0x0013) to the firmware", m is not None,
          "\n".join(fw.lines[-3:]))
    if m is None:
        m = first
    control, setpoint, status, frequency, fault = ints(m.group(5)) if m else [None] * 5
    check("the transactions succeed: fewer than 1 in 10 failed", few_failures(m),
          m.group(0) if m else "no report")
    check("FC 1 reads the control word FC 15 + FC 5 wrote (0x0025, the paper's start)",
          m is not None and int(m.group(3)) == 0x0025, m.group(0) if m else "no report")
    check("FC 4 / FC 23 read the control word and the FC 6 setpoint (2500)",
          (control, setpoint) == (0x0025, 2500), m.group(0) if m else "no report")
    check("the output frequency reached the setpoint, no fault", (frequency, fault) == (2500, 0),
          m.group(0) if m else "no report")
    check("FC 2 reads the status word's bits", m is not None and int(m.group(4)) == status,
          m.group(0) if m else "no report")
    check("FC 3 reads the parameters FC 16 / FC 23 wrote",
          m is not None and ints(m.group(6)) == [5000, 10, 10, 0],
          m.group(0) if m else "no report")
    check("FC 43/14: the vendor name 'ferrule' is 7 long",
          m is not None and int(m.group(7)) == len("ferrule"), m.group(0) if m else "no report")
    check("stack high-water mark measured", m is not None and 0 < int(m.group(8)) < 8192,
          m.group(0) if m else "none")

    # The simulated drive itself, read by the host while the firmware goes on polling.
    live = host_read(0xC800, 5)
    check("the drive holds the firmware's control word and setpoint and runs at 25.00 Hz",
          live == [0x0025, 2500, AT_SPEED, 2500, 0], live)
    check("the drive holds the firmware's parameters", host_read(0xC900, 4) == [5000, 10, 10, 0],
          "see above")
    later = fw.wait_for(REPORT, timeout=30, start=fw.matched_at + 1)
    check("the scan list goes on with the host on the drive's TCP side too",
          later is not None and few_failures(later), later.group(0) if later else "none")
finally:
    fw.stop()
    sim.stop()

raise SystemExit(summary())
