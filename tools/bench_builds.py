"""Candidate single builds of the firmware against both budgets (docs/firmware.md, "The cost
on the target", its table of builds).

For each candidate (:data:`CANDIDATES`: the optimisation options of every file of csrc/ctrl/, or of
the step's hot files and the others apart; link-time optimisation; the shared layout of the step's
pieces, ``-DLS_DRIVE_SHARED_PARTS``), with the firmware flags of the toolchain file (tools/pil.py
reads them) and ``-ffp-contract=off``:

* size: tools/mcu_image.c linked with the library as tools/check_mcu.sh links it; the image's text
  and the library's share (every ``.text*``/``.rodata*`` input section of the linker map that is
  neither the image's own object, compiled without LTO, nor newlib's or libgcc's);
* cycles: the replay of tools/pil.py's short set (recorded once) on that build under QEMU, priced by
  tools/bench_pil.py's model (the harness compiled without LTO, so that the replay calls
  ``ls_drive_step``); the worst step by the upper estimate;
* bit for bit: the replay's outputs against the closed loop's own, every output of every step.

With ``--profile N``, each candidate's N costliest functions of the step (nominal cycles and
instructions per replayed step, the mean over every step; :func:`profile`): where a layout spends its
cycles, piece by piece (docs/firmware.md, "The cost on the target").

Usage: ``python tools/bench_builds.py [NAME ...] [--size-only] [--profile N]`` (every candidate
without names); about 3 minutes per candidate's cycles. Prints one line per candidate; exit 1 when a
replay differs.
"""

from __future__ import annotations

import argparse
import bisect
import re
import subprocess
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tools"))
import bench_pil  # noqa: E402
import pil  # noqa: E402

CTRL = ROOT / "csrc" / "ctrl"
#: the files the step runs through (its modes' steps, their pieces, the per-step functions the
#: headers do not inline); the others are initialisation and configuration
HOT = ("ls_drive_parts", "ls_drive_sensorless", "ls_drive_speed", "ls_emf", "ls_drive_sensored",
       "ls_drive_calibration", "ls_drive_rotating", "ls_drive_square", "ls_drive_startup", "ls_drive_off",
       "ls_dtres", "ls_traj", "ls_lut", "ls_startup", "ls_pos", "ls_math")
SHARED = "-DLS_DRIVE_SHARED_PARTS"
#: name -> (options of the cold files, of the hot files (:data:`HOT`), of the link)
CANDIDATES = {
    "O2": ("-O2", "-O2", "-O2"),
    "Os": ("-Os", "-Os", "-Os"),
    "O2-lto": ("-O2 -flto", "-O2 -flto", "-O2 -flto"),
    "Os-lto": ("-Os -flto", "-Os -flto", "-Os -flto"),
    "O2-shared": (f"-O2 {SHARED}", f"-O2 {SHARED}", "-O2"),
    "O2-shared-lto": (f"-O2 -flto {SHARED}", f"-O2 -flto {SHARED}", "-O2 -flto"),
    "Os-cold-O2-hot": ("-Os", "-O2", "-Os"),
    "Os-cold-O2-hot-lto": ("-Os -flto", "-O2 -flto", "-O2 -flto"),
}
WARN = [*pil.WARN, "-Wconversion"]
#: the size target, from its one home (tools/check_mcu.sh's LIMIT)
LIMIT = int(re.search(r"^LIMIT=(\d+)", (ROOT / "tools" / "check_mcu.sh").read_text(), re.M).group(1))
RUNTIME = re.compile(r"(\.a\(|/crt[^/]*\.o$|mcu_image\.o$|pil_(replay|io_semihost)\.o$|startup_m4\.o$)")


