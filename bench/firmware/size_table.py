#!/usr/bin/env python3
"""One markdown table of the firmware images side by side: whole-image flash (text + data),
RAM (data + bss) and the stack's high-water mark after a few seconds in QEMU against a peer.

  bench/firmware/size_table.py <firmware build dir> [--bench <bench/firmware build dir>]
      [--sim ferrule-sim] [--ferrule ferrule] [--seconds 10] [--check]

Sizes come from arm-none-eabi-size. The stack is read from the guest's RAM at the end of the
run: QEMU's monitor saves the RAM, and the mark is how far below _estack start-up's paint
(board::stack_paint, from _ebss up) has been overwritten, the count board::stack_high_water()
makes; the last `stack=` the image reported on its console is printed beside it. Each image
runs against the peer its job needs (a ferrule-sim device for a master or client, the ferrule
CLI polling a server); without --sim / --ferrule the stack columns are left out. --check also
requires the console to show the peer's answers where PEERS names a pattern."""
import argparse
import os
import re
import select
import socket
import struct
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "..", "tests", "firmware"))
from qemu import Sim  # noqa: E402

PAINT = 0xC0FFEE55
RAM = (0x20000000, 128 * 1024)

# image: (USART1 peer, USART2 peer, console regex that shows the peer answered).
# A peer is ("sim", protocol, args...) or ("cli", unit) for a server polled by the CLI.
PEERS = {
    "movilink_master": (None, ("sim", "movilink"), r"speed=7500"),
    "dimetix_sensor": (None, ("sim", "dimetix"), None),
    "lecom_master": (None, ("sim", "lecom"), None),
    "modbus_client": (None, ("sim", "modbus", "-a", "1", "-a", "2", "-a", "3"), None),
    "modbus_client_functions": (None, ("sim", "modbus"), None),
    "modbus_server": (None, ("cli", 17), None),
    "modbus_client_server": (("cli", 17), ("sim", "modbus"), None),
    "profibus_gateway": (None, ("sim", "modbus"), None),
    "nmbs_client_fc3_fc6": (None, ("sim", "modbus", "-a", "1", "-a", "2", "-a", "3"),
                            r"error=2 "),
    "nmbs_client_ten_functions": (None, ("sim", "modbus"), r"vendor_length=7 "),
    "nmbs_server_ten_functions": (None, ("cli", 17), r"served=\d+ hr0=4321 "),
}


def sizes(elf):
    out = subprocess.run(["arm-none-eabi-size", elf], capture_output=True, text=True,
                         check=True).stdout.splitlines()[1].split()
    text, data, bss = (int(x) for x in out[:3])
    return text + data, data + bss


def symbol(elf, name):
    for line in subprocess.run(["arm-none-eabi-nm", elf], capture_output=True, text=True,
                               check=True).stdout.splitlines():
        parts = line.split()
        if len(parts) == 3 and parts[2] == name:
            return int(parts[0], 16)
    raise KeyError(name)


def high_water(elf, ram_file):
    with open(ram_file, "rb") as f:
        ram = f.read()
    ebss, estack = symbol(elf, "_ebss"), symbol(elf, "_estack")
    p = ebss
    while p < estack and struct.unpack_from("<I", ram, p - RAM[0])[0] == PAINT:
        p += 4
    return estack - p


def monitor(sock_path, command, deadline):
    """One HMP command over the monitor socket; waits for the prompt after it."""
    s = socket.socket(socket.AF_UNIX)
    s.connect(sock_path)
    s.settimeout(max(0.1, deadline - time.monotonic()))
    buf = b""
    while b"(qemu)" not in buf:
        buf += s.recv(4096)
    s.sendall(command.encode() + b"\n")
    buf = b""
    while buf.count(b"(qemu)") < 1:
        buf += s.recv(4096)
    s.close()


class Peer:
    def __init__(self, spec, tools):
        self.spec, self.tools, self.proc, self.sim = spec, tools, None, None
        if spec and spec[0] == "sim":
            self.sim = Sim(tools.sim, spec[1], "line", *spec[2:])

    def qemu_args(self, name):
        if self.spec is None:
            return ["-serial", "null"]
        if self.sim:
            return ["-chardev", f"serial,id={name},path={self.sim.link}", "-serial",
                    f"chardev:{name}"]
        return ["-chardev", f"pty,id={name}", "-serial", f"chardev:{name}"]

    def poll(self, pty):
        """The CLI's round against a server: write, read back, identify; again until stopped."""
        unit = str(self.spec[1])
        base = [self.tools.ferrule, "modbus"]
        common = ["--port", pty, "--unit", unit, "--timeout", "300"]
        script = " ; ".join(" ".join(c) for c in (
            base + ["write"] + common + ["--start", "0", "4321"],
            base + ["read"] + common + ["--count", "8"],
            base + ["read"] + common + ["--type", "coil", "--count", "16"],
            base + ["write"] + common + ["--type", "coil", "--start", "3", "1", "0", "1"],
            base + ["id"] + common))
        self.proc = subprocess.Popen(["sh", "-c", f"while :; do {script}; done"],
                                     stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                                     start_new_session=True)

    def stop(self):
        if self.proc:
            os.killpg(self.proc.pid, 15)
            self.proc.wait(timeout=10)
        if self.sim:
            self.sim.stop()


