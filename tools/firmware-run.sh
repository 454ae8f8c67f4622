#!/usr/bin/env bash
# Usage: tools/firmware-run.sh <elf> [<usart1> [<usart2>]]
#
# Boots a firmware image in QEMU's netduinoplus2 (an STM32F405) with its console (USART3) on
# this terminal. <usart1>/<usart2>: a serial device or pty path for that USART (e.g. the
# --link of ferrule-sim), "pty" to let QEMU create one (it prints the /dev/pts path), or
# "null" (the default). Ctrl-C ends it. Example, the MOVILINK master against a simulated drive:
#   build/default/examples/sim/ferrule-sim movilink --link /tmp/drive &
#   tools/firmware-run.sh build/firmware/examples/firmware/movilink_master.elf null /tmp/drive
set -euo pipefail
[[ $# -ge 1 ]] || { sed -n '2,12p' "$0" >&2; exit 2; }
elf=$1
args=(-M netduinoplus2 -nodefaults -display none -monitor none)
for n in 1 2; do
    where=${2:-null}
    shift || true
    case $where in
    null) args+=(-serial null) ;;
    pty) args+=(-chardev "pty,id=usart$n" -serial "chardev:usart$n") ;;
    *) args+=(-chardev "serial,id=usart$n,path=$where" -serial "chardev:usart$n") ;;
    esac
done
exec "${QEMU:-qemu-system-arm}" "${args[@]}" -serial stdio -kernel "$elf"
