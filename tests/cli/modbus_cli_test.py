#!/usr/bin/env python3
"""The ferrule CLI against `ferrule-sim modbus` over a pseudo-terminal (RTU) and TCP, as
separate processes; mbpoll against ferrule-sim's TCP server.

usage: modbus_cli_test.py <ferrule> <ferrule-sim>
Each check prints 'ok <name>' or 'FAIL <name>: why'; the last line is 'N passed, M failed'.
"""
import socket
import subprocess
import sys

from harness import Sim, check, json_lines, require, summary

ferrule, ferrule_sim = sys.argv[1], sys.argv[2]
require(programs=["mbpoll"])


def run(*args, timeout=30):
    p = subprocess.run([ferrule, *args], capture_output=True, text=True, timeout=timeout)
    return p.returncode, p.stdout, p.stderr


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


# Golden ADUs, without opening anything: the gateway paper's start command, reads, writes.
for args, want in [(["write", "-r", "0xC800", "0x0025"], "01 06 C8 00 00 25 76 71"),
                   (["read", "-r", "0", "-c", "1"], "01 03 00 00 00 01 84 0A"),
                   (["read", "-t", "input", "-r", "8", "-c", "1", "-a", "17"],
                    "11 04 00 08 00 01 B2 98"),
                   (["read", "-t", "coil", "-r", "0x13", "-c", "37", "-a", "17"],
                    "11 01 00 13 00 25 0E 84"),
                   (["write", "-t", "coil", "-r", "0xAC", "1", "-a", "17"],
                    "11 05 00 AC FF 00 4E 8B"),
                   (["write", "-t", "coil", "-r", "19", "1", "0", "1", "1", "0", "0", "1", "1",
                     "1", "0", "-a", "17"], "11 0F 00 13 00 0A 02 CD 01 BF 0B"),
                   (["write", "-r", "1", "0x000A", "0x0102", "-a", "17"],
                    "11 10 00 01 00 02 04 00 0A 01 02 C6 F0"),
                   (["write", "-r", "0", "--as", "float", "1.5"],
                    "01 10 00 00 00 02 04 3F C0 00 00 FF 87"),
                   (["write", "-r", "0", "--as", "float", "--word-order", "cdab", "1.5"],
                    "01 10 00 00 00 02 04 00 00 3F C0 E2 0F"),
                   (["write", "-r", "0", "--as", "i16", "-1"], "01 06 00 00 FF FF 88 7A"),
                   (["diag", "--data", "0xA537", "-a", "17"], "11 08 00 00 A5 37 D8 1D"),
                   (["id"], "01 2B 0E 01 00 70 77"),
                   (["read", "--host", "plc:1502", "-r", "0xC800", "-c", "2"],
                    "00 01 00 00 00 06 01 03 C8 00 00 02")]:
    rc, out, err = run("modbus", *args, "--dry-run", "--port", "/nonexistent")
    check(f"dry-run {' '.join(args)}", rc == 0 and out.strip() == want, out + err)

rc, _, err = run("modbus", "read", "-a", "0", "--dry-run")
check("a read cannot be broadcast", rc == 2 and "broadcast" in err, err)
rc, _, err = run("modbus", "read", "-c", "126", "--dry-run")
check("more than 125 registers is a usage error", rc == 2 and "125" in err, err)
rc, _, err = run("modbus", "write", "-r", "0", "--as", "u16", "70000", "--dry-run")
check("a value beyond u16 is a usage error", rc == 2 and "70000" in err, err)
rc, _, err = run("modbus", "write", "-t", "coil", "2", "--dry-run")
check("a coil value other than 0/1 is a usage error", rc == 2 and "coil" in err, err)

# decode: the paper's frame; a capture of request, response, exception, bad CRC, garbage.
rc, out, _ = run("decode", "modbus-rtu", "01 06 C8 00 00 25 76 71")
check("decode the paper's start command", rc == 0
      and "request  unit 1: write single register 0xC800 = 0x0025" in out and "CRC ok" in out, out)
rc, out, _ = run("decode", "modbus-rtu", "--json", "01 06 C8 00 00 25 76 71",
                 "01 06 C8 00 00 25 76 71", "01 03 C8 02 00 02 5B AB", "01 03 04 00 13 01 36 8A 70",
                 "01 83 02 C0 F1")
