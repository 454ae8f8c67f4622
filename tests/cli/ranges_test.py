#!/usr/bin/env python3
"""Every numeric option and argument of every `ferrule` command against its range, with
--dry-run so nothing is opened (docs/cli.md, "Numbers and ranges").

usage: ranges_test.py <ferrule>

The table below gives, per command and option, the values the protocol allows. For each row
the sweep runs the bounds themselves and every value next to them (expect exit 0), the value
just outside each bound, minimum - 1, maximum + 1, a number too large for 64 bits and a
non-number (expect exit 2 and a message with the option's name and the value). Then it reads
`ferrule ... --help` of every command and fails for a numeric option the table does not cover
or one that shows no range.
Each check prints 'ok <name>' or 'FAIL <name>: why'; the last line is 'N passed, M failed'.
"""
import re
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from decimal import Decimal

from harness import check, summary

ferrule = sys.argv[1]

MAX_MS = 86_400_000  # every duration in ms: a day
MAX_COUNT = 1_000_000
MAX_RETRIES = 100
INT32 = (-2**31, 2**31 - 1)
HOST_BAUDS = [1200, 2400, 4800, 9600, 19200, 38400, 57600, 115200, 230400, 460800, 921600]


def span(lo, hi):
    return [(lo, hi)]


def one_of(*values):
    return [(v, v) for v in values]


class Row:
    """`ferrule <command> <args>`, the value where "{}" is; `allowed` are inclusive intervals.
    `step` is the resolution of a decimal number; `text` formats an integer as typed."""

    def __init__(self, command, name, allowed, args, step=1, text=str):
        self.command, self.name, self.allowed, self.args = command, name, allowed, args
        self.step, self.text = Decimal(step), text

    def fits(self, v):
        return any(lo <= v <= hi for lo, hi in self.allowed)

    def values(self):
        """(value as typed, expected to be accepted)"""
        inside, outside = set(), set()
        for lo, hi in self.allowed:
            for v in (Decimal(lo), Decimal(hi)):
                inside.add(v)
            for v in (Decimal(lo) - self.step, Decimal(hi) + self.step):
                (inside if self.fits(v) else outside).add(v)
        outside.add(Decimal(self.allowed[0][0]) - 1)
        outside.add(Decimal(self.allowed[-1][1]) + 1)
        out = [(self.format(v), True) for v in sorted(inside)]
        out += [(self.format(v), False) for v in sorted(outside)]
        return out + [("99999999999999999999", False), ("x1", False)]

    def format(self, v):
        return str(v) if self.step != 1 else self.text(int(v))


def hex_text(v):
    return f"{v:X}" if v >= 0 else str(v)


# The commands of each protocol with the arguments they need to run with --dry-run.
MOVILINK = {"status": [], "read": ["8318"], "write": ["8318", "0"], "run": ["0"], "stop": [],
            "watch": []}
DIMETIX = {"measure": [], "track": ["1"], "temperature": [], "signal": [], "laser-on": [],
           "stop": [], "info": [], "errors read": [], "errors clear": [], "config get": ["mc"],
           "config set": ["mc", "1"], "config save": []}
LECOM = {"read": ["C0050"], "write": ["C0046", "1"], "poll": ["C0050"]}
MODBUS = {"read": [], "write": ["1"], "diag": [], "id": []}
PROFIBUS = {"diag": [], "set-prm": ["--ident=0x0815"], "cfg": ["24 14"], "get-cfg": [],
            "exchange": ["--out=06 C8 00 00 25"], "clear": []}
MEMOBUS = {"read": ["MW00100"], "write": ["MW00100", "1"]}

LECOM_DRIVES = [(t + 1, t + 9) for t in range(0, 100, 10)]  # 01-99 without x0 (C0009)

TABLE = []


def rows(protocol, commands, option, allowed_of, **kw):
    """One row of `option` per command; allowed_of(command) gives its intervals."""
    for cmd, base in commands.items():
        TABLE.append(Row(f"{protocol} {cmd}", option, allowed_of(cmd), base + [option + "={}"],
                         **kw))


# The common options.
rows("movilink", MOVILINK, "--baud", lambda c: one_of(9600, 57600))
rows("movilink", MOVILINK, "--address",  # 0-99 single, 100-199 group, 254 p2p, 255 broadcast
     lambda c: [(0, 199), (254, 255)] if c == "write" else [(0, 99), (254, 254)])
