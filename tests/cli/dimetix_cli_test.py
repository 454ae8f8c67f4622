#!/usr/bin/env python3
"""The ferrule CLI against `ferrule-sim dimetix` over pseudo-terminals, as separate processes.

usage: dimetix_cli_test.py <ferrule> <ferrule-sim>
Each check prints 'ok <name>' or 'FAIL <name>: why'; the last line is 'N passed, M failed'.
"""
import subprocess
import sys

from harness import Sim, check, json_lines, summary

ferrule, ferrule_sim = sys.argv[1], sys.argv[2]


def run(*args, timeout=30):
    p = subprocess.run([ferrule, "dimetix", *args], capture_output=True, text=True, timeout=timeout)
    return p.returncode, p.stdout, p.stderr


# Golden requests of protocols/dimetix.md §8.1, without opening anything.
for args, want in [(["measure"], "s0g"), (["config", "set", "v", "0", "100000"], "s0v+0+100000"),
                   (["config", "set", "uof", "-10000", "--address", "3"], "s3uof-10000"),
                   (["config", "save"], "s0s"), (["errors", "read"], "s0re"), (["signal"], "s0m+0")]:
    rc, out, _ = run(*args, "--dry-run", "--port", "/nonexistent")
    check(f"dry-run {want}", rc == 0 and out.strip().endswith(want + "\\r\\n")
          and out.split("   ")[0] == " ".join(f"{b:02X}" for b in (want + "\r\n").encode()), out)

# Two sensors on one line (IDs 0 and 3), 1234.5 mm, fixed.
sim = Sim(ferrule_sim, "dimetix", "sensors", "--address", "0", "--address", "3", "--distance", "1234.5")
port = ["--port", sim.link]

rc, out, _ = run("measure", "--count", "3", "--json", *port)
j = json_lines(out)
check("measure 3 times", rc == 0 and [x["sample"] for x in j] == [1, 2, 3]
      and all(x["distance_mm"] == 1234.5 and x["id"] == 0 for x in j), out)
rc, out, _ = run("measure", "--address", "3", *port)
check("measure sensor 3 (text)", rc == 0 and out.strip() == "sensor 3 distance     1234.5 mm", out)
rc, out, _ = run("track", "4", "--interval", "40", "--json", *port)
j = json_lines(out)
check("track 4 samples with sNf + sNq", rc == 0 and len(j) == 4 and all(x["distance_mm"] == 1234.5 for x in j)
      and [x["sample"] for x in j] == [1, 2, 3, 4], out)
rc, out, _ = run("temperature", "--json", *port)
check("temperature", rc == 0 and json_lines(out)[0]["temperature_celsius"] == 25.4, out)
rc, out, _ = run("signal", "--json", *port)
check("signal", rc == 0 and json_lines(out)[0]["signal"] == 8384, out)
rc, out, _ = run("info", "--json", *port)
j = json_lines(out)
check("info", rc == 0 and j[0]["device_type"] == 401 and j[0]["serial_number"] == 12345678, out)
rc, out, _ = run("laser-on", *port)
check("laser on", rc == 0 and "laser on: ok" in out, out)
rc, out, _ = run("stop", *port)
check("stop", rc == 0 and "stop/clear: ok" in out, out)
rc, out, _ = run("errors", "read", "--json", *port)
j = json_lines(out)
check("error stack has the boot marker", rc == 0 and j[0]["errors"][0]["code"] == 200, out)
rc, out, _ = run("errors", "clear", *port)
check("clear error stack", rc == 0, out)
rc, out, _ = run("config", "set", "mc", "1", *port)
rc2, out2, _ = run("config", "get", "mc", "--json", *port)
check("config set + get", rc == 0 and rc2 == 0 and json_lines(out2)[0]["values"] == [1], out + out2)

# Faults: no sensor at ID 5 (exit 3), a command the table does not know (exit 2),
# continuous output refused on a multi-drop line (exit 3 with the reason).
rc, out, err = run("measure", "--address", "5", "--timeout", "300", "--retries", "0", *port)
check("no sensor at ID 5 is a timeout", rc == 3 and "no reply" in err, err)
rc, out, err = run("config", "get", "xx", *port)
check("unknown mnemonic is a usage error", rc == 2, err)
rc, out, err = run("measure", "--address", "100", *port)
check("ID 100 is a usage error", rc == 2, err)
rc, out, err = run("measure", "--trace", *port)
check("trace shows the ASCII lines", rc == 0 and "-> 73 30 67 0D 0A" in err and "<- 67 30 67 2B" in err, err)
sim.stop()

# A sensor whose first measurement fails with @E255 (signal too low): exit 1, the manual's text.
sim = Sim(ferrule_sim, "dimetix", "sensors", "--error", "255")
rc, out, _ = run("measure", "--json", "--port", sim.link)
j = json_lines(out)
check("@E255 is a device error", rc == 1 and j[0]["ok"] is False and j[0]["category"] == "dimetix"
      and j[0]["code"] == 255 and "signal too low" in j[0]["error"], out)
rc, out, _ = run("measure", "--json", "--port", sim.link)
check("the next measurement succeeds", rc == 0 and json_lines(out)[0]["ok"] is True, out)
sim.stop()

# decode: a request, a format-300 answer, an error answer, a buffered read.
p = subprocess.run([ferrule, "decode", "dimetix", "--json",
                    (b"s0g\r\ng0g+00000234+008384+254\r\ng0@E255\r\ng0q+00012345+1\r\n").hex()],
                   capture_output=True, text=True)
j = json_lines(p.stdout)
check("decode dimetix", p.returncode == 0 and len(j) == 4 and j[0]["direction"] == "request"
      and j[1]["values"] == [234, 8384, 254] and j[2]["error_code"] == 255 and j[3]["buffer_status"] == 1, p.stdout)

sys.exit(summary())
