"""The programs and Python modules that ferrule's tests start or import from outside the
build, each with the Debian package that brings it (tools/install-deps.sh installs them all).

A test calls missing() before it starts anything, prints each line it returns and fails at
once: a user then reads which package to install instead of a peer's traceback or a count of
checks that never ran.
"""
import shutil
import subprocess

# Programs the tests run, by the name they are run with.
PROGRAMS = {
    "socat": "socat",
    "mbpoll": "mbpoll",
}

# Modules the pymodbus peer imports under Debian's interpreter. python3-pymodbus only
# recommends the serial ones, yet pymodbus.client and pymodbus.server import them.
MODULES = {
    "pymodbus": "python3-pymodbus",
    "serial": "python3-serial",
    "serial_asyncio": "python3-serial-asyncio",
}

SYSTEM_PYTHON = "/usr/bin/python3"  # Debian's python3-* packages install for this one


def _program_missing(name):
    return shutil.which(name) is None


def _module_missing(python, name):
    try:
        return subprocess.run([python, "-c", f"import {name}"], capture_output=True,
                              timeout=60).returncode != 0
    except OSError:
        return True


def missing(programs=(), modules=(), python=SYSTEM_PYTHON):
    """One line per program or module that is not there, naming the package to install."""
    lines = []
    for p in programs:
        if _program_missing(p):
            lines.append(f"missing program '{p}': apt-get install {PROGRAMS[p]}")
    for m in modules:
        if _module_missing(python, m):
            lines.append(f"missing Python module '{m}' for {python}: "
                         f"apt-get install {MODULES[m]}")
    return lines


if __name__ == "__main__":
    # prereq.py [program ...] [--modules module ...]: the missing ones, one line each; exit 1.
    import sys
    args = sys.argv[1:]
    split = args.index("--modules") if "--modules" in args else len(args)
    lines = missing(args[:split], args[split + 1:])
    print("\n".join(lines))
    sys.exit(1 if lines else 0)