rows("dimetix", DIMETIX, "--baud", lambda c: one_of(9600, 19200, 115200))
rows("dimetix", DIMETIX, "--address", lambda c: span(0, 99))
rows("lecom", LECOM, "--baud", lambda c: one_of(*[b for b in HOST_BAUDS if b <= 57600]))
rows("lecom", LECOM, "--address", lambda c: span(0, 99) if c == "write" else LECOM_DRIVES)
rows("modbus", MODBUS, "--baud", lambda c: one_of(*HOST_BAUDS))
rows("modbus", MODBUS, "--unit", lambda c: span(0 if c == "write" else 1, 247))
rows("modbus", MODBUS, "--gap", lambda c: span(0, MAX_MS), step="0.001")
rows("profibus", PROFIBUS, "--baud", lambda c: one_of(9600, 19200))
rows("profibus", PROFIBUS, "--address", lambda c: [(0, 1), (3, 126)])  # 2: the master's
rows("profibus", PROFIBUS, "--master-address", lambda c: [(0, 7), (9, 126)])  # 8: the slave's
rows("memobus", MEMOBUS, "--local-port", lambda c: span(1, 65535))
rows("memobus", MEMOBUS, "--cpu", lambda c: span(0, 255))
for protocol, commands in [("movilink", MOVILINK), ("dimetix", DIMETIX), ("lecom", LECOM),
                           ("modbus", MODBUS), ("profibus", PROFIBUS), ("memobus", MEMOBUS)]:
    rows(protocol, commands, "--timeout", lambda c: span(1, MAX_MS))
    rows(protocol, commands, "--retries", lambda c: span(0, MAX_RETRIES))