def compile_lib(out: Path, cand: tuple[str, str, str], inc: list[str]) -> list[str]:
    """The library's objects of one candidate in ``out``."""
    cold, hot, _ = cand
    objs = []
    for src in sorted(CTRL.glob("*.c")):
        obj = out / f"{src.stem}.o"
        opts = (hot if src.stem in HOT else cold).split()
        subprocess.run(["arm-none-eabi-gcc", *WARN, *pil.ARM, "-ffp-contract=off", *opts, *inc, "-c",
                        str(src), "-o", str(obj)], check=True)
        objs.append(str(obj))
    return objs


def library_bytes(mapfile: Path) -> int:
    """The ``.text*`` and ``.rodata*`` input sections of the map that are the library's (not the
    image's or harness's own objects, not an archive member, not the C runtime's start files)."""
    total, on, sec = 0, False, ""
    for ln in mapfile.read_text().splitlines():
        if ln.startswith("Linker script and memory map"):
            on = True
        if not on:
            continue
        m = re.match(r"^ (\.\S+)$", ln)
        if m:
            sec = m.group(1)
            continue
        m = re.match(r"^ (\.\S+)?\s+0x([0-9a-f]+)\s+0x([0-9a-f]+)\s+(\S+\.o\)?)$", ln)
        if not m:
            continue
        sec = m.group(1) or sec
        if sec.startswith((".text", ".rodata")) and int(m.group(2), 16) and not RUNTIME.search(m.group(4)):
            total += int(m.group(3), 16)
    return total


def size(out: Path, cand: tuple[str, str, str]) -> tuple[int, int]:
    """(image text, library bytes) of tools/mcu_image.c linked with the candidate's library."""
    inc = [f"-I{ROOT / 'csrc/include'}"]
    objs = compile_lib(out, cand, inc)
    img = out / "mcu_image.o"
    subprocess.run(["arm-none-eabi-gcc", *WARN, *pil.ARM, *cand[0].split(), "-fno-lto", *inc, "-c",
                    str(ROOT / "tools" / "mcu_image.c"), "-o", str(img)], check=True)
    elf, mapfile = out / "image.elf", out / "image.map"
    subprocess.run(["arm-none-eabi-gcc", *pil.ARM, "-ffp-contract=off", *cand[2].split(), *pil.ARM_LINK,
                    f"-Wl,-Map={mapfile}", str(img), *objs, "-lm", "-o", str(elf)], check=True)
    text = int(subprocess.run(["arm-none-eabi-size", str(elf)], check=True, capture_output=True,
                              text=True).stdout.splitlines()[1].split()[0])
    return text, library_bytes(mapfile)


def cycles(out: Path, rec: Path, names: list[tuple[str, int]],
           cand: tuple[str, str, str]) -> tuple[int, bool]:
    """(worst step's upper cycles, bit for bit) of the candidate's replay of the recorded cases."""
    for f in [*rec.glob("*.in"), rec / "pil_cases.h"]:
        (out / f.name).write_bytes(f.read_bytes())
    inc = [f"-I{ROOT / 'csrc/include'}", f"-I{pil.PIL}", f"-I{out}", '-DPIL_TAG="m4f"', "-DPIL_TARGET"]
    objs = compile_lib(out, cand, inc)
    for s in ("pil_replay.c", "pil_io_semihost.c", "startup_m4.c"):
        obj = out / f"{s[:-2]}.o"
        subprocess.run(["arm-none-eabi-gcc", *pil.WARN, *pil.ARM, "-ffp-contract=off", "-O2", "-fno-lto",
                        *inc, "-c", str(pil.PIL / s), "-o", str(obj)], check=True)
        objs.append(str(obj))
    elf = out / "pil_replay_m4f.elf"
    subprocess.run(["arm-none-eabi-gcc", *pil.ARM, "-ffp-contract=off", *cand[2].split(), *objs,
                    "-nostartfiles", *pil.ARM_LINK, f"-T{pil.PIL / 'mps2_an386.ld'}", "-lm", "-o", str(elf)],
                   check=True)
    subprocess.run(pil.qemu_cmd(elf), cwd=out, check=True, timeout=900, stdout=subprocess.DEVNULL)
    same = all(np.array_equal(pil.read_out(out / f"{n}.m4f.out"), pil.read_out(rec / f"{n}.sim.out"))
               for n, _ in names)
    counts = bench_pil.count_target(out, elf)
    if len(counts) != sum(n for _, n in names):
        raise SystemExit(f"bench_builds: {len(counts)} steps counted, {sum(n for _, n in names)} replayed")
    return int(counts[:, 2].max()), same


