#!/usr/bin/env python3
"""Hostile inputs to the ferrule CLI and to ferrule-sim: bad hex tokens; `ferrule-sim --link`
on a path that holds something else, on another simulator's link and on a stale one.

usage: inputs_test.py <ferrule> <ferrule-sim>
Each check prints 'ok <name>' or 'FAIL <name>: why'; the last line is 'N passed, M failed'.
"""
import os
import shutil
import subprocess
import sys
import tempfile

from harness import Sim, check, summary

ferrule, ferrule_sim = sys.argv[1], sys.argv[2]
tmp = tempfile.mkdtemp(prefix="ferrule-inputs-")


def run(*args, timeout=60):
    p = subprocess.run([ferrule, *args], capture_output=True, text=True, timeout=timeout)
    return p.returncode, p.stdout, p.stderr


def path(name):
    return os.path.join(tmp, name)


def write(name, data):
    with open(path(name), "wb") as f:
        f.write(data)
    return path(name)


# --- hex tokens ------------------------------------------------------------------------------

rc, _, err = run("decode", "movilink", "02", "0G", "05")
check("a bad hex token is named with its place",
      rc == 2 and 'hex token 2 "0G"' in err and "'G'" in err, err)
rc, _, err = run("decode", "movilink", "02 01:zz")
check("tokens are counted inside an argument", rc == 2 and 'hex token 3 "zz"' in err, err)
rc, _, err = run("decode", "movilink", "02", "1", "05")
check("an odd number of digits names the token",
      rc == 2 and 'hex token 2 "1"' in err and "odd" in err, err)
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