TABLE += [
    # command, option or argument, allowed, arguments
    Row("movilink read", "index", span(0, 0xFFFF), ["{}"]),
    Row("movilink read", "--subindex", span(0, 255), ["8318", "--subindex={}"]),
    Row("movilink write", "index", span(0, 0xFFFF), ["{}", "0"]),
    Row("movilink write", "value", span(-2**31, 2**32 - 1), ["8318", "{}"]),
    Row("movilink write", "--subindex", span(0, 255), ["8318", "0", "--subindex={}"]),
    Row("movilink run", "rpm", span(Decimal("-6553.6"), Decimal("6553.4")), ["{}"], step="0.1"),
    Row("movilink run", "--ramp", span(0, 0xFFFF), ["0", "--ramp={}"]),
    Row("movilink run", "--seconds", span(0, 86400), ["0", "--seconds={}"], step="0.1"),
    Row("movilink run", "--interval", span(0, MAX_MS), ["0", "--interval={}"]),
    Row("movilink stop", "--ramp", span(0, 0xFFFF), ["--ramp={}"]),
    Row("movilink stop", "--seconds", span(0, 86400), ["--seconds={}"], step="0.1"),
    Row("movilink stop", "--interval", span(0, MAX_MS), ["--interval={}"]),
    Row("movilink watch", "--count", span(1, MAX_COUNT), ["--count={}"]),
    Row("movilink watch", "--interval", span(0, MAX_MS), ["--interval={}"]),

    Row("dimetix measure", "--count", span(1, MAX_COUNT), ["--count={}"]),
    Row("dimetix measure", "--interval", span(0, MAX_MS), ["--interval={}"]),
    Row("dimetix track", "count", span(1, MAX_COUNT), ["{}"]),
    Row("dimetix track", "--interval", span(0, MAX_MS), ["1", "--interval={}"]),
    Row("dimetix config get", "selector", span(1, 3), ["afi", "{}"]),
    Row("dimetix config get", "selector", span(1, 2), ["ado", "{}"]),
    # config set: the first value in the range of S1 §8.3-8.4, the others 32-bit.
    Row("dimetix config set", "values", one_of(1, 2, 6, 7, 10, 11), ["br", "{}"]),
    Row("dimetix config set", "values", span(0, 99), ["id", "{}"]),
    Row("dimetix config set", "values", span(0, 1), ["vm", "{}"]),
    Row("dimetix config set", "values", span(0, 999), ["ve", "{}"]),
    Row("dimetix config set", "values", span(*INT32), ["v", "{}", "0"]),
    Row("dimetix config set", "values", span(*INT32), ["v", "0", "{}"]),
    Row("dimetix config set", "values", span(0, 2), ["ot", "{}"]),
    Row("dimetix config set", "values", span(*INT32), ["1", "{}", "0"]),
    Row("dimetix config set", "values", span(*INT32), ["2", "{}", "0"]),
    Row("dimetix config set", "values", span(0, 8), ["DI1", "{}"]),
    Row("dimetix config set", "values", span(0, 63), ["SSI", "{}"]),
    Row("dimetix config set", "values", span(-2, 33554431), ["SSIe", "{}"]),
    Row("dimetix config set", "values", span(0, 4), ["mc", "{}"]),
    Row("dimetix config set", "values", span(0, 32), ["fi", "{}", "0", "0"]),
    Row("dimetix config set", "values", span(0, MAX_MS), ["A", "{}"]),
    Row("dimetix config set", "values", span(0, MAX_MS), ["f", "{}"]),
    Row("dimetix config set", "values", span(0, 301), ["uo", "{}"]),
    Row("dimetix config set", "values", span(*INT32), ["uof", "{}"]),
    Row("dimetix config set", "values", span(*INT32), ["uga", "{}", "0"]),
    Row("dimetix config set", "values", span(0, 5), ["um", "{}"]),
    Row("dimetix config set", "values", span(1, 3), ["afi", "{}", "0"]),
    Row("dimetix config set", "values", span(1, 2), ["ado", "{}", "0", "0", "0"]),

    Row("lecom read", "codes", span(0, 6229), ["C{}"]),
    Row("lecom read", "codes", span(0, 0xFFFF), ["C{}", "--extended"]),
    Row("lecom read", "codes", span(0, 255), ["C1/{}"]),
    Row("lecom write", "code", span(0, 6229), ["C{}", "1"]),
    Row("lecom write", "value", span(Decimal("-214748.3648"), Decimal("214748.3647")),
        ["C0046", "{}"], step="0.0001"),
    Row("lecom poll", "codes", span(0, 6229), ["C{}"]),
    Row("lecom poll", "--drives", LECOM_DRIVES, ["C0050", "--drives={}"]),
    Row("lecom poll", "--interval", span(0, MAX_MS), ["C0050", "--interval={}"]),
    Row("lecom poll", "--cycles", span(0, MAX_COUNT), ["C0050", "--cycles={}"]),
    Row("lecom poll", "--refresh", span(1, MAX_MS), ["C0050", "--refresh={}"]),
    Row("lecom poll", "--gap", span(0, MAX_MS), ["C0050", "--gap={}"]),

    Row("modbus read", "--unit", span(0, 255), ["--host=plc", "--unit={}"]),  # TCP
    Row("modbus read", "--start", span(0, 0xFFFF), ["--start={}"]),
    Row("modbus read", "--count", span(1, 125), ["--count={}"]),
    Row("modbus read", "--count", span(1, 125), ["-t", "input", "--count={}"]),
    Row("modbus read", "--count", span(1, 2000), ["-t", "coil", "--count={}"]),
    Row("modbus read", "--count", span(1, 2000), ["-t", "discrete", "--count={}"]),
    Row("modbus read", "--count", span(1, 62), ["--as", "float", "--count={}"]),
    Row("modbus read", "--count", span(1, 6), ["--start=65530", "--count={}"]),
    Row("modbus write", "--start", span(0, 0xFFFF), ["--start={}", "1"]),
    Row("modbus write", "--start", span(0, 0xFFFE), ["--start={}", "--as", "u32", "1"]),
    Row("modbus write", "values", span(0, 0xFFFF), ["{}"]),
    Row("modbus write", "values", span(-32768, 32767), ["--as", "i16", "{}"]),
    Row("modbus write", "values", span(0, 2**32 - 1), ["--as", "u32", "{}"]),
    Row("modbus write", "values", span(*INT32), ["--as", "i32", "{}"]),
    Row("modbus write", "values", span(0, 0xFFFF), ["--as", "hex", "{}"], text=hex_text),
    Row("modbus write", "values", span(0, 1), ["-t", "coil", "{}"]),
    Row("modbus diag", "--data", span(0, 0xFFFF), ["--data={}"]),

    Row("profibus set-prm", "--ident", span(1, 0xFFFE), ["--ident={}"]),
    Row("profibus set-prm", "--watchdog-ms", span(10, 650250),
        ["--ident=0x0815", "--watchdog-ms={}"]),
    Row("profibus exchange", "--count", span(1, MAX_COUNT), ["--out=00", "--count={}"]),
    Row("profibus exchange", "--interval-ms", span(0, MAX_MS), ["--out=00", "--interval-ms={}"]),
    Row("profibus exchange", "--ident", span(1, 0xFFFE), ["--out=00", "--ident={}"]),
    Row("profibus exchange", "--watchdog-ms", span(10, 650250), ["--out=00", "--watchdog-ms={}"]),

    Row("memobus read", "--count", span(1, 2044), ["MW00000", "--count={}"]),
    Row("memobus read", "--count", span(1, 2044), ["IW00000", "--count={}"]),
    Row("memobus read", "--count", span(1, 125), ["MW00000", "--classic", "--count={}"]),
    Row("memobus read", "--count", span(1, 2000), ["MB000000", "--count={}"]),
    Row("memobus read", "--count", span(1, 535), ["MW65000", "--count={}"]),
    Row("memobus write", "values", span(-32768, 65535), ["MW00100", "{}"]),
    Row("memobus write", "values", span(0, 1), ["MB001000", "{}"]),

    Row("decode", "--max-junk", span(8192, 16 << 20),
        ["modbus-rtu", "--max-junk={}", "01", "06", "C8", "00", "00", "25", "76", "71"]),
]