j = json_lines(out)
check("decode RTU requests and responses", rc == 0 and len(j) == 5
      and [f["direction"] for f in j] == ["request", "response", "request", "response", "response"]
      and j[0]["address"] == 0xC800 and j[0]["value"] == 0x25
      and j[3]["registers"] == [0x13, 0x136] and j[4]["exception"] == 2
      and "illegal data address" in j[4]["exception_text"], out)
rc, out, _ = run("decode", "modbus-rtu", "55", "01 06 C8 00 00 25 76 70")
check("decode garbage and a bad CRC", rc == 1 and "not a Modbus RTU frame" in out
      and "CRC bad: 0x7076, the bytes give 0x7176" in out, out)
rc, out, _ = run("decode", "modbus-tcp", "--json", "00 07 00 00 00 06 01 03 C8 00 00 02",
                 "00 07 00 00 00 07 01 03 04 00 25 03 E8")
j = json_lines(out)
check("decode TCP request and response", rc == 0 and len(j) == 2
      and j[0]["direction"] == "request" and j[0]["transaction"] == 7 and j[0]["quantity"] == 2
      and j[1]["direction"] == "response" and j[1]["registers"] == [0x25, 1000], out)

# Units 1 and 2 on one pty; unit 1's drive over TCP too.
tcp_port = free_port()
sim = Sim(ferrule_sim, "modbus", "vfds", "--unit", "1", "--unit", "2", "--tcp", str(tcp_port))
second = sim.proc.stdout.readline().strip()
check("ferrule-sim prints the TCP address", second == f"127.0.0.1:{tcp_port}", second)
port = ["--port", sim.link]

rc, out, _ = run("modbus", "read", "-r", "0xC900", "-c", "4", *port)
check("read the parameters", rc == 0 and out.splitlines() == [
    "[51456]: 5000", "[51457]: 50", "[51458]: 50", "[51459]: 0"], out)
rc, out, _ = run("modbus", "write", "-r", "0xC901", "0", "0", "--json", *port)
j = json_lines(out)
check("FC16 write the ramps", rc == 0 and j[0]["function"] == 16 and j[0]["acknowledged"], out)
rc, out, _ = run("modbus", "write", "-r", "0xC801", "2500", *port)
rc2, out2, err2 = run("modbus", "write", "-r", "0xC800", "0x0025", "--trace", *port)
check("start with the paper's frame, traced", rc == 0 and rc2 == 0 and ": ok" in out2
      and "-> 01 06 C8 00 00 25 76 71" in err2 and "<- 01 06 C8 00 00 25 76 71" in err2, err2)
rc, out, _ = run("modbus", "read", "-r", "0xC802", "-c", "2", "--json", *port)
j = json_lines(out)
check("running at the setpoint (no ramp)", rc == 0 and j[0]["values"] == [0x13, 2500], out)
rc, out, _ = run("modbus", "read", "-r", "0xC803", "--as", "hex", *port)
check("--as hex", rc == 0 and out.strip() == "[51203]: 0x09C4", out)
rc, out, _ = run("modbus", "read", "-r", "0xC802", "-c", "1", "--as", "u32", *port)
check("--as u32 over two registers", rc == 0 and out.strip() == f"[51202]: {0x13 << 16 | 2500}",
      out)
rc, out, _ = run("modbus", "read", "-r", "0xC802", "--as", "u32", "--word-order", "cdab", *port)
check("--word-order cdab", rc == 0 and out.strip() == f"[51202]: {2500 << 16 | 0x13}", out)
rc, out, _ = run("modbus", "read", "-t", "coil", "-c", "6", "--json", *port)
check("FC1 coils are the control word's bits", rc == 0
      and json_lines(out)[0]["values"] == [1, 0, 1, 0, 0, 1], out)
rc, out, _ = run("modbus", "read", "-t", "discrete", "-c", "5", *port)
check("FC2 discrete inputs are the status word's bits", rc == 0
      and out.splitlines() == ["[0]: 1", "[1]: 1", "[2]: 0", "[3]: 0", "[4]: 1"], out)
rc, out, _ = run("modbus", "write", "-t", "coil", "-r", "0", "0", *port)
rc2, out2, _ = run("modbus", "read", "-r", "0xC800", "--as", "hex", *port)
check("FC5 clears the run bit", rc == 0 and out2.strip() == "[51200]: 0x0024", out + out2)
rc, out, _ = run("modbus", "write", "-t", "coil", "-r", "0", "1", "0", "1", *port)
rc2, out2, _ = run("modbus", "read", "-r", "0xC800", "--as", "hex", *port)
check("FC15 writes three bits", rc == 0 and out2.strip() == "[51200]: 0x0025", out + out2)

