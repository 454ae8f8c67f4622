#!/usr/bin/env python3
"""`ferrule profibus` against `ferrule-sim profibus-gateway` over pseudo-terminals, as separate
processes: the gateway paper's start command 06 C8 00 00 25 goes out as DP outputs, through the
gateway to a simulated VFD and back as DP inputs; the slave's diagnosis before and after
parameterization; its refusals (wrong ident, wrong configuration, Data_Exchange before start-up)
and a station that is not there. Also with the drive line on a separate `ferrule-sim modbus`
(--drive-port), and with the DP side on a serial port (--dp-port: one end of a socat pty pair,
the master on the other).

usage: profibus_gateway_cli_test.py <ferrule> <ferrule-sim>
Each check prints 'ok <name>' or 'FAIL <name>: why'; the last line is 'N passed, M failed'.
"""
import os
import subprocess
import sys
import tempfile
import time

from harness import Sim, check, json_lines, require, summary

ferrule, ferrule_sim = sys.argv[1], sys.argv[2]
require(programs=["socat"])
START = "06 C8 00 00 25"


def run(*args, timeout=30):
    p = subprocess.run([ferrule, *args], capture_output=True, text=True, timeout=timeout)
    return p.returncode, p.stdout, p.stderr


# Golden requests of protocols/modbus_profibus.md §B.9, without opening anything.
for args, want in [(["diag"], "68 05 05 68 88 82 6D 3C 3E F1 16"),
                   (["cfg", "11 21"], "68 07 07 68 88 82 6D 3E 3E 11 21 25 16"),
                   (["clear"], "68 07 07 68 FF 82 46 3A 3E 02 00 41 16"),
                   (["exchange", "--out", "00 01 02 03 04 05 06 07"],
                    "A2 08 02 6D 00 01 02 03 04 05 06 07 93 16"),
                   # The golden Set_Prm is a second request (FCV 1: 7D); as a first one, 6D.
                   (["set-prm", "--ident", "0x0815", "--lock", "--watchdog-ms", "1000"],
                    "68 0C 0C 68 88 82 6D 3D 3E 88 0A 0A 0B 08 15 00 B6 16")]:
    rc, out, err = run("profibus", *args, "--dry-run", "--port", "/nonexistent")
    check(f"dry-run {' '.join(args)}", rc == 0 and out.strip() == want, out + err)
# Lock_Req is the default; --no-lock sends Station_Status without it (only min_TSDR and
# User_Prm_Data for the slave), --lock is still accepted.
for flags, status in [([], "88"), (["--lock"], "88"), (["--no-lock"], "08")]:
    rc, out, err = run("profibus", "set-prm", "--ident", "0x0815", "--watchdog-ms", "1000", *flags,
                       "--dry-run")
    tokens = out.split()
    check(f"dry-run set-prm {' '.join(flags) or '(default)'}: Station_Status {status}",
          rc == 0 and len(tokens) == 18 and tokens[9] == status, out + err)
rc, _, err = run("profibus", "diag", "--address", "2", "--dry-run")
check("the slave cannot have the master's address", rc == 2 and "--master-address" in err, err)

