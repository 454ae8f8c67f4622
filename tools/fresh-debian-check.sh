#!/usr/bin/env bash
# Runs the README's two commands on a Debian 12 that has none of ferrule's packages: a
# debootstrap chroot (minbase: no compiler, no Python) holding a clean clone of this
# repository's HEAD and ../shared beside it. This is how a missing line in
# tools/install-deps.sh shows before a user meets it.
#
# usage (as root, needs debootstrap): tools/fresh-debian-check.sh [DIR]
#   DIR  where the chroot goes (default /var/tmp/ferrule-fresh); reused if it holds one
#        already, so only the first run downloads the base system. FERRULE_FRESH_CLEAN=1
#        starts from a new base system.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

root=${1:-/var/tmp/ferrule-fresh}
mirror=${FERRULE_DEBIAN_MIRROR:-http://deb.debian.org/debian}
[[ $(id -u) -eq 0 ]] || { echo "fresh-debian-check: run as root (chroot, mount)" >&2; exit 1; }
command -v debootstrap >/dev/null || {
    echo "fresh-debian-check: apt-get install debootstrap" >&2
    exit 1
}

mounted=()
cleanup() {
    for ((i = ${#mounted[@]} - 1; i >= 0; i--)); do umount -l "${mounted[i]}" || true; done
}
trap cleanup EXIT

if [[ ${FERRULE_FRESH_CLEAN:-0} == 1 ]]; then rm -rf "$root"; fi
if [[ ! -x $root/usr/bin/apt-get ]]; then
    echo "fresh-debian-check: debootstrap bookworm (minbase) into $root"
    debootstrap --variant=minbase bookworm "$root" "$mirror"
fi
cp /etc/resolv.conf "$root/etc/resolv.conf"

for m in proc sys dev dev/pts; do
    mount --bind "/$m" "$root/$m"
    mounted+=("$root/$m")
done

work=$root/work
rm -rf "$work"
mkdir -p "$work"
git clone -q . "$work/main"
cp -R ../shared "$work/shared"

echo "fresh-debian-check: packages before: $(chroot "$root" dpkg-query -W | wc -l)"
# The README's two commands, as a user on that machine types them.
chroot "$root" /bin/bash -c 'cd /work/main && tools/install-deps.sh && cmake --preset default \
    && cmake --build --preset default --target ferrule_cli && build/default/examples/ferrule/ferrule demo' \
    >"$work/demo.out" 2>"$work/demo.err"
echo "fresh-debian-check: demo exit 0; stdout $(wc -l <"$work/demo.out") lines, $work/demo.out"
chroot "$root" /bin/bash -c 'cd /work/main && tools/install-deps.sh && cmake --workflow --preset default' \
    2>&1 | tee "$work/test.out" | tail -n 15
echo "fresh-debian-check: the README's two commands passed on a fresh Debian 12 in $root"
