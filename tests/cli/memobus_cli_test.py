#!/usr/bin/env python3
"""The ferrule CLI against `ferrule-sim memobus` (a simulated MP2310) over TCP and UDP, as
separate processes, and its UDP channels running out; `ferrule decode memobus` on the golden
vectors of protocols/memobus.md §8.

usage: memobus_cli_test.py <ferrule> <ferrule-sim>
Each check prints 'ok <name>' or 'FAIL <name>: why'; the last line is 'N passed, M failed'.
"""
import socket
import subprocess
import sys
import time

from harness import check, json_lines, summary

ferrule, ferrule_sim = sys.argv[1], sys.argv[2]


def run(*args, timeout=30):
    p = subprocess.run([ferrule, *args], capture_output=True, text=True, timeout=timeout)
    return p.returncode, p.stdout, p.stderr


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class MemobusSim:
    """`ferrule-sim memobus --port 0 args…`, up until it prints its address."""

    def __init__(self, *args):
        self.proc = subprocess.Popen([ferrule_sim, "memobus", "--port", "0", *args],
                                     stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        self.address = self.proc.stdout.readline().strip()
        if not self.address.startswith("127.0.0.1:"):
            raise RuntimeError(f"ferrule-sim memobus did not come up: {self.address!r}")

    def stop(self):
        self.proc.terminate()
        self.proc.wait(timeout=10)
        return self.proc.stderr.read()


# Golden commands without opening anything (§8.1 #2: the Yaskawa sample's SFC 09).
for args, want in [(["read", "MW00000", "-c", "10"],
                    "11 00 00 00 00 00 16 00 00 00 00 00 08 00 20 09 10 00 00 00 0A 00"),
                   (["read", "MW00001", "-c", "15", "--cpu", "0"],
                    "11 00 00 00 00 00 16 00 00 00 00 00 08 00 20 09 00 00 01 00 0F 00"),
                   (["read", "MW00107", "-c", "3", "--classic", "--cpu", "0x12"],
                    "11 00 00 00 00 00 15 00 00 00 00 00 07 00 20 03 12 00 6B 00 03"),
                   (["write", "MW00100", "0x1234", "0xABCD", "--cpu", "0x21"],
                    "11 00 00 00 00 00 1A 00 00 00 00 00 0C 00 20 0B 21 00 64 00 02 00 34 12 CD AB"),
                   (["write", "MW00100", "0x1234", "0xABCD", "--classic", "--cpu", "0x21"],
                    "11 00 00 00 00 00 19 00 00 00 00 00 0B 00 20 10 21 00 64 00 02 12 34 AB CD"),
                   (["write", "MW00100", "0x1234", "--classic", "--data-order", "little"],
                    "11 00 00 00 00 00 15 00 00 00 00 00 07 00 20 06 10 00 64 34 12"),
                   (["write", "MB000064", "1", "--cpu", "0x21"],
                    "11 00 00 00 00 00 15 00 00 00 00 00 07 00 20 05 21 00 64 FF 00"),
                   (["read", "IW0000", "--cpu", "0x21"],
                    "11 00 00 00 00 00 16 00 00 00 00 00 08 00 20 0A 21 00 00 00 01 00")]:
    rc, out, err = run("memobus", *args, "--dry-run")
    check(f"dry-run {' '.join(args)}", rc == 0 and out.strip() == want, out + err)

rc, _, err = run("memobus", "read", "XW00100", "--dry-run")
check("a bad register name is a usage error", rc == 2 and "XW00100" in err, err)
for verb, name, last in [("read", "MW65535", 65534), ("read", "IW99999", 65535),
                         ("write", "MB65535A", 65534)]:
    rc, _, err = run("memobus", verb, name, *(["1"] if verb == "write" else []), "--dry-run")
    check(f"{verb} {name}: a name beyond its area", rc == 2
          and f"{name}: register number out of range 0..{last}" in err, err)
rc, _, err = run("memobus", "write", "IW0010", "1", "--dry-run")
check("IW cannot be written", rc == 2 and "MW" in err, err)
rc, _, err = run("memobus", "read", "MW00000", "-c", "126", "--classic", "--dry-run")
check("SFC 03 reads at most 125", rc == 2 and "125" in err, err)
rc, _, err = run("memobus", "write", "MB000000", "2", "--dry-run")
check("a bit is 0 or 1", rc == 2 and "bit" in err, err)
rc, _, err = run("memobus", "read", "MW00000")
check("no --host is a usage error", rc == 2 and "--host" in err, err)

# decode: the golden vectors, an error response, garbage and a bad length.
rc, out, _ = run("decode", "memobus",
                 "11 00 00 00 00 00 16 00 00 00 00 00 08 00 20 09 10 00 00 00 0A 00")
check("decode the Yaskawa sample's SFC 09", rc == 0 and "command" in out
      and "CPU 0x10: dest 1 src 0" in out
      and "SFC 09 read hold registers (extended): MW00000 (address 0), count 10" in out, out)
rc, out, _ = run("decode", "memobus", "--json",
                 "11 0B 00 00 00 00 15 00 00 00 00 00 07 00 20 03 21 00 64 00 02",
                 "19 0B 00 00 00 00 15 00 00 00 00 00 07 00 20 03 12 12 34 AB CD",
                 "11 07 00 00 00 00 1A 00 00 00 00 00 0C 00 20 0B 21 00 64 00 02 00 34 12 CD AB",
                 "19 07 00 00 00 00 16 00 00 00 00 00 08 00 20 0B 12 00 64 00 02 00",
                 "11 00 00 00 00 00 15 00 00 00 00 00 07 00 20 01 21 00 64 00 0A",
                 "19 00 00 00 00 00 13 00 00 00 00 00 05 00 20 01 12 05 02")
j = json_lines(out)
check("decode commands and responses", rc == 0 and len(j) == 6
      and [f["type"] for f in j] == ["command", "response"] * 3
      and j[1]["registers"] == [0x1234, 0xABCD] and j[1]["register"] == "MW00100"
      and j[2]["registers"] == [0x1234, 0xABCD] and j[3]["count"] == 2
      and j[5]["bits"] == [1, 0, 1, 0, 0, 0, 0, 0, 0, 1] and j[5]["cpu_destination"] == 1
      and j[5]["cpu_source"] == 2, out)
rc, out, _ = run("decode", "memobus", "19 00 00 00 00 00 12 00 00 00 00 00 04 00 20 89 01 02")
check("decode an error response", rc == 0
      and "error 02: controller: reference address error" in out, out)
rc, out, _ = run("decode", "memobus", "55 AA",
                 "11 00 00 00 00 00 FF FF 00 00 00 00",
                 "11 01 00 00 00 00 16 00 00 00 00 00 08 00 20 09 10 00 00 00 0A 00",
                 "11 02 00 00 00 00 16 00")
check("decode reports garbage, a bad length and a cut message", rc == 1
      and "no 218 header: type 0x55" in out and "total length 65535 out of range" in out
      and "serial 1" in out and "incomplete" in out, out)
rc, out, _ = run("decode", "memobus", "12 00 00 00 00 00 10 00 00 00 00 00 34 12 CD AB")
check("decode a general-purpose message", rc == 0 and "general-purpose" in out
      and "0x1234 0xABCD" in out, out)

# The simulated controller over TCP and UDP.
sim = MemobusSim("--udp")
host = ["--host", sim.address]
rc, out, _ = run("memobus", "write", "MW00100", "1", "2", "0x1234", *host)
rc2, out2, _ = run("memobus", "read", "MW00100", "-c", "3", *host)
check("TCP write and read back MW", rc == 0 and rc2 == 0 and ": ok" in out
      and out2.splitlines() == ["MW00100:     1  0x0001", "MW00101:     2  0x0002",
                                "MW00102:  4660  0x1234"], out + out2)
rc, out, err = run("memobus", "write", "MB002000", "1", "0", "1", "1", "--trace", *host)
rc2, out2, _ = run("memobus", "read", "MB002000", "-c", "4", "--json", *host)
check("TCP write and read back MB bits", rc == 0 and rc2 == 0
      and "20 0F 10 0C 80 00 04 0D" in err
      and json_lines(out2)[0]["values"] == [1, 0, 1, 1], err + out2)
rc, out, _ = run("memobus", "read", "MW00200", "--json", *host)
check("the bits are MW00200's", rc == 0 and json_lines(out)[0]["values"] == [0b1101], out)
rc, out, _ = run("memobus", "write", "MW00300", "7", "8", "--udp", *host)
rc2, out2, _ = run("memobus", "read", "MW00300", "-c", "2", "--udp", "--json", *host)
check("UDP write and read back MW", rc == 0 and rc2 == 0
      and json_lines(out2)[0]["values"] == [7, 8], out + out2)
rc, out, _ = run("memobus", "write", "MB003000", "0", "1", "--udp", *host)
rc2, out2, _ = run("memobus", "read", "MB003000", "-c", "2", "--udp", *host)
check("UDP write and read back MB bits", rc == 0 and rc2 == 0
      and out2.splitlines() == ["MB003000: 0", "MB003001: 1"], out + out2)
rc, out, _ = run("memobus", "write", "MW00400", "0x0102", "--classic", *host)
rc2, out2, _ = run("memobus", "read", "MW00400", "--classic", "--json", *host)
check("SFC 06 and 03", rc == 0 and json_lines(out2)[0]["values"] == [0x0102], out + out2)
rc, out, _ = run("memobus", "read", "IW0000", "--json", *host)
time.sleep(0.3)
rc2, out2, _ = run("memobus", "read", "IW0000", "--json", *host)
check("IW00000 counts up every 100 ms", rc == 0 and rc2 == 0
      and json_lines(out2)[0]["values"][0] >= json_lines(out)[0]["values"][0] + 2, out + out2)
rc, out, err = run("memobus", "read", "IW5000", "-c", "2", *host)
check("a read beyond the image is the controller's address error", rc == 1
      and "controller: reference address error" in err, err)
rc, out, _ = run("memobus", "read", "IW5000", "--udp", "--json", *host)
j = json_lines(out)
check("the address error over UDP, as JSON", rc == 1 and j[0]["ok"] is False
      and j[0]["category"] == "memobus" and j[0]["code"] == 2, out)
rc, out, err = run("memobus", "read", "MW00000", "--host", f"127.0.0.1:{free_port()}")
check("TCP connection refused", rc == 3 and "refused" in err, err)
rc, out, err = run("memobus", "read", "MW00000", "--udp", "--timeout", "200",
                   "--host", f"127.0.0.1:{free_port()}")
check("no controller on UDP", rc == 3, err)
stats = sim.stop()
check("ferrule-sim reports per-channel statistics", "channel 1:" in stats
      and "channel 4:" in stats and "address" in stats, stats)

# Offsets and a write range, on every channel.
sim = MemobusSim("--mw-offset", "1000", "--write-range", "1000-1999")
host = ["--host", sim.address]
rc, out, _ = run("memobus", "write", "MW00005", "42", *host)
rc2, out2, err2 = run("memobus", "write", "MW01000", "1", *host)
check("the write range refuses MW02000", rc == 0 and rc2 == 1
      and "number of data items error" in err2, out + err2)
rc, out, err = run("memobus", "read", "MW65000", *host)
check("the offset pushes MW65000 beyond the image", rc == 1 and "address error" in err, err)
sim.stop()

# UDP channels (4, a 218IFA's). The Yaskawa sample's SFC 09 command (§8.1 #2).
command = bytes.fromhex("11 00 00 00 00 00 16 00 00 00 00 00 08 00 20 09 10 00 00 00 0A 00")


def udp_from(address):
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.bind((address, 0))
    s.settimeout(5)
    return s


sim = MemobusSim("--udp")
host = ["--host", sim.address]
sim_port = int(sim.address.split(":")[1])
# One byte from each of four ports on four addresses: as many as there are channels.
for i, address in enumerate(["127.0.0.2", "127.0.0.3", "127.0.0.4", "127.0.0.5"]):
    with udp_from(address) as s:
        s.sendto(bytes([0x11 + i]), ("127.0.0.1", sim_port))
# Each run of the CLI sends from a new ephemeral port of 127.0.0.1.
runs = [run("memobus", "read", "MW00000", "--udp", *host) for _ in range(6)]
check("garbage takes no channel, and six UDP runs in a row are all answered",
      all(rc == 0 for rc, _, _ in runs), "\n".join(err for _, _, err in runs))
rc, out, err = run("memobus", "read", "MW00000", *host)
check("a TCP master after the six UDP runs is answered", rc == 0, err)
stats = sim.stop()
check("the six runs were one UDP master; the garbage is counted", "1 UDP masters (" in stats
      and "0 commands refused" in stats and "4 datagrams of no master ignored" in stats
      and "1 TCP connections (0 refused" in stats, stats)

# One channel, held by a master on 127.0.0.2; the CLI on 127.0.0.1 finds none free.
sim = MemobusSim("--udp", "--channels", "1")
host = ["--host", sim.address]
sim_port = int(sim.address.split(":")[1])
with udp_from("127.0.0.2") as holder:
    holder.sendto(command, ("127.0.0.1", sim_port))
    reply, _ = holder.recvfrom(8192)
    check("the first UDP master holds the only channel", reply[:2] == b"\x19\x00", reply.hex())
    rc, out, err = run("memobus", "read", "MW00000", "--udp", "--timeout", "200",
                       "--retries", "2", *host)
    check("the UDP timeout names a controller with no free channel as one possibility",
          rc == 3 and "no reply before the response timeout" in err
          and "may be unreachable or have no free channel" in err, err)
stats = sim.stop()
check("ferrule-sim logs one line for the run's three refused commands and counts each",
      stats.count("no free channel for UDP master 127.0.0.1:") == 1
      and "3 commands refused for want of a channel" in stats, stats)

sys.exit(summary())