def run(elf, name, tools, seconds):
    """Boots `elf` against its peers; returns (stack high-water mark, console lines)."""
    u1, u2, _ = PEERS.get(name, (None, None, None))
    tmp = tempfile.mkdtemp(prefix="ferrule-size-")
    sock, ram = os.path.join(tmp, "monitor"), os.path.join(tmp, "ram.bin")
    peers = [Peer(u1, tools), Peer(u2, tools)]
    args = [tools.qemu, "-M", "netduinoplus2", "-nodefaults", "-display", "none",
            "-monitor", f"unix:{sock},server,nowait"]
    args += peers[0].qemu_args("usart1") + peers[1].qemu_args("usart2")
    args += ["-serial", f"file:{os.path.join(tmp, 'console')}", "-kernel", elf]
    # QEMU names the ptys it makes on stdout ("char device redirected to …").
    qemu = subprocess.Popen(args, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                            stderr=subprocess.DEVNULL, text=True)
    try:
        deadline = time.monotonic() + 20
        err = ""
        for peer, label in zip(peers, ("usart1", "usart2")):
            if peer.spec and peer.spec[0] == "cli":
                while f"(label {label})" not in err and time.monotonic() < deadline:
                    ready, _, _ = select.select([qemu.stdout], [], [], 1.0)
                    if ready:
                        err += qemu.stdout.readline()
                m = re.search(rf"redirected to (\S+) \(label {label}\)", err)
                if not m:
                    raise RuntimeError(f"{name}: QEMU made no pty for {label}: {err!r}")
                peer.poll(m.group(1))
        end = time.monotonic() + seconds
        while time.monotonic() < end and qemu.poll() is None:
            time.sleep(0.2)  # the run's length is the measurement's, not a wait for an event
        monitor(sock, f"pmemsave {RAM[0]:#x} {RAM[1]:#x} \"{ram}\"", time.monotonic() + 20)
        stack = high_water(elf, ram)
    finally:
        qemu.terminate()
        qemu.wait(timeout=10)
        for p in peers:
            p.stop()
    with open(os.path.join(tmp, "console"), errors="replace") as f:
        return stack, f.read().splitlines()


def images(fw_dir, bench_dir):
    found = []
    ex = os.path.join(fw_dir, "examples", "firmware")
    if os.path.isdir(ex):
        found += sorted((f[:-4], os.path.join(ex, f)) for f in os.listdir(ex)
                        if f.endswith(".elf"))
    if bench_dir:
        found += sorted((f[:-4], os.path.join(bench_dir, f)) for f in os.listdir(bench_dir)
                        if f.startswith("nmbs_") and f.endswith(".elf"))
    return found


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("firmware_dir", help="build directory of the firmware preset")
    p.add_argument("--bench", help="build directory of bench/firmware (nanoMODBUS images)")
    p.add_argument("--sim", help="ferrule-sim, the masters' and clients' peer")
    p.add_argument("--ferrule", help="the ferrule CLI, the servers' peer")
    p.add_argument("--qemu", default=os.environ.get("FERRULE_QEMU", "qemu-system-arm"))
    p.add_argument("--seconds", type=float, default=10.0)
    p.add_argument("--check", action="store_true",
                   help="fail unless each image's console shows its peer's answers")
    tools = p.parse_args()
    measure = tools.sim and tools.ferrule
    rows, failed = [], []
    for name, elf in images(tools.firmware_dir, tools.bench):
        flash, ram = sizes(elf)
        stack = console = "—"
        if measure:
            mark, lines = run(elf, name, tools, tools.seconds)
            stack = str(mark)
            reported = [int(m.group(1)) for l in lines for m in [re.search(r"stack=(\d+)", l)] if m]
            console = str(reported[-1]) if reported else "—"
            expect = PEERS.get(name, (None, None, None))[2]
            if tools.check and expect and not any(re.search(expect, l) for l in lines):
                failed.append(f"{name}: no console line matching {expect!r}: {lines[-3:]}")
        rows.append(f"| {name} | {flash} | {ram} | {stack} | {console} |")
    print("| image | flash (text + data) | RAM (data + bss) | stack high-water (RAM) |"
          " last stack= on the console |")
    print("|---|---|---|---|---|")
    print("\n".join(rows))
    for f in failed:
        print(f"check failed: {f}", file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":
    raise SystemExit(main())