def run(args):
    p = subprocess.run([ferrule, *args], capture_output=True, text=True, timeout=30)
    return p.returncode, p.stdout, p.stderr


def invocation(row, value):
    """The command with the value, and --dry-run where the command opens a port."""
    dry = [] if row.command == "decode" else ["--dry-run"]
    return row.command.split() + [a.replace("{}", value) for a in row.args] + dry


def typed(row, value):
    """The value as the command line has it: "C6230" for "C{}", "256" for "--address={}"."""
    arg = next(a for a in row.args if "{}" in a).replace("{}", value)
    return arg.split("=", 1)[1] if arg.startswith("--") else arg


def refusal(row, value, err):
    """Does `err` name the option and, after a colon, the value: "--address: 256 is …"?"""
    pattern = re.escape(row.name) + r"[^\n]*?: '?" + re.escape(typed(row, value)) + r"'?(?=[\s;,)]|$)"
    return re.search(pattern, err) is not None


# The sweep: every row's values, run four at a time, checked in table order.
cases = [(row, value, accepted) for row in TABLE for value, accepted in row.values()]
with ThreadPoolExecutor(max_workers=4) as pool:
    results = list(pool.map(lambda c: run(invocation(c[0], c[1])), cases))
for (row, value, accepted), (rc, out, err) in zip(cases, results):
    what = " ".join(invocation(row, value))
    if accepted:
        check(f"{what} runs", rc == 0 and out.strip() != "", f"exit {rc}: {err}")
    else:
        check(f"{what} is refused", rc == 2 and out == "" and refusal(row, value, err),
              f"exit {rc}: {out}{err}")


# Coverage: the numeric options and arguments of every command, from --help.
def commands(path):
    """Every command below `path` that has no subcommand of its own, as word lists."""
    _, out, _ = run([*path, "--help"])
    subs = re.findall(r"^  (\S+) ", out.split("Subcommands:")[1], re.M) if "Subcommands:" in out \
        else []
    if not subs:
        return [path]
    return [c for s in subs for c in commands(path + [s])]


NUMERIC = re.compile(r"^  (\S+) ((?:U?INT|FLOAT)\S*)", re.M)
covered = {(row.command, row.name) for row in TABLE}
found = 0
for path in commands([]):
    _, out, _ = run([*path, "--help"])
    for names, kind in NUMERIC.findall(out):
        long_names = [n for n in names.split(",") if n.startswith("--")]
        name = long_names[0] if long_names else names
        found += 1
        command = " ".join(path)
        check(f"{command} {name} is in the table", (command, name) in covered, kind)
        check(f"{command} {name} shows its range", ":" in kind, kind)
check("--help lists numeric options", found > 100, f"{found} found")

# The review's cases, each a frame for another drive, parameter or value before.
for args in (["movilink", "write", "0x1207E", "5"], ["movilink", "read", "70000"],
             ["movilink", "read", "8318", "--address", "256"],
             ["movilink", "read", "8318", "--address", "300"],
             ["movilink", "read", "8318", "--subindex", "300"],
             ["movilink", "write", "8599", "4294967296"],
             ["movilink", "write", "8599", "99999999999"], ["movilink", "run", "100000"]):
    rc, out, err = run([*args, "--dry-run"])
    check(f"{' '.join(args)} is refused", rc == 2 and out == "", out + err)

# A leading 0 is decimal: drive 10, register 10, not octal 8.
rc, out, _ = run(["movilink", "read", "8318", "--address", "010", "--dry-run"])
check("--address 010 is drive 10", out.strip() == "02 0A 86 31 00 20 7E 00 00 00 00 E1", out)
rc, out, _ = run(["modbus", "read", "-r", "010", "--dry-run"])
check("--start 010 is register 10", out.strip() == "01 03 00 0A 00 01 A4 08", out)
# The speed's bounds are the PO2 word's, not clamped to it.
rc, out, _ = run(["movilink", "run", "6553.4", "--dry-run"])
check("run 6553.4 is PO2 0x7FFF", out.strip() == "02 01 05 00 06 7F FF 03 E8 6B", out)
rc, out, _ = run(["movilink", "run", "-6553.6", "--dry-run"])
check("run -6553.6 is PO2 0x8000", out.strip() == "02 01 05 00 06 80 00 03 E8 6B", out)
rc, out, _ = run(["movilink", "write", "8599", "-1", "--dry-run"])
check("write -1 is 0xFFFFFFFF", out.strip() == "02 01 86 33 00 21 97 FF FF FF FF 00", out)

sys.exit(summary())
