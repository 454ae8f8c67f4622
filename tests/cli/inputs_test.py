#!/usr/bin/env python3
"""Hostile inputs to the ferrule CLI and to ferrule-sim: `decode --file` on a directory,
/dev/zero, an empty file, a pipe and captures longer than one read; bad hex tokens; --host
ports out of range; `ferrule-sim --link` on a path that holds something else, on another
simulator's link and on a stale one.

usage: inputs_test.py <ferrule> <ferrule-sim>
Each check prints 'ok <name>' or 'FAIL <name>: why'; the last line is 'N passed, M failed'.
"""
import os
import re
import resource
import select
import shutil
import subprocess
import sys
import tempfile

from harness import Sim, check, summary

ferrule, ferrule_sim = sys.argv[1], sys.argv[2]
tmp = tempfile.mkdtemp(prefix="ferrule-inputs-")

# A capture decoder that keeps everything it reads would use gigabytes on /dev/zero: here it
# fails at 1 GiB instead of taking the machine's memory.
MEMORY_LIMIT = 1 << 30


def limit_memory():
    resource.setrlimit(resource.RLIMIT_AS, (MEMORY_LIMIT, MEMORY_LIMIT))


def run(*args, timeout=60):
    p = subprocess.run([ferrule, *args], capture_output=True, text=True, timeout=timeout,
                       preexec_fn=limit_memory)
    return p.returncode, p.stdout, p.stderr


def path(name):
    return os.path.join(tmp, name)


def write(name, data):
    with open(path(name), "wb") as f:
        f.write(data)
    return path(name)


# --- decode --file ---------------------------------------------------------------------------

rc, out, err = run("decode", "movilink", "--file", tmp)
check("decode --file on a directory is a usage error naming it",
      rc == 2 and tmp in err and "Is a directory" in err and out == "", f"{rc} {out} {err}")

rc, out, err = run("decode", "movilink", "--file", path("missing"))
check("decode --file of a missing file names it", rc == 2 and path("missing") in err, err)

empty = write("empty.bin", b"")
rc, out, err = run("decode", "modbus-rtu", "--file", empty)
check("decode --file of an empty file says so", rc == 2 and "empty" in err and empty in err
      and out == "", f"{rc} {out} {err}")

for protocol in ["movilink", "dimetix", "lecom", "modbus-rtu", "modbus-tcp", "profibus",
                 "memobus"]:
    rc, out, err = run("decode", protocol, "--file", "/dev/zero")
    # (Dimetix shows the first 80 bytes as an overlong line; the run without one follows.)
    check(f"decode {protocol} --file /dev/zero stops after 8192 bytes without a telegram",
          rc == 2 and re.search(f"/dev/zero: no {protocol} telegram in the 8192 bytes from "
                                "offset (0|80); stopped there", err) and "--max-junk" in err
          and out.startswith("@0 "), f"{rc} {err[-300:]}")

# Golden telegrams of each protocol (the docs' and the manuals' examples), repeated into a
# capture of many read pieces with noise in between: --file gives what the same bytes as
# hex give, whatever piece boundary falls inside a telegram.
GOLDEN = {
    "movilink": ["02 01 85 00 06 20 00 0B B8 13", "1D 01 85 02 06 00 00 06 06 9D",
                 "1D 01 86 B1 00 20 7E 08 00 00 10 6D"],
    "dimetix": ["73 30 67 0D 0A", "67 30 67 2B 30 30 30 30 30 32 33 34 2B 30 30 38 33 38 34 2B "
                "32 35 34 0D 0A", "67 30 40 45 32 35 35 0D 0A"],
    "lecom": ["04 30 31 34 36 05", "02 34 36 33 35 2E 34 03 1D",
              "04 33 34 02 31 31 39 35 2E 32 03 13", "15", "02 34 36 04"],
    "modbus-rtu": ["01 03 C8 02 00 02 5B AB", "01 03 04 00 13 09 C4 0C 35",
                   "01 06 C8 00 00 25 76 71", "01 06 C8 00 00 25 76 71", "01 83 02 C0 F1"],
    "modbus-tcp": ["00 07 00 00 00 06 01 03 C8 00 00 02",
                   "00 07 00 00 00 07 01 03 04 00 25 03 E8"],
    "profibus": ["10 08 02 49 53 16", "68 05 05 68 08 02 5D 12 34 AD 16", "E5"],
    "memobus": ["11 00 00 00 00 00 16 00 00 00 00 00 08 00 20 09 10 00 00 00 0A 00"],
}
NOISE = "55"
for protocol, frames in GOLDEN.items():
    tokens = []
    size = 0
    while size < 5 * 4096:
        tokens.append(frames[len(tokens) % len(frames)])
        if len(tokens) % 97 == 0:
            tokens.append(NOISE)
        size += len(bytes.fromhex(tokens[-1]))
    tokens.append(frames[0][:5])  # a telegram cut short at the end
    data = bytes.fromhex(" ".join(tokens))
    capture = write(f"{protocol}.bin", data)
    rc_hex, out_hex, _ = run("decode", protocol, *tokens)
    rc_file, out_file, err = run("decode", protocol, "--file", capture)
    check(f"decode {protocol} --file of {len(data)} bytes = the same bytes as hex",
          rc_file == rc_hex == 1 and out_file == out_hex and out_file.count("\n") > 500,
          f"{rc_hex} {rc_file} {err}")

