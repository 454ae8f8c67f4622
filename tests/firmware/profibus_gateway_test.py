"""examples/firmware/profibus_gateway in QEMU: its DP slave (USART1, address 8, ident 0x0F2A)
brought up by `ferrule profibus` (diagnosis, configuration, parameterisation, data exchange),
its drive line (USART2) on `ferrule-sim modbus`. The gateway paper's start command
06 C8 00 00 25 goes out as DP outputs, reaches the simulated drive (read back over the
simulator's Modbus TCP side) and the drive's echo comes back as the DP inputs; a stop follows
the same way."""
import json
import subprocess
import time

from qemu import Firmware, Sim, args, check, summary

a = args("ferrule", "sim")
sim = Sim(a.sim, "modbus", "drive", "--tcp", "0")
tcp = sim.proc.stdout.readline().strip()  # the simulator's second line: 127.0.0.1:PORT
START = "06 C8 00 00 25"
STOP = "06 C8 00 00 00"


def profibus(*argv):
    """`ferrule profibus …` on the firmware's DP line: exit status and JSON lines. A generous
    slot time: the guest and the host share a busy machine."""
    r = subprocess.run([a.ferrule, "profibus", *argv, "--port", fw.pty["usart1"], "--timeout",
                        "200", "--json"], capture_output=True, text=True, timeout=60)
    lines = [json.loads(line) for line in r.stdout.splitlines() if line.startswith("{")]
    return r.returncode, lines, r.stderr


def command(out):
    """Data exchange with `out` until the drive's reply comes back as the inputs (3 tries).
    The example waits 100 ms for the drive and resends once, which a loaded machine may
    miss: the gateway then counts the command failed and takes the next one when the
    outputs change, so a try that fails puts zeros out (no Modbus request) before the next."""
    for _ in range(3):
        rc, x, err = profibus("exchange", "--out", out, "--no-init", "--count", "6",
                              "--interval-ms", "50")
        if rc == 0 and x and x[-1].get("inputs") == out:
            break
        profibus("exchange", "--out", "00 00 00 00 00", "--no-init", "--count", "2")
    return rc, x, err


def control_word():
    """The simulated drive's control word (0xC800), read by the host over TCP."""
    r = subprocess.run([a.ferrule, "modbus", "read", "--host", tcp, "-r", str(0xC800), "--json"],
                       capture_output=True, text=True, timeout=30)
    return json.loads(r.stdout.splitlines()[-1]).get("values", [None])[0] if r.stdout else None


fw = Firmware(a.elf, usart1="pty", usart2=sim.link)
try:
    check("boots", fw.wait_for(r"^boot: STM32F405") is not None, "no boot line")
    # The first request may go out before QEMU listens on the pty (it looks once a second).
    deadline = time.monotonic() + 20
    rc, diag, err = profibus("diag")
    while rc != 0 and time.monotonic() < deadline:
        rc, diag, err = profibus("diag")
    d = diag[-1] if diag else {}
    check("diag before parameterisation: ident 0x0F2A, not ready, Prm_Req",
          rc == 0 and d.get("ident_number") == 0x0F2A and not d.get("ready")
          and "Prm_Req" in d.get("station_status_2", []), f"{diag} {err}")
    rc, cfg, err = profibus("get-cfg")
    check("get-cfg: 24 14, 5 bytes out, 5 in",
          rc == 0 and cfg and cfg[-1].get("cfg") == "24 14" and cfg[-1].get("outputs") == 5
          and cfg[-1].get("inputs") == 5, f"{cfg} {err}")

    start = len(fw.lines)
    rc, x, err = profibus("exchange", "--out", "00 00 00 00 00")
    check("exchange: start-up with the slave's ident and configuration",
          rc == 0 and len(x) == 2 and x[0].get("ready") and x[0].get("ident_number") == 0x0F2A
          and x[0].get("cfg") == "24 14", f"{x} {err}")
    rc, x, err = command(START)
    check("the drive's echo of the start command comes back as the DP inputs",
          rc == 0 and x and x[-1].get("inputs") == START, f"{x[-1:]} {err}")
    m = fw.wait_for(r"^delivered=[1-9]", timeout=30, start=start)
    m = m and fw.wait_for(r"^delivered=(\d+) failed=(\d+) exceptions=(\d+) stack=(\d+)$",
                          start=fw.matched_at)
    check("the gateway reports the command delivered, no exception",
          m is not None and int(m.group(3)) == 0, m.group(0) if m else fw.lines[-3:])
    word = control_word()
    check("the simulated drive holds the start command: control word 0x0025", word == 0x0025,
          word)

    rc, d, err = profibus("diag")
    check("diag in Data_Exchange: ready", rc == 0 and d and d[-1].get("ready"), f"{d} {err}")

    rc, x, err = command(STOP)
    check("the stop command's echo comes back", rc == 0 and x and x[-1].get("inputs") == STOP,
          f"{x[-1:]} {err}")
    word = control_word()
    check("the simulated drive holds the stop: control word 0", word == 0, word)
    check("stack high-water mark measured", m is not None and 0 < int(m.group(4)) < 8192,
          m.group(0) if m else "none")
finally:
    fw.stop()
    sim.stop()

raise SystemExit(summary())
