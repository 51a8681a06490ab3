#!/usr/bin/env bash
# Cross-compile the controller library for a Cortex-M4F (float build) with the firmware flags,
# fail if it calls anything but the allowed libc/libm functions or contains double-precision
# operations (soft-double helpers __aeabi_d*, __aeabi_f2d ...), and measure its code size as a
# firmware engineer ships it: linked into an image (tools/mcu_image.c, the smallest main that uses
# the whole drive API: every mode is reachable through the step table) with -ffunction-sections
# -fdata-sections -Wl,--gc-sections, in the shipped build (the toolchain file's MinSizeRel flags:
# -Os with link-time optimisation; the target: the library's .text and .rodata in that image
# <= 32 kB) and, for information, at -O2. The image's own main is compiled without LTO (none of the
# library is counted as the image's); the image's total also holds the C runtime and libm's
# functions (newlib-nano); the library's share is summed from the linker map: every .text/.rodata
# input section that is not the image's object, an archive member or a C runtime start file (with
# LTO the library's code comes from the link's ltrans objects).
set -euo pipefail
CC=${ARM_CC:-arm-none-eabi-gcc}
OUT=${1:-build/arm}
LIMIT=32768 # bytes, the library's code and constants in the shipped image
WARN="-std=c99 -Wall -Wextra -Wpedantic -Werror -Wdouble-promotion -Wconversion -Wshadow"
# the firmware flags, from their one home: the CMake toolchain file
TOOLCHAIN=csrc/cmake/arm-none-eabi-m4f.cmake
ARCH=$(sed -n 's/^set(CMAKE_C_FLAGS_INIT "\(.*\)")$/\1/p' "$TOOLCHAIN")
LINK=$(sed -n 's/^set(CMAKE_EXE_LINKER_FLAGS_INIT "\(.*\)")$/\1/p' "$TOOLCHAIN")
SHIP=$(sed -n 's/^set(CMAKE_C_FLAGS_MINSIZEREL_INIT "\(.*\)")$/\1/p' "$TOOLCHAIN")
if [ -z "$ARCH" ] || [ -z "$LINK" ] || [ -z "$SHIP" ]; then
  echo "check_mcu: FAILED: no one-line CMAKE_C_FLAGS_INIT, CMAKE_EXE_LINKER_FLAGS_INIT or CMAKE_C_FLAGS_MINSIZEREL_INIT in $TOOLCHAIN" >&2
  exit 1
fi
mkdir -p "$OUT"

# build the library and the image with one set of options; sets objs, lib_bytes, image_bytes
build() { # $1: the folder's name, $2: the options (-O2, or the shipped build's)
  local dir="$OUT/$1" src obj
  mkdir -p "$dir"
  objs=()
  for src in csrc/ctrl/*.c; do
    obj="$dir/$(basename "$src" .c).o"
    # (fat LTO objects: the symbol checks below read them without the LTO plugin)
    # shellcheck disable=SC2086
    $CC $WARN $ARCH $2 -ffat-lto-objects -Icsrc/include -c "$src" -o "$obj"
    objs+=("$obj")
  done
  # shellcheck disable=SC2086
  $CC $WARN $ARCH $2 -fno-lto -Icsrc/include -c tools/mcu_image.c -o "$dir/mcu_image.o"
  # shellcheck disable=SC2086
  $CC $ARCH $2 $LINK -Wl,-Map="$dir/image.map" \
    "$dir/mcu_image.o" "${objs[@]}" -lm -o "$dir/image.elf"
  image_bytes=$("${CC%gcc}size" "$dir/image.elf" | awk 'NR == 2 {print $1}')
  # the input sections of .text and .rodata the link kept from the library's objects (map lines
  # " .text.f  0xADDR  0xSIZE  file.o", the name alone on its line when it is long)
  lib_bytes=$(awk '
    function hex(x,   i, n) { n = 0; x = tolower(substr(x, 3)); for (i = 1; i <= length(x); i++) n = n * 16 + index("0123456789abcdef", substr(x, i, 1)) - 1; return n }
    /^Linker script and memory map/ {on = 1}
    !on {next}
    /^ \.[^ ]+$/ {sec = $1; next}
    /^ \.[^ ]+ +0x/ {sec = $1; addr = $2; size = $3; file = $4}
    /^ +0x[0-9a-f]+ +0x[0-9a-f]+ +[^ ]+\.o$/ {addr = $1; size = $2; file = $3}
    /0x/ && file != "" {
      if ((sec ~ /^\.text/ || sec ~ /^\.rodata/) && file !~ /\.a\(/ && file !~ /\/crt[^\/]*\.o$/ &&
          file !~ /mcu_image\.o$/ && hex(addr) != 0) {
        total += hex(size)
      }
      file = ""
    }
    END {print total + 0}' "$dir/image.map")
}

build O2 -O2
o2_lib=$lib_bytes
o2_image=$image_bytes
build shipped "$SHIP"

defined=$("${CC%gcc}nm" --defined-only "${objs[@]}" | awk 'NF == 3 {print $3}' | sort -u)
undefined=$("${CC%gcc}nm" -u "${objs[@]}" | awk 'NF == 2 {print $2}' | sort -u)
allowed="sinf cosf tanf atan2f sqrtf floorf fabsf memset memcpy memmove"
bad=""
for sym in $undefined; do
  if grep -qx "$sym" <<<"$defined"; then continue; fi
  case " $allowed " in *" $sym "*) continue ;; esac
  bad="$bad $sym"
done
if [ -n "$bad" ]; then
  echo "check_mcu: FAILED: the library needs symbols outside math.h/string.h or double helpers:$bad" >&2
  exit 1
fi
calls=$(comm -23 <(tr ' ' '\n' <<<"$undefined") <(echo "$defined") | tr '\n' ' ')
echo "check_mcu: linked -O2 image (information): library $o2_lib bytes, image $o2_image bytes"
if [ "$lib_bytes" -gt "$LIMIT" ]; then
  echo "check_mcu: FAILED: the library's code in the linked -Os image is $lib_bytes bytes ($SHIP, the shipped build) (target <= $LIMIT)" >&2
  exit 1
fi
echo "check_mcu: Cortex-M4F float build OK: library $lib_bytes bytes of code in a linked -Os image (target <= $LIMIT; the shipped build, $SHIP; image $image_bytes bytes with the C runtime and libm), external calls: $calls"