# Noise longer than --max-junk stops the decode; a larger --max-junk finds the telegram.
noisy = write("noisy.bin", b"\x55" * 9000 + bytes.fromhex("01 06 C8 00 00 25 76 71"))
rc, out, err = run("decode", "modbus-rtu", "--file", noisy)
check("decode --file stops at 8192 bytes of noise", rc == 2
      and "no modbus-rtu telegram in the 8192 bytes from offset 0" in err
      and "@0    not a telegram" in out, f"{rc} {err}")
rc, out, err = run("decode", "modbus-rtu", "--file", noisy, "--max-junk", "16384")
check("decode --file --max-junk 16384 finds the telegram behind 9000 bytes of noise",
      rc == 1 and "@9000 01 06 C8 00 00 25 76 71" in out, f"{rc} {out[-200:]} {err}")
rc, out, err = run("decode", "modbus-rtu", "--file", noisy, "--max-junk", "100")
check("--max-junk below 8192 is refused", rc == 2 and "max-junk" in err, err)

# A pipe: each telegram is printed as soon as it is read, before the writer closes.
p = subprocess.Popen([ferrule, "decode", "movilink", "--file", "/dev/stdin"],
                     stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                     preexec_fn=limit_memory)
p.stdin.write(bytes.fromhex("02 01 85 00 06 20 00 0B B8 13"))
p.stdin.flush()
ready, _, _ = select.select([p.stdout], [], [], 10)
line = os.read(p.stdout.fileno(), 4096).decode() if ready else ""
rest, _ = p.communicate(timeout=10)  # closes the pipe
check("decode --file /dev/stdin prints a telegram while the pipe is open",
      line.startswith("@0    request  ADR 1") and p.returncode == 0, f"{line!r} {rest!r}")

# --- hex tokens ------------------------------------------------------------------------------

rc, _, err = run("decode", "movilink", "02", "0G", "05")
check("a bad hex token is named with its place",
      rc == 2 and 'hex token 2 "0G"' in err and "'G'" in err, err)
rc, _, err = run("decode", "movilink", "02 01:zz")
check("tokens are counted inside an argument", rc == 2 and 'hex token 3 "zz"' in err, err)
rc, _, err = run("decode", "movilink", "02", "1", "05")
check("an odd number of digits names the token",
      rc == 2 and 'hex token 2 "1"' in err and "odd" in err, err)
rc, _, err = run("decode", "movilink", "02", "--file", empty)
check("hex bytes and --file together are a usage error", rc == 2 and "--file" in err, err)

# --- --host ports ----------------------------------------------------------------------------

for host in ["127.0.0.1:99999", "127.0.0.1:0", "127.0.0.1:65536", "127.0.0.1:http",
             "127.0.0.1:", "127.0.0.1:-1", "127.0.0.1:5 02"]:
    port = host.split(":", 1)[1]
    rc, _, err = run("modbus", "read", "-r", "0", "--host", host, "--timeout", "500")
    check(f"modbus --host {host} is a usage error naming the port",
          rc == 2 and f"'{port}'" in err and "1-65535" in err and "connect" not in err, err)
for extra in [[], ["--udp"]]:
    rc, _, err = run("memobus", "read", "MW00100", "--host", "127.0.0.1:70000", *extra)
    check(f"memobus --host 127.0.0.1:70000{''.join(' ' + e for e in extra)} is a usage error",
          rc == 2 and "'70000'" in err and "1-65535" in err, err)

