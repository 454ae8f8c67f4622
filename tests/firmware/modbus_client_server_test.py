"""examples/firmware/modbus_client_server in QEMU: the PLC side (USART1, unit 17) served to the
ferrule CLI, the drive side (USART2) on `ferrule-sim modbus`. The control word and setpoint
the PLC writes reach the simulated drive (read back over the simulator's Modbus TCP side),
and the drive's registers and status bits, copied by the firmware, are what the PLC reads."""
import json
import subprocess
import time

from qemu import Firmware, Sim, args, check, summary

a = args("ferrule", "sim")
sim = Sim(a.sim, "modbus", "drive", "--tcp", "0")
tcp = sim.proc.stdout.readline().strip()  # the simulator's second line: 127.0.0.1:PORT
AT_SPEED = 0x0013  # ready | running | at speed (vfd.hpp status bits)


def modbus(*argv, where, first=False):
    """`ferrule modbus …` at `where` (option list); its last JSON line. The test's first
    request on the firmware's pty may go out before QEMU listens (it looks once a second)
    and be lost: it is sent again."""
    patience = ["--timeout", "3000", "--retries", "2"] if first else []
    r = subprocess.run([a.ferrule, "modbus", *argv, *where, "--json", *patience],
                       capture_output=True, text=True, timeout=60)
    lines = [line for line in r.stdout.splitlines() if line.startswith("{")]
    return json.loads(lines[-1]) if lines else {"stderr": r.stderr}


def plc(*argv, first=False):
    return modbus(*argv, where=["--port", fw.pty["usart1"], "--unit", "17"], first=first)


def drive(start, count):
    """The simulated drive's registers, read by the host over TCP."""
    return modbus("read", "-r", str(start), "-c", str(count), where=["--host", tcp]).get("values")


def poll(read, done, timeout=30):
    """The PLC's reading once done(values) holds, or its last one at the deadline."""
    deadline = time.monotonic() + timeout
    r = read()
    while not (r.get("ok") and done(r["values"])) and time.monotonic() < deadline:
        r = read()
    return r


fw = Firmware(a.elf, usart1="pty", usart2=sim.link)
try:
    check("boots", fw.wait_for(r"^boot: STM32F405") is not None, "no boot line")
    r = plc("read", "-t", "input", "-r", "0", "-c", "5", first=True)
    check("the PLC reads the drive's registers, stopped", r.get("values") == [0, 0, 0, 0, 0], r)

    start = len(fw.lines)
    r = plc("write", "-t", "holding", "-r", "0", str(0x0025), "3000")
    check("the PLC writes start (0x0025) and 30.00 Hz to holding registers 0-1",
          r.get("ok") is True, r)
    m = fw.wait_for(r"^to_drive=(\d+),(\d+) failures=(\d+) stack=(\d+)$", timeout=30, start=start)
    check("the firmware writes them to the drive (FC 16)",
          m is not None and (int(m.group(1)), int(m.group(2))) == (0x0025, 3000),
          m.group(0) if m else fw.lines[-3:])
    held = drive(0xC800, 2)
    check("the drive holds the PLC's control word and setpoint", held == [0x0025, 3000], held)

    # The drive ramps to 30 Hz in 0.6 s; the PLC polls its copy until the drive is at speed.
    r = poll(lambda: plc("read", "-t", "input", "-r", "0", "-c", "5"),
             lambda v: v[2] == AT_SPEED)
    check("the PLC reads the drive at speed: control, setpoint, status, 30.00 Hz, no fault",
          r.get("values") == [0x0025, 3000, AT_SPEED, 3000, 0], r)
    check("the PLC's copy is the drive's own", drive(0xC800, 5) == r.get("values"),
          "drive and PLC differ")
    # The firmware copies the status bits (FC 2) in the transaction after the registers.
    bits = [(AT_SPEED >> k) & 1 for k in range(8)]
    r = poll(lambda: plc("read", "-t", "discrete", "-r", "0", "-c", "8"), lambda v: v == bits)
    check("the PLC reads the drive's status bits (FC 2 copied into the discrete inputs)",
          r.get("values") == bits, r)

    start = len(fw.lines)
    r = plc("write", "-t", "holding", "-r", "0", "0")
    m = fw.wait_for(r"^to_drive=(\d+),(\d+) failures=(\d+) stack=(\d+)$", timeout=30, start=start)
    check("the PLC's stop (control word 0) reaches the drive",
          m is not None and int(m.group(1)) == 0 and drive(0xC800, 1) == [0],
          m.group(0) if m else fw.lines[-3:])
    check("stack high-water mark measured", m is not None and 0 < int(m.group(4)) < 8192,
          m.group(0) if m else "none")
finally:
    fw.stop()
    sim.stop()

raise SystemExit(summary())
