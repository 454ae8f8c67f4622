#!/usr/bin/env bash
# Usage: tools/firmware-size.sh [-v] [-r] [-i] <elf> <namespace-regex> [<exclude-regex>]
#
# Sums the sizes of the code symbols (.text: nm types t/T, and w/W, which is where the inline
# functions and template instantiations of a header-only library end up) of <elf> whose
# demangled name matches the extended regex <namespace-regex> (and not <exclude-regex>, if
# given), and prints the total in bytes on stdout. Symbols sharing an address are counted once.
# Read-only data (tables, vtables) is counted only with -r: then the named objects in .rodata*
# that match are added (objdump -t). With -v the matching symbols are listed on stderr,
# largest last.
# With -i the code that the compiler inlined from ferrule's headers into other functions (the
# application's main(), a static initialiser) is added too: the instructions of functions
# that do not match, and are not excluded, whose debug line lies in a file under
# include/ferrule/ whose path <exclude-regex> does not match either. The ELF must carry line tables (-g; the firmware preset builds with it).
# Without -i an example that calls a session function once may get it inlined into main()
# and not counted.
#   tools/firmware-size.sh build/firmware/examples/firmware/movilink_master.elf 'ferrule::movilink::'
# MOVILINK codec + master session (no cyclic layer, no error-message texts):
#   tools/firmware-size.sh <elf> 'ferrule::' 'ferrule::movilink::cyclic::|_domain_t::|^board::'
# NM and OBJDUMP override the binaries (default arm-none-eabi-nm, arm-none-eabi-objdump).
set -euo pipefail

verbose=0
rodata=0
inlined=0
while [[ ${1:-} == -[vri] ]]; do
    [[ $1 == -v ]] && verbose=1
    [[ $1 == -r ]] && rodata=1
    [[ $1 == -i ]] && inlined=1
    shift
done
if [[ $# -ne 2 && $# -ne 3 ]]; then
    echo "usage: $0 [-v] [-r] [-i] <elf> <namespace-regex> [<exclude-regex>]" >&2
    exit 2
fi
elf=$1
regex=$2
exclude=${3:-}
nm=${NM:-arm-none-eabi-nm}
objdump=${OBJDUMP:-arm-none-eabi-objdump}
[[ -f $elf ]] || { echo "$0: no such file: $elf" >&2; exit 2; }

total=0
declare -A seen # aliases (e.g. C1/C2 constructors) share one address: count it once
# count <addr> <hex size> <name> [<note>]: adds a symbol that matches, once per address.
count() {
    [[ $3 =~ $regex ]] || return 0
    [[ -n $exclude && $3 =~ $exclude ]] && return 0
    [[ -z ${seen[$1]:-} ]] || return 0
    seen[$1]=1
    total=$((total + 16#$2))
    if ((verbose)); then
        printf '%8d %s%s\n' "$((16#$2))" "$3" "${4:-}" >&2
    fi
}

symbols=$("$nm" --size-sort -C -S "$elf")
while read -r addr size type name; do
    [[ $type == [tTwW] ]] && count "$addr" "$size" "$name"
done <<<"$symbols"
if ((rodata)); then
    # objdump -t: "<addr> <7 flag columns> <section>\t<size> <name>"
    objects=$("$objdump" -t -C "$elf")
    re_obj=$'^([0-9a-f]+) .{6}O (\\.rodata[^\t]*)\t([0-9a-f]+) (.*)$'
    while IFS= read -r line; do
        [[ $line =~ $re_obj ]] &&
            count "${BASH_REMATCH[1]}" "${BASH_REMATCH[3]}" "${BASH_REMATCH[4]}" ' (rodata)'
    done <<<"$objects"
fi
if ((inlined)); then
    # objdump -d -l: "<addr> <name>:" opens a function, "/path/file:line" sets the source, an
    # instruction line is "  addr:\t<hex bytes>\t…". Prints "<bytes> <function>" per function.
    per_function=$("$objdump" -d -l -C "$elf" | awk -v re="$regex" -v ex="$exclude" '
        /^[0-9a-f]+ <.*>:$/ {
            name = substr($0, index($0, "<") + 1); sub(/>:$/, "", name)
            other = name !~ re && (ex == "" || name !~ ex); ours = 0; next
        }
        /^\/.*:[0-9]+/ { ours = index($0, "/include/ferrule/") > 0 && (ex == "" || $0 !~ ex); next }
        other && ours && /^ +[0-9a-f]+:\t/ {
            split($0, f, "\t"); hex = f[2]; gsub(/ /, "", hex)
            bytes[name] += length(hex) / 2
        }
        END { for (n in bytes) print bytes[n], n }')
    if ! "$objdump" -h "$elf" | grep -q '\.debug_line'; then
        echo "$0: -i: $elf has no line tables (build with -g)" >&2
        exit 2
    fi
    while read -r bytes name; do
        [[ -n $bytes ]] || continue
        total=$((total + bytes))
        ((verbose)) && printf '%8d %s (inlined ferrule code)\n' "$bytes" "$name" >&2
    done <<<"$per_function"
fi
echo "$total"