# --dry-run connects nowhere, yet the port is checked while the command line is parsed.
for proto, args in [("modbus", ["read", "-r", "0"]), ("memobus", ["read", "MW00100"])]:
    rc, out, err = run(proto, *args, "--host", "127.0.0.1:99999", "--dry-run")
    check(f"{proto} --dry-run --host 127.0.0.1:99999 is a usage error",
          rc == 2 and "'99999'" in err and "1-65535" in err and not out, out + err)

# --- ferrule-sim --link ----------------------------------------------------------------------


def sim_refuses(link, protocol="modbus"):
    """ferrule-sim --link `link`: its exit code and stderr; None when it came up instead."""
    p = subprocess.Popen([ferrule_sim, protocol, "--link", link], stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True)
    try:
        _, err = p.communicate(timeout=10)
        return p.returncode, err
    except subprocess.TimeoutExpired:
        p.terminate()
        p.communicate(timeout=10)
        return None, "it came up and served"


def link_of(name):
    """Where the symlink `name` points; None when it is gone or no symlink."""
    return os.readlink(name) if os.path.islink(name) else None


def contents(name):
    """What the regular file `name` holds; None when it is gone or no regular file."""
    if os.path.islink(name) or not os.path.isfile(name):
        return None
    with open(name, "rb") as f:
        return f.read()


regular = write("regular", b"x\n")
rc, err = sim_refuses(regular)
check("ferrule-sim --link on a regular file: exit 2, the file unchanged",
      rc == 2 and "regular file" in err and regular in err and contents(regular) == b"x\n",
      f"{rc} {err} {contents(regular)!r}")

subdir = path("subdir")
os.mkdir(subdir)
rc, err = sim_refuses(subdir)
check("ferrule-sim --link on a directory: exit 2", rc == 2 and "directory" in err
      and os.path.isdir(subdir), f"{rc} {err}")

to_file = path("to-file")
os.symlink(path("elsewhere"), to_file)
rc, err = sim_refuses(to_file)
check("ferrule-sim --link on a symlink that is no pty's: exit 2, the link unchanged",
      rc == 2 and link_of(to_file) == path("elsewhere"), f"{rc} {err}")

rc, err = sim_refuses(regular, "profibus-gateway")
check("ferrule-sim profibus-gateway --link on a regular file: exit 2",
      rc == 2 and "regular file" in err and contents(regular) == b"x\n", f"{rc} {err}")

first = Sim(ferrule_sim, "modbus", "vfd")
target = link_of(first.link)
rc, err = sim_refuses(first.link)
check("a second ferrule-sim on the same --link is refused", rc == 2 and "in use" in err
      and link_of(first.link) == target, f"{rc} {err}")
p = subprocess.run([ferrule, "modbus", "read", "-r", "0xC802", "--port", first.link, "--gap",
                    "0", "--json"], capture_output=True, text=True, timeout=30)
check("the first ferrule-sim still serves on its link", p.returncode == 0
      and '"ok":true' in p.stdout, p.stdout + p.stderr)
first.stop()
check("the link goes when its ferrule-sim ends", not os.path.lexists(first.link), first.link)

# A stale link: to a pty that is gone, as a simulator killed with SIGKILL leaves it.
gone = next(f"/dev/pts/{n}" for n in range(999999, 0, -1)
            if not os.path.exists(f"/dev/pts/{n}"))
stale_dir = tempfile.mkdtemp(prefix="ferrule-stale-")
stale = os.path.join(stale_dir, "vfd")
os.symlink(gone, stale)
p = subprocess.Popen([ferrule_sim, "modbus", "--link", stale], stdout=subprocess.PIPE,
                     stderr=subprocess.PIPE, text=True)
came_up = p.stdout.readline().strip() == stale
now = link_of(stale) or ""
p.terminate()
p.communicate(timeout=10)
check("a stale link to a gone pty is taken over", came_up and now.startswith("/dev/pts/")
      and now != gone and not os.path.lexists(stale), f"{came_up} {now}")

# At exit only the simulator's own link goes: a file that took its place stays.
sim = Sim(ferrule_sim, "modbus", "vfd")
os.remove(sim.link)
with open(sim.link, "w") as f:
    f.write("mine\n")
sim.stop()
check("ferrule-sim leaves what took its link's place", contents(sim.link) == b"mine\n",
      sim.link)

for d in [tmp, stale_dir, first.dir, sim.dir]:
    shutil.rmtree(d, ignore_errors=True)
sys.exit(summary())
