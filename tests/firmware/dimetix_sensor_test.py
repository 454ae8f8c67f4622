"""examples/firmware/dimetix_sensor in QEMU against `ferrule-sim dimetix`: the firmware
connects (sNc until gN?), reports the sensor's first measurement error as its code, recovers
with the next measurement and reports the distance that `ferrule dimetix measure` then reads
from the same simulated sensor."""
import json
import subprocess

from qemu import Firmware, Sim, args, check, summary

a = args("ferrule", "sim")
# Sensor ID 1 as in the example; the first measurement answers g1@E255 (signal too low).
sim = Sim(a.sim, "dimetix", "sensor", "--address", "1", "--distance", "2345.6", "--error", "255")
fw = Firmware(a.elf, usart2=sim.link)
try:
    check("boots", fw.wait_for(r"^boot: STM32F405") is not None, "no boot line")
    connected = fw.wait_for(r"^connected$", timeout=30)
    check("connects with sNc", connected is not None, "\n".join(fw.lines[-5:]))
    after = fw.matched_at if connected else 0
    error = fw.wait_for(r"^error=(\d+)$", timeout=30, start=after)
    check("the sensor's error answer is reported as its code",
          error is not None and int(error.group(1)) == 255,
          error.group(0) if error else "\n".join(fw.lines[-5:]))
    after = fw.matched_at if error else after
    distance = fw.wait_for(r"^distance=(-?\d+)$", timeout=30, start=after)
    check("measures again after the error", distance is not None, "\n".join(fw.lines[-5:]))
    stack = fw.wait_for(r"^transactions=\d+ stack=(\d+)$", timeout=60)
    check("stack high-water mark measured", stack is not None and 0 < int(stack.group(1)) < 4096,
          stack.group(0) if stack else "none")
    check("stays connected",
          not any(line == "disconnected" for line in fw.lines), "\n".join(fw.lines))
finally:
    fw.stop()

# The same simulated sensor, read by the host CLI once QEMU has let go of the line (with
# resends: QEMU may have left half a command on it).
try:
    out = subprocess.run([a.ferrule, "dimetix", "measure", "--port", sim.link, "--address", "1",
                          "--retries", "2", "--json"], capture_output=True, text=True,
                         timeout=30).stdout
    host = json.loads(out.splitlines()[-1]) if out.strip() else {}
    mm = host.get("distance_mm")
    check("firmware's distance equals the host's reading (0.1 mm)",
          distance is not None and mm is not None and int(distance.group(1)) == round(mm * 10),
          f"firmware {distance.group(1) if distance else None}, host {out!r}")
finally:
    sim.stop()

raise SystemExit(summary())
