#!/usr/bin/env bash
# Installs the Debian 12 packages needed to build, test, fuzz, benchmark and cross-compile
# ferrule, QEMU for the firmware tests, and the Modbus peers its tests talk to (libmodbus, pymodbus, mbpoll, socat). Idempotent: when every package is already installed it does nothing (and needs
# neither root nor the network); set FERRULE_DEPS_FORCE=1 to run apt-get anyway.
set -euo pipefail

packages=(
    cmake ninja-build g++ python3
    catch2 libbenchmark-dev libasio-dev libcli11-dev libfmt-dev nlohmann-json3-dev
    clang-14 libclang-rt-14-dev
    gcc-arm-none-eabi libstdc++-arm-none-eabi-newlib binutils-arm-none-eabi
    # boots the firmware examples (netduinoplus2, an STM32F405) in the tests
    qemu-system-arm
    pkg-config socat libmodbus-dev mbpoll
    # pymodbus's serial and server modules import these; Debian only recommends them.
    python3-pymodbus python3-serial python3-serial-asyncio
)

missing=()
for p in "${packages[@]}"; do
    status=$(dpkg-query -W -f='${db:Status-Status}' "$p" 2>/dev/null || true)
    [[ $status == installed ]] || missing+=("$p")
done

if [[ ${#missing[@]} -eq 0 && ${FERRULE_DEPS_FORCE:-0} != 1 ]]; then
    echo "install-deps: all ${#packages[@]} packages already installed"
    exit 0
fi
[[ ${#missing[@]} -eq 0 ]] || echo "install-deps: missing: ${missing[*]}"

sudo=()
if [[ $(id -u) -ne 0 ]]; then
    command -v sudo >/dev/null || { echo "install-deps: not root and no sudo" >&2; exit 1; }
    sudo=(sudo)
fi
export DEBIAN_FRONTEND=noninteractive
"${sudo[@]}" apt-get update
"${sudo[@]}" apt-get install -y --no-install-recommends "${packages[@]}"