def profile(out: Path, elf: Path, steps: int) -> list[tuple[str, float, float]]:
    """(function, nominal cycles, instructions) per replayed step of the image's functions that the
    steps ran, costliest first: the executions of tools/bench_pil.py's count (``hits.txt``, written
    by :func:`cycles`) priced by its model (its ``COSTS``), each instruction given to the function
    symbol that holds it."""
    syms = []
    nm = subprocess.run(["arm-none-eabi-nm", "-S", str(elf)], check=True, capture_output=True, text=True)
    for ln in nm.stdout.splitlines():
        f = ln.split()
        if len(f) == 4 and f[2] in "tTW":
            syms.append((int(f[0], 16) & ~1, int(f[1], 16), f[3]))
    syms.sort()
    starts = [a for a, _, _ in syms]
    tot: dict[str, list[float]] = {}
    for ln in (out / "hits.txt").read_text().split("\n"):
        if not ln:
            continue
        a, hits, taken = (int(v, 16) if i == 0 else int(v) for i, v in enumerate(ln.split()))
        i = bisect.bisect_right(starts, a) - 1
        name = syms[i][2] if i >= 0 and a < syms[i][0] + syms[i][1] else "?"
        bn, _, tn, _ = bench_pil.COSTS[a]
        acc = tot.setdefault(name, [0.0, 0.0])
        acc[0] += (bn * hits + tn * taken) / steps
        acc[1] += hits / steps
    return sorted(((k, c, n) for k, (c, n) in tot.items()), key=lambda r: -r[1])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("names", nargs="*", help=f"candidates (default all: {', '.join(CANDIDATES)})")
    ap.add_argument("--size-only", action="store_true")
    ap.add_argument("--profile", type=int, default=0, metavar="N",
                    help="print each candidate's N costliest functions per step")
    a = ap.parse_args(argv)
    unknown = [n for n in a.names if n not in CANDIDATES]
    if unknown:
        ap.error(f"unknown candidates {unknown}; known: {', '.join(CANDIDATES)}")
    base = ROOT / "build" / "builds"
    rec = base / "record"
    rec.mkdir(parents=True, exist_ok=True)
    names = [] if a.size_only else pil.record(rec, quick=True)
    ok = True
    for name in a.names or list(CANDIDATES):
        cand = CANDIDATES[name]
        out = base / name
        out.mkdir(parents=True, exist_ok=True)
        text, lib = size(out, cand)
        line = f"bench_builds: {name:20s} image text {text:6d} bytes, library {lib:6d} bytes"
        if not a.size_only:
            worst, same = cycles(out, rec, names, cand)
            ok &= same
            pct = 100 * worst * bench_pil.F_PWM / bench_pil.F_CPU
            line += (f", worst step {worst} cycles (upper) = {pct:.1f} % of the period, "
                     f"{'bit for bit' if same else 'DIFFERS from the host'}")
        print(line, flush=True)
        if a.profile and not a.size_only:
            steps = sum(n for _, n in names)
            for fn, cyc, ins in profile(out, out / "pil_replay_m4f.elf", steps)[:a.profile]:
                print(f"bench_builds:   {fn:40s} {cyc:7.1f} cycles, {ins:7.1f} instructions per step "
                      "(nominal, mean)")
    print(f"bench_builds: budgets: library <= {LIMIT} bytes (tools/check_mcu.sh), worst step <= "
          f"{bench_pil.BUDGET:,.0f} cycles (tools/bench_pil.py)")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
