#!/usr/bin/env python3
"""The ferrule CLI against ferrule-sim over pseudo-terminals, as separate processes.

usage: movilink_cli_test.py <ferrule> <ferrule-sim>
Each check prints 'ok <name>' or 'FAIL <name>: why'; the last line is 'N passed, M failed'.
"""
import subprocess
import sys

from harness import Sim, check, json_lines, summary

ferrule, ferrule_sim = sys.argv[1], sys.argv[2]


def run(*args, timeout=30):
    p = subprocess.run([ferrule, *args], capture_output=True, text=True, timeout=timeout)
    return p.returncode, p.stdout, p.stderr


sim = Sim(ferrule_sim, "movilink", "bus", "--address", "1", "--address", "2")
port = ["--port", sim.link]

# Golden vectors of protocols/movilink.md: the request bytes, without opening anything.
rc, out, _ = run("movilink", "read", "0x207E", "--dry-run", "--port", "/nonexistent")
check("dry-run read P000 is D2", rc == 0 and out.strip() == "02 01 86 31 00 20 7E 00 00 00 00 EA", out)
rc, out, _ = run("movilink", "write", "0x2071", "1", "--dry-run")
check("dry-run write volatile P871 is D5", rc == 0 and out.strip() == "02 01 86 33 00 20 71 00 00 00 01 E6", out)

# Parameters by index, JSON checked field by field.
rc, out, _ = run("movilink", "read", "8597", "--address", "2", "--json", *port)
j = json_lines(out)
check("read P810 of drive 2", rc == 0 and len(j) == 1 and j[0]["ok"] is True and j[0]["address"] == 2
      and j[0]["index"] == 8597 and j[0]["value"] == 2, out)
rc, out, _ = run("movilink", "write", "8599", "1500", "--json", *port)
j = json_lines(out)
check("write P812 volatile", rc == 0 and j[0]["value"] == 1500 and j[0]["service"] == "write volatile", out)
rc, out, _ = run("movilink", "read", "8599", *port)
check("read back P812 (text)", rc == 0 and "= 1500 (0x000005DC)" in out, out)

# Status, run to a speed, stop.
rc, out, _ = run("movilink", "status", "--json", *port)
j = json_lines(out)
check("status", rc == 0 and j[0]["ready"] is True and j[0]["fault"] is False and j[0]["speed_rpm"] == 0.0
      and j[0]["heat_sink_celsius"] == 20, out)
rc, out, _ = run("movilink", "run", "600", "--ramp", "200", "--interval", "50", "--json", *port)
j = json_lines(out)
check("run to 600 rpm shows the ramp", rc == 0 and len(j) >= 2 and j[-1]["speed_rpm"] == 600.0
      and j[0]["speed_rpm"] < 600.0 and all(x["ready"] for x in j), out)
rc, out, _ = run("movilink", "watch", "--count", "2", "--interval", "20", "--json", *port)
j = json_lines(out)
check("watch keeps the drive running", rc == 0 and len(j) == 2 and j[-1]["speed_rpm"] == 600.0, out)
rc, out, _ = run("movilink", "stop", "--ramp", "100", "--json", *port)
j = json_lines(out)
check("stop reaches standstill", rc == 0 and j[-1]["speed_rpm"] == 0.0, out)

# Faults: the drive's error reply (exit 1), a missing drive (exit 3), usage (exit 2).
rc, out, _ = run("movilink", "read", "0x1234", "--retries", "0", "--json", *port)
j = json_lines(out)
check("invalid index is a device error", rc == 1 and j[0]["ok"] is False and j[0]["category"] == "movilink"
      and "invalid parameter index" in j[0]["error"], out)
rc, out, err = run("movilink", "read", "8318", "--address", "7", "--retries", "1", *port)
check("no drive at address 7 is a timeout", rc == 3 and "no reply before the response timeout" in err, err)
rc, out, err = run("movilink", "read", "8318", "--port", "/dev/ferrule-no-such-port")
check("missing port is explained", rc == 3 and "no such port" in err, err)
rc, out, err = run("movilink", "read")
check("missing argument is a usage error", rc == 2, err)

# --trace shows both directions.
rc, out, err = run("movilink", "read", "8318", "--trace", *port)
check("trace shows request and reply", rc == 0 and "-> 02 01 86 31 00 20 7E" in err and "<- 1D 01 86" in err, err)

