"""examples/firmware/movilink_master in QEMU against `ferrule-sim movilink`: the drive reaches
the commanded 1500 rpm through the cyclic 3PD exchange, and the firmware's P014 read gives
the heat sink temperature that `ferrule movilink status` reads from the same simulated drive."""
import json
import subprocess

from qemu import Firmware, Sim, args, check, summary

a = args("ferrule", "sim")
sim = Sim(a.sim, "movilink", "drive")
fw = Firmware(a.elf, usart2=sim.link)
try:
    check("boots", fw.wait_for(r"^boot: STM32F405") is not None, "no boot line")
    m = fw.wait_for(r"speed=7500\b")  # 1500 rpm in 0.2 rpm digits
    check("drive reaches the commanded speed", m is not None, "\n".join(fw.lines[-5:]))
    status = fw.wait_for(r"status=(\d+)", start=fw.matched_at if m else 0)
    check("drive enabled and running (status word state 4, bits 0-2 set)",
          status is not None and int(status.group(1)) & 0xFF07 == 0x0407,
          status.group(0) if status else "no status line")
    p014 = fw.wait_for(r"^P014=(-?\d+)$")
    check("P014 read arrives", p014 is not None, "\n".join(fw.lines[-5:]))
    stack = fw.wait_for(r"stack=(\d+)")
    check("stack high-water mark measured", stack is not None and 0 < int(stack.group(1)) < 4096,
          stack.group(0) if stack else "none")
finally:
    fw.stop()
    sim.stop()

# The same simulated drive, read by the host CLI: the firmware's value must be the drive's.
host_sim = Sim(a.sim, "movilink", "drive")
try:
    out = subprocess.run([a.ferrule, "movilink", "status", "--port", host_sim.link, "--json"],
                         capture_output=True, text=True, timeout=30).stdout
    host = json.loads(out.splitlines()[-1]) if out.strip() else {}
    temp = host.get("heat_sink_celsius")
    check("firmware's P014 equals the host's reading",
          p014 is not None and temp is not None and int(p014.group(1)) == int(temp),
          f"firmware {p014.group(1) if p014 else None}, host {out!r}")
finally:
    host_sim.stop()

raise SystemExit(summary())
