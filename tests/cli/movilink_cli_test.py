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

print(sim.stop().strip().splitlines()[-1])

# A lossy line: replies dropped or damaged, the master's resends get through.
sim = Sim(ferrule_sim, "movilink", "bus", "--drop", "30", "--corrupt", "10", "--seed", "7")
rc, out, err = run("movilink", "status", "--retries", "8", "--json", "--port", sim.link)
j = json_lines(out)
check("status over a lossy line", rc == 0 and j[0]["ready"] is True, out + err)
stats = sim.stop().strip().splitlines()[-1]
check("the simulator dropped or damaged replies", " 0 dropped, 0 corrupted" not in stats, stats)

sys.exit(summary())
