#!/usr/bin/env python3
"""`ferrule demo` with stdout and stderr on one pipe, as in `ferrule demo 2>&1 | less` or a CI
log: the serial driver's warnings about settings a pseudo-terminal cannot take are whole
lines of their own, each said once, and no line of the demo carries a warning's text.

usage: demo_output_test.py <ferrule>
Each check prints 'ok <name>' or 'FAIL <name>: why'; the last line is 'N passed, M failed'.
"""
import subprocess
import sys

from harness import check, summary

ferrule = sys.argv[1]
p = subprocess.run([ferrule, "demo"], stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                   text=True, timeout=120)
lines = p.stdout.splitlines()
warnings = [line for line in lines if line.startswith("warning: ")]
check("the demo ends with exit 0", p.returncode == 0, p.stdout[-2000:])
# The demo's ptys take neither 7 data bits nor parity: there is something to warn about.
check("the pty warnings are there", len(warnings) > 0, p.stdout[-2000:])
broken = [line for line in lines if "warning" in line and not line.startswith("warning: ")]
check("no demo line carries a warning's text", not broken, "\n".join(broken))
repeated = sorted({w for w in warnings if warnings.count(w) > 1})
check("each warning once", not repeated, "\n".join(repeated))
check("the demo's lines are whole", "  broadcast C0040 = 0 (controller inhibit)" in p.stdout,
      p.stdout[-2000:])
sys.exit(summary())
