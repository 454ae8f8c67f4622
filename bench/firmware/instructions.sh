#!/bin/sh
# Instructions per transaction of each protocol's master, counted in QEMU (netduinoplus2):
#   bench/firmware/instructions.sh <bench/firmware build dir>
# boots <dir>/insn.elf (bench/firmware/insn/main.cpp) twice with `-icount shift=0` (one guest
# instruction per virtual nanosecond), fails unless both runs print the same counts, and prints
# them as one markdown table. QEMU is $FERRULE_QEMU or qemu-system-arm.
set -eu
dir=${1:?usage: instructions.sh <bench/firmware build dir>}
elf=$dir/insn.elf
[ -f "$elf" ] || { echo "no $elf: build bench/firmware first" >&2; exit 2; }
qemu=${FERRULE_QEMU:-qemu-system-arm}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

# One run: the console (USART3) until the image ends QEMU through semihosting, 300 s at most.
run() {
    timeout 300 "$qemu" -M netduinoplus2 -nodefaults -display none -monitor none \
        -semihosting-config enable=on,target=native -icount shift=0 \
        -serial null -serial null -serial stdio -kernel "$elf" 2>/dev/null |
        tr -d '\r' | sed -n '/^insn /p'
}
run >"$tmp/1"
run >"$tmp/2"
grep -q '^insn done' "$tmp/1" || { echo "the image did not finish:" >&2; cat "$tmp/1" >&2; exit 1; }
if ! cmp -s "$tmp/1" "$tmp/2"; then
    echo "two runs differ:" >&2
    diff "$tmp/1" "$tmp/2" >&2 || true
    exit 1
fi

awk '
function field(name,    i, kv) {
    for (i = 2; i <= NF; ++i) { split($i, kv, "="); if (kv[1] == name) return kv[2] }
    return "?"
}
/^insn nops_100000/ { nops = field("measured") }
/^insn metering_overhead_per_call/ { overhead = field("metering_overhead_per_call") }
/^insn done/ { stack = field("stack") }
/^insn [a-z_0-9]+ ok=/ {
    rows[++n] = sprintf("| %s | %s | %s | %s | %s | %s |", $2, field("ok"), field("total"),
                        field("line_and_device"), field("master"), field("stream_calls"))
}
END {
    print "| transaction | succeeded | instructions, all | line + simulated device | master | stream calls |"
    print "|---|---|---|---|---|---|"
    for (i = 1; i <= n; ++i) print rows[i]
    print ""
    printf "Check: 100 000 nops counted as %s; metering overhead %s per stream call; stack %s bytes; two runs identical.\n", nops, overhead, stack
}' "$tmp/1"