# decode: golden M2 request and response, and a bad BCC.
rc, out, _ = run("decode", "movilink", "02 01 85 00 06 20 00 0B B8 13 1D 01 85 02 06 00 00 06 06 9D", "--json")
j = json_lines(out)
check("decode M2", rc == 0 and len(j) == 2 and j[0]["direction"] == "request" and j[0]["pd"] == [6, 0x2000, 0xBB8]
      and j[1]["direction"] == "response" and j[1]["pd"] == [0x206, 0, 0x606] and j[1]["pdu"] == "3PD acyclic", out)
rc, out, _ = run("decode", "movilink", "1D 01 86 B1 00 20 7E 08 00 00 10 6D")
check("decode D4 error reply", rc == 0 and "invalid parameter index" in out, out)
rc, out, _ = run("decode", "movilink", "02 01 05 00 06 3A 98 01 F4 58")
check("decode bad BCC", rc == 1 and "checksum mismatch" in out, out)


# Status word 1, bits 1 (ready) and 5 (fault/warning) together (movilink.md §3.3).
def pd3_reply(pi1):
    body = [0x1D, 0x01, 0x05, pi1 >> 8, pi1 & 0xFF, 0x07, 0xD0, 0x02, 0xBC]
    bcc = 0
    for b in body:
        bcc ^= b
    return " ".join(f"{b:02X}" for b in body + [bcc])


check("the issue's warning vector is built alike", pd3_reply(0x0427) == "1D 01 05 04 27 07 D0 02 BC 53")
for pi1, state, text, numbers in [
        (0x0104, "not ready", "ready 0, output stage 0, unit status 1", (0, 0, 1)),
        (0x2B24, "fault", "ready 0, output stage 0, FAULT 43", (43, 0, 0)),
        (0x0407, "ready", "ready 1, output stage 1, unit status 4", (0, 0, 4)),
        (0x0427, "warning", "ready 1, output stage 1, WARNING 4", (0, 4, 0))]:
    rc, out, _ = run("decode", "movilink", pd3_reply(pi1))
    check(f"decode status word 0x{pi1:04X} text: {state}", rc == 0 and f"status word 1: {text}\n" in out, out)
    rc, out, _ = run("decode", "movilink", pd3_reply(pi1), "--json")
    j = json_lines(out)
    sw = j[0].get("status_word", {}) if len(j) == 1 else {}
    check(f"decode status word 0x{pi1:04X} JSON: {state}", rc == 0 and sw.get("value") == pi1
          and sw.get("state") == state
          and (sw.get("fault_number"), sw.get("warning_number"), sw.get("unit_status")) == numbers, out)

print(sim.stop().strip().splitlines()[-1])

# `movilink status` of a drive with a warning, then of one with a fault.
sim = Sim(ferrule_sim, "movilink", "bus", "--warning", "4")
rc, out, _ = run("movilink", "status", "--json", "--port", sim.link)
j = json_lines(out)
check("status of a drive with warning 4", rc == 0 and j[0]["state"] == "warning" and j[0]["ready"] is True
      and j[0]["warning"] is True and j[0]["warning_number"] == 4 and j[0]["fault"] is False
      and j[0]["fault_number"] == 0, out)
rc, out, _ = run("movilink", "status", "--port", sim.link)
check("status text names the warning", rc == 0
      and "(ready 1, output stage 0, fault 0, warning 1, warning number 4)" in out, out)
rc, out, _ = run("movilink", "watch", "--count", "3", "--interval", "0", "--json", "--port", sim.link)
j = json_lines(out)
check("watch: a warning is no failed exchange", rc == 0 and len(j) == 3 and all(x["warning"] for x in j), out)
sim.stop()
sim = Sim(ferrule_sim, "movilink", "bus", "--fault", "7")
rc, out, _ = run("movilink", "status", "--json", "--port", sim.link)
j = json_lines(out)
check("status of a drive with fault 7", rc == 0 and j[0]["state"] == "fault" and j[0]["ready"] is False
      and j[0]["fault"] is True and j[0]["fault_number"] == 7 and j[0]["warning"] is False, out)
rc, out, _ = run("movilink", "status", "--port", sim.link)
check("status text names the fault", rc == 0
      and "(ready 0, output stage 0, fault 1, warning 0, fault number 7)" in out, out)
sim.stop()

# A lossy line: replies dropped or damaged, the master's resends get through.
sim = Sim(ferrule_sim, "movilink", "bus", "--drop", "30", "--corrupt", "10", "--seed", "7")
rc, out, err = run("movilink", "status", "--retries", "8", "--json", "--port", sim.link)
j = json_lines(out)
check("status over a lossy line", rc == 0 and j[0]["ready"] is True, out + err)
stats = sim.stop().strip().splitlines()[-1]
check("the simulator dropped or damaged replies", " 0 dropped, 0 corrupted" not in stats, stats)

sys.exit(summary())