sim = Sim(ferrule_sim, "profibus-gateway", "dp")
# A pty has no wire time, but a busy machine may be slow to answer: a generous slot time.
common = ["--port", sim.link, "--timeout", "200"]
try:
    rc, out, err = run("profibus", "diag", *common)
    check("diag before parameterization: Station_Not_Ready, Prm_Req", rc == 0
          and "Station_Status_1  0x02  Station_Not_Ready" in out
          and "Station_Status_2  0x05  Prm_Req, always 1" in out
          and "Diag.Master_Add   255 (none)" in out and "Ident_Number      0x0815" in out
          and "extended          08 00 00 00 00 00 00 01" in out, out + err)
    rc, out, err = run("profibus", "set-prm", "--ident", "0x0815", "--no-lock", "--watchdog-ms",
                       "1000", *common)
    rc2, out2, _ = run("profibus", "diag", "--json", *common)
    j = json_lines(out2)
    check("set-prm --no-lock: the slave keeps waiting for parameters", rc == 0
          and "not locked (no Lock_Req" in out and rc2 == 0 and len(j) == 1
          and "Prm_Req" in j[0]["station_status_2"] and "WD_On" not in j[0]["station_status_2"]
          and j[0]["master_address"] == 255, out + err + out2)
    rc, out, err = run("profibus", "get-cfg", "--json", *common)
    j = json_lines(out)
    check("get-cfg: 5 bytes out, 5 in", rc == 0 and len(j) == 1 and j[0]["cfg"] == "24 14"
          and j[0]["outputs"] == 5 and j[0]["inputs"] == 5, out + err)

    rc, out, err = run("profibus", "exchange", "--out", START, "--count", "6", "--interval-ms",
                       "50", "--json", *common)
    j = json_lines(out)
    check("exchange: start-up with the slave's ident and configuration", rc == 0 and len(j) == 7
          and j[0]["ready"] and j[0]["ident_number"] == 0x0815 and j[0]["cfg"] == "24 14", out + err)
    check("exchange: the paper's command comes back as the drive's echo", rc == 0 and len(j) == 7
          and all(x["outputs"] == START for x in j[1:]) and j[-1]["inputs"] == START
          and not j[-1]["data_high"], out + err)
    rc, out, err = run("profibus", "exchange", "--out", START, "--no-init", *common)
    check("exchange --no-init in Data_Exchange, text", rc == 0
          and f"1: outputs {START} -> inputs {START} (DL)" in out, out + err)
    rc, out, err = run("profibus", "diag", "--json", *common)
    j = json_lines(out)
    check("diag in Data_Exchange: ready, no flags", rc == 0 and len(j) == 1 and j[0]["ready"]
          and j[0]["station_status_1"] == [] and j[0]["station_status_2"] == ["always 1"], out)

    # Locked to master 2: master 3's Set_Prm is acknowledged and not taken, whatever it asks.
    for flags in ([], ["--no-lock"]):
        rc, out, err = run("profibus", "set-prm", "--ident", "0x0815", "--master-address", "3",
                           *flags, *common)
        check(f"set-prm from master 3 {' '.join(flags)}: locked to another master", rc == 1
              and "ferrule: Set_Prm: slave 8: locked to another master (Master_Lock)" in err,
              out + err)
    rc, out, err = run("profibus", "diag", "--master-address", "3", *common)
    check("diag from master 3: Master_Add 2, so Master_Lock", rc == 0
          and "Station_Status_1  0x80  Master_Lock" in out and "Diag.Master_Add   2\n" in out,
          out + err)
    rc, out, err = run("profibus", "exchange", "--out", START, "--no-init", *common)
    check("master 2 still exchanges data", rc == 0 and f"outputs {START}" in out, out + err)

    rc, out, err = run("profibus", "set-prm", "--ident", "0x1234", *common)
    check("set-prm with a wrong ident: the slave's Prm_Fault", rc == 1
          and "ferrule: Set_Prm: slave 8: parameter fault (Prm_Fault)" in err, out + err)
    rc, out, err = run("profibus", "diag", *common)
    check("diag after a wrong ident: Prm_Fault, Prm_Req", rc == 0
          and "Station_Status_1  0x42  Station_Not_Ready, Prm_Fault" in out
          and "Prm_Req" in out, out + err)
    rc, out, err = run("profibus", "exchange", "--out", START, "--no-init", *common)
    check("Data_Exchange before start-up: SAP not activated", rc == 1
          and "ferrule: Data_Exchange: slave 8: SAP not activated (RS)" in err, out + err)

    rc, out, err = run("profibus", "set-prm", "--ident", "0x0815", "--lock", "--watchdog-ms",
                       "2000", *common)
    check("set-prm: locked, watchdog 2 s", rc == 0
          and "ident 0x0815, watchdog 2000 ms (20 x 10 x 10 ms), locked" in out, out + err)
    rc, out, err = run("profibus", "cfg", "27 17", *common)
    check("cfg the slave does not have: Cfg_Fault", rc == 1
          and "slave 8: configuration fault (Cfg_Fault)" in err, out + err)
    rc, out, err = run("profibus", "set-prm", "--ident", "0x0815", *common)
    rc2, out2, err2 = run("profibus", "cfg", "24 14", *common)
    rc3, out3, _ = run("profibus", "diag", "--json", *common)
    j = json_lines(out3)
    check("set-prm, cfg: ready", rc == 0 and rc2 == 0
          and "Chk_Cfg to slave 8: 24 14: 5 bytes out, 5 in: accepted" in out2
          and rc3 == 0 and j and j[0]["ready"], out + err + out2 + err2 + out3)
    rc, out, err = run("profibus", "clear", *common)
    check("Global_Control Clear_Data", rc == 0 and "sent, no reply by design" in out, out + err)

    rc, out, err = run("profibus", "diag", "--address", "9", "--port", sim.link, "--timeout", "50")
    check("no slave at address 9: timeout after the resend", rc == 3
          and "ferrule: Slave_Diag: slave 9: no reply before the response timeout after 2 requests"
          in err, out + err)
finally:
    log = sim.stop()
check("the gateway delivered the command to the drive", "1 delivered, 0 failed" in log, log)

# The drive line on a separate `ferrule-sim modbus`.
drives = Sim(ferrule_sim, "modbus", "rtu")
try:
    gateway = Sim(ferrule_sim, "profibus-gateway", "dp", "--drive-port", drives.link,
                  "--address", "12", "--ident", "0x4224")
    try:
        rc, out, err = run("profibus", "exchange", "--out", START, "--count", "6",
                           "--interval-ms", "50", "--json", "--address", "12", "--port",
                           gateway.link, "--timeout", "200")
        j = json_lines(out)
        check("--drive-port: through a ferrule-sim modbus pty", rc == 0 and len(j) == 7
              and j[0]["ident_number"] == 0x4224 and j[-1]["inputs"] == START, out + err)
    finally:
        gateway.stop()
finally:
    drives.stop()

# The DP side on a serial port: socat makes two linked ptys; the gateway opens one as its DP
# port, the master the other.
tmp = tempfile.mkdtemp(prefix="ferrule-dp-")
a, b = os.path.join(tmp, "gateway"), os.path.join(tmp, "master")
socat = subprocess.Popen(["socat", f"pty,raw,echo=0,link={a}", f"pty,raw,echo=0,link={b}"],
                         stderr=subprocess.DEVNULL)
for _ in range(100):
    if os.path.exists(a) and os.path.exists(b):
        break
    time.sleep(0.05)
gateway = subprocess.Popen([ferrule_sim, "profibus-gateway", "--dp-port", a],
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
try:
    first = gateway.stdout.readline().strip()
    rc, out, err = run("profibus", "exchange", "--out", START, "--count", "6",
                       "--interval-ms", "50", "--json", "--port", b, "--timeout", "200")
    j = json_lines(out)
    check("--dp-port: the gateway on a serial port", first == a and rc == 0 and len(j) == 7
          and j[-1]["inputs"] == START, first + out + err)
finally:
    gateway.terminate()
    gateway.wait(timeout=10)
    socat.terminate()
    socat.wait(timeout=10)

sys.exit(summary())
