#!/usr/bin/env python3
"""The ferrule CLI against `ferrule-sim lecom` over pseudo-terminals, as separate processes.

usage: lecom_cli_test.py <ferrule> <ferrule-sim>
Each check prints 'ok <name>' or 'FAIL <name>: why'; the last line is 'N passed, M failed'.
"""
import subprocess
import sys

from harness import Sim, check, json_lines, summary

ferrule, ferrule_sim = sys.argv[1], sys.argv[2]


def run(*args, timeout=30):
    p = subprocess.run([ferrule, *args], capture_output=True, text=True, timeout=timeout)
    return p.returncode, p.stdout, p.stderr


# Golden telegrams of protocols/lecom.md §4, without opening anything.
for args, want in [(["read", "C46", "-a", "1"], "04 30 31 34 36 05"),
                   (["read", "C68", "-a", "25"], "04 32 35 36 38 05"),
                   (["read", "C111", "-a", "1"], "04 30 31 3B 31 05"),
                   (["read", "C1002", "-a", "1"], "04 30 31 45 3C 05"),
                   (["read", "C1002/0", "-a", "1"], "04 30 31 21 30 33 45 41 30 30 05"),
                   (["write", "C11", "95.2", "-a", "34"], "04 33 34 02 31 31 39 35 2E 32 03 13"),
                   (["write", "C9", "12", "-a", "1"], "04 30 31 02 30 39 31 32 03 09"),
                   (["write", "C40", "0", "-a", "0"], "04 30 30 02 34 30 30 03 37")]:
    rc, out, _ = run("lecom", *args, "--dry-run", "--port", "/nonexistent")
    check(f"dry-run {' '.join(args)}", rc == 0 and out.strip() == want, out)

rc, _, err = run("lecom", "read", "C7000", "--dry-run")
check("standard code above 6229 is a usage error", rc == 2 and "6229" in err, err)
rc, _, err = run("lecom", "read", "C46", "-a", "20", "--dry-run")
check("RECEIVE to a group address is a usage error", rc == 2 and "group" in err, err)
rc, _, err = run("lecom", "write", "C46", "12.", "--dry-run")
check("a decimal point without decimals is refused", rc == 2, err)

# decode: the reply vectors, every error form, a bad BCC, garbage between telegrams.
rc, out, _ = run("decode", "lecom", "--json", "02 34 36 33 35 2E 34 03 1D", "02 34 36 3F 03 3E",
                 "02 34 36 04", "02 36 38 48 30 39 30 30 03 4C", "06", "15",
                 "02 44 30 53 38 32 45 56 31 32 33 03 0D")
j = json_lines(out)
check("decode reply vectors", rc == 0 and len(j) == 7
      and j[0]["code"] == 46 and j[0]["number"] == 35.4 and j[0]["bcc"] == "ok"
      and j[1]["kind"] == "reply ?" and "checksum" in j[1]["meaning"]
      and j[2]["kind"] == "reply EOT" and "no such code" in j[2]["meaning"]
      and j[3]["value"] == "H0900" and j[3]["number"] == 0x900
      and j[4]["kind"] == "ACK" and j[5]["kind"] == "NAK"
      and j[6]["code"] == 200 and j[6]["value"] == 'S"82EV123"', out)
rc, out, _ = run("decode", "lecom", "04 33 34 02 31 31 39 35 2E 32 03 13", "AA BB",
                 "04 30 31 02 30 39 31 32 03 08")
check("decode SEND, garbage and a bad BCC", rc == 1 and "SEND to drive 34 C0011 = 95.2, BCC ok" in out
      and "not a telegram" in out and "BCC bad: 0x08, the bytes give 0x09" in out, out)

# Drives 1, 2 and 3 on one line (4900 profile), one pty.
sim = Sim(ferrule_sim, "lecom", "drives", "--address", "1,2,3")
port = ["--port", sim.link]

rc, out, _ = run("lecom", "read", "C0009", "C0200", "-a", "2", "--json", *port)
j = json_lines(out)
check("read C0009 and C0200", rc == 0 and j[0]["number"] == 2 and j[0]["address"] == 2
      and j[1]["format"] == "string" and j[1]["text"].startswith("4902"), out)
rc, out, _ = run("lecom", "write", "C0046", "750", "-a", "3", *port)
rc2, out2, _ = run("lecom", "read", "C46", "-a", "3", *port)
check("write then read back C0046", rc == 0 and "ACK" in out and rc2 == 0
      and out2.strip() == "drive 3 C0046 = 750", out + out2)
rc, out, _ = run("lecom", "read", "C0999", "-a", "1", "--json", *port)
j = json_lines(out)
check("unknown code is a device error", rc == 1 and j[0]["ok"] is False and j[0]["category"] == "lecom"
      and "no such code" in j[0]["error"], out)
rc, out, err = run("lecom", "write", "C0050", "1", "-a", "1", *port)
check("writing a read-only code is refused (NAK)", rc == 1 and "refused" in err, err)
rc, out, err = run("lecom", "read", "C0050", "-a", "7", "--timeout", "100", "--retries", "1", *port)
check("no drive at address 7 is a timeout", rc == 3 and "no reply" in err, err)
rc, out, err = run("lecom", "read", "C0009", "-a", "1", "--trace", *port)
check("trace shows both directions", rc == 0 and "-> 04 30 31 30 39 05" in err
      and "<- 02 30 39 31 03" in err, err)
rc, out, _ = run("lecom", "write", "C0040", "0", "-a", "0", "--json", *port)
j = json_lines(out)
check("broadcast write needs no reply", rc == 0 and j[0]["acknowledged"] is False, out)
rc, out, _ = run("lecom", "poll", "C0009", "C0050", "-d", "1,2,3", "--cycles", "3", "--refresh", "100",
                 "--json", *port)
j = json_lines(out)
last = j[-1] if j else {}
check("poll three drives", rc == 0 and last.get("cycles", 0) >= 3
      and [d["address"] for d in last["drives"]] == [1, 2, 3]
      and all(d["online"] for d in last["drives"])
      and [d["values"]["C0009"]["number"] for d in last["drives"]] == [1, 2, 3], out)
rc, out, _ = run("lecom", "poll", "C0050", "-d", "1,4", "--cycles", "4", "--refresh", "100",
                 "--timeout", "50", "--retries", "0", *port, timeout=60)
check("poll shows a missing drive offline", rc == 3 and "OFFLINE" in out and "online" in out, out)
sim.stop()

# 4900-style replies: a bare EOT for an unknown code, and a drive with a trip.
sim = Sim(ferrule_sim, "lecom", "drives", "--address", "5", "--bare-replies", "--trip", "11",
          "--family", "8200")
port = ["--port", sim.link, "-a", "5"]
rc, out, _ = run("lecom", "read", "C0999", "--json", *port)
j = json_lines(out)
check("bare EOT is 'no such code'", rc == 1 and "no such code" in j[0]["error"], out)
rc, out, _ = run("lecom", "read", "C0067", "--profile", "lenze-8200", *port)
check("trip number", rc == 0 and out.strip() == "drive 5 C0067 = 11", out)
sim.stop()

sys.exit(summary())
