"""What the CLI end-to-end tests share: checks that count, JSON lines, ferrule-sim as a process."""
import json
import os
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
import prereq  # noqa: E402

passed = 0
failed = 0


def check(name, cond, why=""):
    global passed, failed
    if cond:
        passed += 1
        print(f"ok {name}")
    else:
        failed += 1
        print(f"FAIL {name}: {why}")


def require(programs=(), modules=()):
    """Fails at once, one line per missing program or module, naming its Debian package."""
    lines = prereq.missing(programs, modules)
    for line in lines:
        check("prerequisite", False, line)
    if lines:
        sys.exit(summary())


def summary():
    """Prints the closing 'N passed, M failed' line; returns the exit status."""
    print(f"{passed} passed, {failed} failed")
    return 1 if failed else 0


def json_lines(out):
    return [json.loads(line) for line in out.splitlines() if line.strip()]


class Sim:
    """`ferrule-sim <protocol> --link <tmp>/<name> args…`, up until its link is there."""

    def __init__(self, ferrule_sim, protocol, name, *args):
        self.dir = tempfile.mkdtemp(prefix="ferrule-sim-")
        self.link = os.path.join(self.dir, name)
        self.proc = subprocess.Popen([ferrule_sim, protocol, "--link", self.link, *args],
                                     stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        first = self.proc.stdout.readline().strip()
        if first != self.link or not os.path.islink(self.link):
            raise RuntimeError(f"ferrule-sim did not come up: {first!r}")

    def stop(self):
        """Ends the simulator; returns what it printed on stderr."""
        self.proc.terminate()
        self.proc.wait(timeout=10)
        return self.proc.stderr.read()
