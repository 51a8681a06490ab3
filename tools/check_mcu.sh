#!/usr/bin/env bash
# Cross-compile the controller library for a Cortex-M4F (float build) with the firmware flags,
# print its code size, and fail if it calls anything but the allowed libc/libm functions or
# contains double-precision operations (soft-double helpers __aeabi_d*, __aeabi_f2d ...).
set -euo pipefail
CC=${ARM_CC:-arm-none-eabi-gcc}
OUT=${1:-build/arm}
FLAGS="-std=c99 -Wall -Wextra -Wpedantic -Werror -Wdouble-promotion -Wconversion -Wshadow
       -mcpu=cortex-m4 -mthumb -mfpu=fpv4-sp-d16 -mfloat-abi=hard -O2 -ffunction-sections -fdata-sections"
mkdir -p "$OUT"
objs=()
for src in csrc/ctrl/*.c; do
  obj="$OUT/$(basename "$src" .c).o"
  # shellcheck disable=SC2086
  $CC $FLAGS -Icsrc/include -c "$src" -o "$obj"
  objs+=("$obj")
done
"${CC%gcc}size" -t "${objs[@]}" | tee "$OUT/size.txt"
text=$(awk '/TOTALS/ {print $1}' "$OUT/size.txt")
defined=$("${CC%gcc}nm" --defined-only "${objs[@]}" | awk 'NF == 3 {print $3}' | sort -u)
undefined=$("${CC%gcc}nm" -u "${objs[@]}" | awk 'NF == 2 {print $2}' | sort -u)
allowed="sinf cosf tanf atan2f sqrtf floorf fabsf expf memset memcpy memmove"
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
echo "check_mcu: Cortex-M4F float build OK: text $text bytes, external calls: $(comm -23 <(tr ' ' '\n' <<<"$undefined") <(echo "$defined") | tr '\n' ' ')"
