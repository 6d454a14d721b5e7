#!/usr/bin/env bash
# Builds the gpio-sim kernel module for the rt-vm guest kernel, out of tree, and
# caches it beside the kernel package: Debian's RT kernel has CONFIG_GPIO_CDEV
# but not CONFIG_GPIO_SIM. Prints the path of gpio-sim.ko on stdout.
#
#   scripts/lib/rt-vm/gpio-sim-build.sh CACHE
#
# CACHE is the rt-vm kernel cache (scripts/rt-vm --cache; it must already hold
# the unpacked kernel: run scripts/rt-vm once). The sources come from the
# packages of the same version as the kernel package: linux-source-6.1,
# linux-headers-<release> and linux-headers-<abi>-common-rt, linux-kbuild-6.1,
# fetched with `apt-get download` and unpacked with `dpkg-deb -x` (nothing is
# installed). gpio-sim needs the interrupt simulator (kernel/irq/irq_sim.c),
# which this kernel does not build: it is compiled into the same module, with
# its one use of the unexported irq_to_desc() replaced by generic_handle_irq().
#
# Exit status: 0 built or cached; 77 the packages cannot be downloaded and
# nothing is cached (a skip); 1 the build failed.
set -euo pipefail

cache="$(realpath "${1:?usage: gpio-sim-build.sh CACHE}")"
say() { echo "gpio-sim-build: $*" >&2; }

image_dir="$(ls -d "$cache"/linux-image-*/ 2>/dev/null | head -n1)"
[ -n "$image_dir" ] || { say "no unpacked kernel in $cache (run scripts/rt-vm once)"; exit 1; }
release="$(ls "$image_dir/lib/modules" | head -n1)"           # 6.1.0-57-rt-amd64
version="$(basename "$image_dir" | sed 's/^linux-image-[^_]*_\([^_]*\)_.*/\1/')"  # 6.1.192-3
abi="${release%-rt-amd64}"                                    # 6.1.0-57
series="${release%%.*}.$(echo "$release" | cut -d. -f2)"      # 6.1
out="$cache/gpio-sim/$release"
if [ -f "$out/gpio-sim.ko" ]; then
  echo "$out/gpio-sim.ko"
  exit 0
fi

work="$cache/gpio-sim/work-$release"
mkdir -p "$work/debs" "$work/root"
log="$work/build.log"
: >"$log"
exec 9>"$cache/gpio-sim/.lock"
flock 9

pkgs=("linux-source-$series" "linux-headers-$release" "linux-headers-$abi-common-rt" "linux-kbuild-$series")
for p in "${pkgs[@]}"; do
  if ! ls "$work/debs/${p}_"*.deb >/dev/null 2>&1; then
    say "downloading $p=$version (apt-get download)"
    if ! (cd "$work/debs" && apt-get download "$p=$version") >>"$log" 2>&1; then
      cat "$log" >&2
      say "skipped: $p=$version cannot be downloaded and no gpio-sim.ko is cached in $out"
      exit 77
    fi
  fi
done
root="$work/root"
for deb in "$work/debs"/*.deb; do
  stamp="$root/.$(basename "$deb").unpacked"
  [ -f "$stamp" ] && continue
  say "unpacking $(basename "$deb") (dpkg-deb -x)"
  dpkg-deb -x "$deb" "$root"
  touch "$stamp"
done

# Only three files are needed from the (large) source tarball.
src="$work/src"
if [ ! -f "$src/gpio-sim-main.c" ]; then
  tarball="$(ls "$root"/usr/src/linux-source-"$series".tar.* | head -n1)"
  top="linux-source-$series"
  mkdir -p "$src"
  say "extracting gpio-sim.c, gpiolib.h and irq_sim.c from $(basename "$tarball")"
  tar -xf "$tarball" -C "$src" --strip-components=3 \
    "$top/drivers/gpio/gpio-sim.c" "$top/drivers/gpio/gpiolib.h" "$top/kernel/irq/irq_sim.c"
  # irq_to_desc() is not exported: generic_handle_irq() does the same lookup.
  sed -i 's/handle_simple_irq(irq_to_desc(\([^)]*\)))/generic_handle_irq(\1)/' "$src/irq_sim.c"
  grep -q 'generic_handle_irq(' "$src/irq_sim.c" || { say "irq_sim.c: the irq_to_desc() call was not found"; exit 1; }
  cat >"$src/Makefile" <<'MK'
obj-m := gpio-sim.o
gpio-sim-y := gpio-sim-main.o irq_sim.o
MK
  mv "$src/gpio-sim.c" "$src/gpio-sim-main.c"
fi

# The headers' Makefile includes the common tree by its installed path.
hdr="$root/usr/src/linux-headers-$release"
common="$root/usr/src/linux-headers-$abi-common-rt"
sed -i "s|[^ ]*/usr/src/linux-headers-$abi-common-rt|$common|g" "$hdr/Makefile"
# The kbuild tools are a symlink to the installed linux-kbuild package.
for l in scripts tools; do
  if [ -L "$hdr/$l" ]; then
    target="$(readlink "$hdr/$l")"
    case "$target" in /*) ln -sfn "$root$target" "$hdr/$l" ;; esac
  fi
done
say "building gpio-sim.ko for $release"
if ! make -C "$hdr" M="$src" modules >>"$log" 2>&1; then
  tail -40 "$log" >&2
  say "the module build failed (log: $log)"
  exit 1
fi
mkdir -p "$out"
cp "$src/gpio-sim.ko" "$out/gpio-sim.ko"
echo "$out/gpio-sim.ko"
