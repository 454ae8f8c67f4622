"""examples/firmware/lecom_master in QEMU against `ferrule-sim lecom`: three of the example's
six drives are on the line (01-03), drive 02 already turning backwards. The firmware's
start-up setpoint (C0046 = 1500 rpm) reaches drive 01, drives 04-06 never show online, and
the actual speeds (C0050) the firmware polls are those `ferrule lecom read` then reads from
the same simulated drives."""
import json
import subprocess
import time

from qemu import Firmware, Sim, args, check, summary

a = args("ferrule", "sim")
SPEEDS = r"^transactions=(\d+) C0050=(-?\d+(?:,-?\d+){5}) stack=(\d+)$"


def lecom(command, address, *rest):
    """`ferrule lecom <command> --address <address> …` on the simulator's line, as JSON."""
    out = subprocess.run([a.ferrule, "lecom", command, "--port", sim.link, "--address",
                          str(address), "--json", *rest],
                         capture_output=True, text=True, timeout=30).stdout
    return [json.loads(line) for line in out.splitlines() if line.strip()]


def settled(fw, want_1, want_2, timeout=60):
    """The first speeds report with drive 01 at `want_1` and drive 02 at `want_2` (FIX32)."""
    deadline = time.monotonic() + timeout
    start = 0
    while True:
        m = fw.wait_for(SPEEDS, timeout=max(0.0, deadline - time.monotonic()), start=start)
        if m is None:
            return None
        speeds = [int(v) for v in m.group(2).split(",")]
        if speeds[0] == want_1 and speeds[1] == want_2:
            return speeds, int(m.group(3))
        start = fw.matched_at + 1


sim = Sim(a.sim, "lecom", "bus", "--address", "1,2,3")
try:
    preset = lecom("write", 2, "C0046", "-700")
    check("host sets drive 02 turning at -700 rpm",
          preset and preset[0].get("acknowledged"), repr(preset))
    fw = Firmware(a.elf, usart2=sim.link)
    try:
        check("boots", fw.wait_for(r"^boot: STM32F405") is not None, "no boot line")
        write = fw.wait_for(r"^write drive=(\d+) C0046=(-?\d+) error=(\d+)$", timeout=30)
        check("start-up setpoint acknowledged by drive 01",
              write is not None and write.groups() == ("1", "15000000", "0"),
              write.group(0) if write else "\n".join(fw.lines[-5:]))
        report = settled(fw, 15_000_000, -7_000_000)
        check("drives 01 and 02 reach their setpoints in the firmware's polls",
              report is not None, "\n".join(fw.lines[-5:]))
        speeds, stack = report if report else ([], 0)
        check("stack high-water mark measured", 0 < stack < 4096, str(stack))
        online = [int(line.split("=")[1]) for line in fw.lines if line.startswith("online=")]
        check("drives 01-03 online, 04-06 never", online and online[-1] == 0b111 and
              all(m & ~0b111 == 0 for m in online), repr(online))
    finally:
        fw.stop()

    # The same simulated drives, read by the host CLI once QEMU has let go of the line (with
    # resends: QEMU may have left half a telegram on it).
    host = {d: {r["code"]: r for r in lecom("read", d, "C0046", "C0050", "--retries", "2")}
            for d in (1, 2, 3)}
    check("firmware's write arrived: drive 01's C0046 is 1500 rpm",
          host[1].get(46, {}).get("number") == 1500, repr(host[1]))
    host_speeds = [round(host[d][50]["number"] * 10_000) if 50 in host[d] else None
                   for d in (1, 2, 3)]
    check("firmware's C0050 of drives 01-03 equal the host's readings",
          speeds[:3] == host_speeds, f"firmware {speeds}, host {host_speeds}")
    check("drives 04-06 read 0 in the firmware (never answered)", speeds[3:] == [0, 0, 0],
          repr(speeds))
finally:
    sim.stop()

raise SystemExit(summary())
