"""What the firmware tests share: an example's ELF booted in QEMU's netduinoplus2 (STM32F405),
its USARTs on pseudo-terminals, its console (USART3) read line by line with deadlines."""
import os
import re
import select
import subprocess
import sys
import time
import tty

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "cli"))
from harness import Sim, check, require, summary  # noqa: E402,F401


class Firmware:
    """qemu-system-arm -M netduinoplus2 running `elf`.

    usart1 / usart2: None (not connected), a path (a pty the test already has, e.g. a
    ferrule-sim link) or "pty" (QEMU makes one; its path is then in .pty["usart1"] etc.).
    USART3 is the console, on QEMU's stdout. QEMU runs the guest on the host's real-time clock,
    so SysTick and the peers' timeouts agree."""

    def __init__(self, elf, usart1=None, usart2=None,
                 qemu=os.environ.get("FERRULE_QEMU", "qemu-system-arm")):
        self.elf = elf
        self.pty = {}
        args = [qemu, "-M", "netduinoplus2", "-nodefaults", "-display", "none",
                "-monitor", "none"]
        for name, where in (("usart1", usart1), ("usart2", usart2)):
            if where is None:
                args += ["-serial", "null"]
            elif where == "pty":
                args += ["-chardev", f"pty,id={name}", "-serial", f"chardev:{name}"]
            else:
                args += ["-chardev", f"serial,id={name},path={where}", "-serial",
                         f"chardev:{name}"]
        args += ["-serial", "stdio", "-kernel", elf]
        self.proc = subprocess.Popen(args, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                                     stderr=subprocess.PIPE)
        self.lines = []
        self._buf = b""
        self._err = b""
        wanted = [n for n, w in (("usart1", usart1), ("usart2", usart2)) if w == "pty"]
        deadline = time.monotonic() + 10
        while len(self.pty) < len(wanted) and time.monotonic() < deadline:
            self._pump(deadline)
            # QEMU 7 prints this on stdout (qemu_printf), older ones on stderr.
            said = self._err.decode(errors="replace") + "\n".join(self.lines)
            for m in re.finditer(r"char device redirected to (\S+) \(label (\w+)\)", said):
                self.pty[m.group(2)] = m.group(1)
        if len(self.pty) < len(wanted):
            raise RuntimeError(f"QEMU made no pty for {wanted}: {self._err.decode()!r}")
        # QEMU reads a pty only while its other end is open, and looks for that once a second
        # (chardev/char-pty.c): what a peer sends before QEMU has looked is lost. Held open
        # here, raw (no echo of the guest's bytes back to it), the ptys stay connected for the
        # programs that come and go on them; only a test's first request may need a resend.
        self._held = [os.open(p, os.O_RDWR | os.O_NOCTTY) for p in self.pty.values()]
        for fd in self._held:
            tty.setraw(fd)

    def _pump(self, deadline):
        """Reads what QEMU wrote, waiting at most until `deadline`; False once it exited."""
        fds = [f for f in (self.proc.stdout, self.proc.stderr) if f]
        ready, _, _ = select.select(fds, [], [], max(0.0, deadline - time.monotonic()))
        for f in ready:
            data = os.read(f.fileno(), 4096)
            if not data:
                if f is self.proc.stdout:
                    self.proc.stdout = None
                else:
                    self.proc.stderr = None
                continue
            if f is self.proc.stderr:
                self._err += data
                continue
            self._buf += data
            while b"\n" in self._buf:
                line, self._buf = self._buf.split(b"\n", 1)
                self.lines.append(line.decode(errors="replace").rstrip("\r"))
        return self.proc.stdout is not None

    def wait_for(self, pattern, timeout=20.0, start=0):
        """The first console line from index `start` on matching `pattern` (a regex), as a
        match object; None when none came before the deadline or QEMU ended."""
        rx = re.compile(pattern)
        deadline = time.monotonic() + timeout
        seen = start
        while True:
            for i in range(seen, len(self.lines)):
                m = rx.search(self.lines[i])
                if m:
                    self.matched_at = i
                    return m
            seen = len(self.lines)
            if time.monotonic() >= deadline or not self._pump(deadline):
                return None

    def stop(self):
        """Ends QEMU; returns the whole console output."""
        self.proc.terminate()
        self.proc.wait(timeout=10)
        for fd in self._held:
            os.close(fd)
        return "\n".join(self.lines)


def args(*names):
    """Command-line arguments: --elf <elf> and --<name> <path> for each of `names`."""
    import argparse
    p = argparse.ArgumentParser()
    p.add_argument("--elf", required=True)
    for n in names:
        p.add_argument(f"--{n}", required=True)
    return p.parse_args()