rc, out, err = run("modbus", "read", "-r", "0", *port)
check("an unmapped register is exception 02", rc == 1
      and "exception 02: illegal data address" in err, err)
rc, out, _ = run("modbus", "write", "-r", "0xC900", "5", "--json", *port)
j = json_lines(out)
check("a value out of range is exception 03", rc == 1 and j[0]["ok"] is False
      and j[0]["exception"] == 3 and j[0]["error"].startswith("exception 03"), out)
rc, out, err = run("modbus", "read", "-a", "9", "-r", "0xC800", "--timeout", "100",
                   "--retries", "1", *port)
check("no unit 9 is a timeout", rc == 3 and "no reply" in err, err)
rc, out, _ = run("modbus", "write", "-a", "0", "-r", "0xC801", "1200", *port)
rc2, out2, _ = run("modbus", "read", "-a", "2", "-r", "0xC801", *port)
check("broadcast: no reply by design, executed by unit 2", rc == 0
      and "no reply by design" in out and out2.strip() == "[51201]: 1200", out + out2)
rc, out, _ = run("modbus", "diag", "--data", "0xBEEF", *port)
check("FC8 echo", rc == 0 and "echoed 0xBEEF" in out, out)
rc, out, _ = run("modbus", "diag", "counters", "--json", *port)
j = json_lines(out)
check("FC8 counters", rc == 0 and j[0]["counters"]["bus message count"] > 0, out)
rc, out, _ = run("modbus", "id", "-a", "2", "--json", *port)
j = json_lines(out)
check("FC43/14 device identification", rc == 0 and j[0]["objects"] == {
    "VendorName": "ferrule", "ProductCode": "sim-vfd", "MajorMinorRevision": "1.0"}, out)
rc, out, _ = run("modbus", "read", "-r", "0xC800", "--gap", "0", *port)
check("--gap 0", rc == 0 and out.strip() == "[51200]: 37", out)

# TCP: the same drive as unit 1 on the pty.
host = ["--host", f"127.0.0.1:{tcp_port}"]
rc, out, _ = run("modbus", "read", "-r", "0xC800", "-c", "2", "--json", *host)
check("TCP read", rc == 0 and json_lines(out)[0]["values"] == [0x25, 1200], out)
rc, out, err = run("modbus", "write", "-r", "0xC801", "1500", "--trace", *host)
rc2, out2, _ = run("modbus", "read", "-r", "0xC801", *port)
check("TCP write, read back over RTU", rc == 0 and "-> 00 01 00 00 00 06 01 06 C8 01 05 DC" in err
      and out2.strip() == "[51201]: 1500", err + out2)
rc, out, err = run("modbus", "read", "-r", "0", *host)
check("TCP exception 02", rc == 1 and "exception 02" in err, err)
rc, out, err = run("modbus", "read", "--host", f"127.0.0.1:{free_port()}")
check("TCP connection refused", rc == 3 and "connection refused" in err, err)

# mbpoll (libmodbus) reads ferrule-sim's TCP server; its -r is 1-based.
p = subprocess.run(["mbpoll", "-m", "tcp", "-p", str(tcp_port), "-a", "1", "-r", "51202",
                    "-c", "1", "-1", "127.0.0.1"], capture_output=True, text=True, timeout=30)
check("mbpoll reads 0xC801 as reference 51202", p.returncode == 0
      and "[51202]: \t1500" in p.stdout, p.stdout + p.stderr)

stats = sim.stop()
check("ferrule-sim reports RTU and TCP traffic", "replies" in stats and "TCP:" in stats, stats)

tcp_only_port = free_port()
proc = subprocess.Popen([ferrule_sim, "modbus", "--tcp", str(tcp_only_port), "--tcp-only"],
                        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
first = proc.stdout.readline().strip()
rc, out, _ = run("modbus", "id", "--host", f"127.0.0.1:{tcp_only_port}")
proc.terminate()
proc.wait(timeout=10)
check("--tcp-only serves TCP without a pty", first == f"127.0.0.1:{tcp_only_port}" and rc == 0
      and "sim-vfd" in out, first + out)

sys.exit(summary())
