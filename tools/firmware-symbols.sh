#!/usr/bin/env bash
# Usage: tools/firmware-symbols.sh <elf>...
#
# Fails (exit 1) when a firmware image holds a symbol of the heap, C++ strings, exceptions,
# locales or stdio: what a firmware engineer does not want in a flash image, and what would
# show that something reached libstdc++'s or newlib's hosted parts. Lists each offender.
# NM overrides the binary (default arm-none-eabi-nm).
set -euo pipefail
nm=${NM:-arm-none-eabi-nm}
forbidden='(^|[^[:alnum:]_])(_?malloc|_?free|_?realloc|_?calloc|_sbrk|_sbrk_r|__cxa_[a-z_]+|__gxx_personality_v0|_Unwind_[A-Za-z_]+|abort|_exit|printf|puts|fwrite|fputs|__sfp|_impure_ptr|__sinit|setlocale|__locale_ctype_ptr)$|operator new|operator delete|std::__cxx11::basic_string|std::(__cxx11::)?locale|std::error_category|std::system_error'
status=0
for elf in "$@"; do
    bad=$("$nm" -C "$elf" | awk '{ $1 = ""; $2 = ""; sub(/^ +/, ""); print }' | grep -E "$forbidden" || true)
    if [[ -n $bad ]]; then
        echo "$elf: forbidden symbols:" >&2
        sed 's/^/  /' <<<"$bad" >&2
        status=1
    else
        echo "$elf: none of heap, strings, exceptions, locale, stdio"
    fi
done
exit $status
