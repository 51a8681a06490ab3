"""The cost of ``ls_drive_step`` on the target (``make bench``; docs/firmware.md, "The cost on the target").

The processor-in-the-loop cases (tools/pil.py, the short set: the Fig. 13 trajectory's first 0.5 s
and a hold in every mode and injection shape) are replayed on the Cortex-M4F build (-O2, the
firmware flags, linked with newlib) under ``qemu-system-arm -M mps2-an386 -singlestep -d exec,nochain``:
one log line per executed instruction, streamed through a pipe into csrc/pil/pil_count.c, which
counts the Thumb-2 instructions from the entry of ls_drive_step to its return, step by step, and
prices each with the cycle model below (the instruction classes from the image's disassembly,
``arm-none-eabi-objdump``; a branch is taken when the next executed address is not the following
instruction). Beside them: the x86-64 instructions of the same steps (callgrind on the host build
of the same replay, -O2), and the library's code size (tools/check_mcu.sh).

Cycle model (Cortex-M4 TRM r0p1, "Processor instruction timings" and the FPU's table; zero-wait
memory, i.e. code in flash behind the STM32F4's ART accelerator, data in SRAM; pipeline stalls on
result dependencies not modelled), nominal and upper:
  data processing, MOV, compare, shifts, multiply (MUL, UMULL ...)       1
  MLA, MLS                                                              2
  SDIV, UDIV                                                            7, 12 (2 to 12)
  IT                                                                    0, 1 (folded or not)
  LDR (any size)                                                        2
  LDRD                                                                  3
  STR (any size)                                                        1, 2 (write buffer)
  STRD                                                                  2, 3
  LDM, STM, PUSH, POP                                                   1 + N registers
  branch (B, BL, BX, CBZ ...; POP and LDR to PC add it), taken          + 2, + 3 (pipeline refill P, 1 to 3)
  branch not taken                                                      1
  TBB, TBH                                                              2 + P
  VADD, VSUB, VMUL, VNMUL, VNEG, VABS, VCMP, VCVT, VMOV, VMRS           1 (VMOV of two core registers 2)
  VMLA, VMLS, VNMLA, VNMLS, VFMA, VFMS, VFNMA, VFNMS                     3
  VDIV, VSQRT                                                           14
  VLDR, VSTR                                                            2
  VLDM, VSTM, VPUSH, VPOP                                               1 + N single registers
The budget: at most 25 % of the 16 kHz period on a 168 MHz M4F, 2,625 cycles, in every
mode by the upper estimate (the worst step) of the build for speed (-O2, the firmware flags); the
library's code at most 32 kB in the shipped build (tools/check_mcu.sh's image, the toolchain file's
MinSizeRel: -Os -flto). Both builds are counted; the shipped build's cycles are printed for
information (no single build meets both budgets: docs/firmware.md, "The cost on the target").
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tools"))
import pil  # noqa: E402

F_CPU = 168e6  # Hz
F_PWM = 16e3  # Hz
BUDGET = 0.25 * F_CPU / F_PWM  # cycles, 2,625
JUDGED = "-O2"  # the build the cycle budget is judged on (the build for speed)
MODES = {0: "off", 1: "sensored", 2: "sensorless_lut", 3: "sensorless_nolut", 4: "calibration", 5: "startup",
         6: "commission"}

CONDS = ("eq", "ne", "cs", "cc", "hs", "lo", "mi", "pl", "vs", "vc", "hi", "ls", "ge", "lt", "gt", "le", "al")
BRANCH = {"b", "bl", "bx", "blx", "cbz", "cbnz"}
LOAD = {"ldr", "ldrb", "ldrh", "ldrsb", "ldrsh", "ldrex", "ldrt", "ldrbt", "ldrht"}
STORE = {"str", "strb", "strh", "strex", "strt", "strbt", "strht"}
MULTI_LOAD = {"pop", "ldm", "ldmia", "ldmdb", "ldmfd", "ldmea"}
MULTI_STORE = {"push", "stm", "stmia", "stmdb", "stmfd", "stmea"}
VFP3 = {"vmla", "vmls", "vnmla", "vnmls", "vfma", "vfms", "vfnma", "vfnms"}
VFP14 = {"vdiv", "vsqrt"}
VMULTI = {"vldm", "vldmia", "vldmdb", "vstm", "vstmia", "vstmdb", "vpush", "vpop"}
KNOWN = (BRANCH | LOAD | STORE | MULTI_LOAD | MULTI_STORE | VFP3 | VFP14 | VMULTI |
         {"ldrd", "strd", "tbb", "tbh", "mla", "mls", "sdiv", "udiv", "mul", "umull", "smull", "umlal",
          "smlal", "vldr", "vstr", "vmov", "vmrs", "vmsr", "vadd", "vsub", "vmul", "vnmul", "vneg", "vabs",
          "vcmp", "vcmpe", "vcvt", "it", "mov", "movs", "add", "adds", "sub", "subs", "cmp", "orr", "and",
          "nop", "teq", "tst"})


def base(mnemonic: str) -> str:
    """The instruction without its width (.w/.n), data type (.f32) and condition suffixes."""
    m = mnemonic.split(".")[0]
    if m.startswith("it") and set(m[2:]) <= {"t", "e"}:
        return "it"
    if m in KNOWN:
        return m
    if m[-2:] in CONDS and m[:-2] in KNOWN:
        return m[:-2]
    if m.endswith("s") and m[:-1] in KNOWN:
        return m[:-1]
    if m[-2:] in CONDS and m[:-2].endswith("s") and m[:-3] in KNOWN:
        return m[:-3]
    return m[:-2] if m[-2:] in CONDS and len(m) > 3 else m


def reg_count(ops: str) -> int:
    """Registers in a list such as ``{r4, r5, pc}`` or ``{d8-d9}`` (a d register counts two)."""
    body = ops[ops.find("{") + 1:ops.find("}")]
    n = 0
    for part in body.split(","):
        part = part.strip()
        k = 2 if part.startswith("d") else 1
        r = re.fullmatch(r"[rsd](\d+)-[rsd](\d+)", part)
        n += k * (int(r.group(2)) - int(r.group(1)) + 1) if r else k
    return n


def cost(mnemonic: str, ops: str) -> tuple[int, int, int, int]:
    """(base nominal, base upper, taken extra nominal, taken extra upper) cycles of one instruction."""
    b = base(mnemonic)
    to_pc = bool(re.match(r"\s*pc\b", ops)) or "pc}" in ops.replace(" ", "")
    p = (2, 3)
    if b in BRANCH:
        return 1, 1, *p
    if b in ("tbb", "tbh"):
        return 2, 2, *p
    if b in MULTI_LOAD or b in MULTI_STORE:
        n = 1 + reg_count(ops)
        return (n, n, *p) if to_pc else (n, n, 0, 0)
    if b in LOAD:
        return (2, 2, *p) if to_pc else (2, 2, 0, 0)
    if b == "ldrd":
        return 3, 3, 0, 0
    if b in STORE:
        return 1, 2, 0, 0
    if b == "strd":
        return 2, 3, 0, 0
    if b in ("mla", "mls"):
        return 2, 2, 0, 0
    if b in ("sdiv", "udiv"):
        return 7, 12, 0, 0
    if b == "it":
        return 0, 1, 0, 0
    if b in VFP14:
        return 14, 14, 0, 0
    if b in VFP3:
        return 3, 3, 0, 0
    if b in ("vldr", "vstr"):
        return 2, 2, 0, 0
    if b in VMULTI:
        n = 1 + reg_count(ops)
        return n, n, 0, 0
    if b == "vmov" and ops.count(",") >= 2:
        return 2, 2, 0, 0
    if b in ("add", "mov") and to_pc:  # (a computed jump)
        return 1, 1, *p
    return 1, 1, 0, 0


def klass(mnemonic: str) -> str:
    """The instruction's class in the breakdown of the cycles."""
    b = base(mnemonic)
    if b in VFP14:
        return "VDIV/VSQRT"
    if b in VFP3:
        return "FP multiply-add"
    if b in ("vldr", "vstr") or b in VMULTI:
        return "FP load/store"
    if b.startswith("v"):
        return "FP other"
    if b in LOAD or b == "ldrd":
        return "load"
    if b in STORE or b == "strd":
        return "store"
    if b in MULTI_LOAD or b in MULTI_STORE:
        return "load/store multiple"
    if b in BRANCH or b in ("tbb", "tbh"):
        return "branch"
    return "integer other"


#: address -> class and cost of the image last passed to cost_table
CLASSES: dict[int, str] = {}
COSTS: dict[int, tuple[int, int, int, int]] = {}


def cost_table(elf: Path, dest: Path) -> tuple[str, str]:
    """Write the cost of every instruction of ``elf`` (pil_count.c's COSTS); return the addresses of
    ls_drive_step and of the instruction after the replay's call of it (hex)."""
    dis = subprocess.run(["arm-none-eabi-objdump", "-d", str(elf)], check=True, capture_output=True,
                         text=True).stdout
    lines, entry, ret, after_call = [], None, None, False
    CLASSES.clear()
    COSTS.clear()
    for ln in dis.splitlines():
        m = re.match(r"^([0-9a-f]{8}) <(\w+)>:", ln)
        if m and m.group(2) == "ls_drive_step":
            entry = m.group(1).lstrip("0") or "0"
        m = re.match(r"^\s+([0-9a-f]+):\t([0-9a-f]{4})(?: ([0-9a-f]{4}))?\s*\t(\S+)\s*(.*)$", ln)
        if not m:
            continue
        addr, size = int(m.group(1), 16), 4 if m.group(3) else 2
        if after_call:
            ret, after_call = f"{addr:x}", False
        mn, ops = m.group(4), m.group(5)
        if mn == "bl" and ops.endswith("<ls_drive_step>"):
            if ret is not None:
                raise SystemExit("bench_pil: more than one call of ls_drive_step in the replay")
            after_call = True
        if mn.startswith("."):  # (literal pool data)
            continue
        COSTS[addr] = cost(mn, ops)
        lines.append(f"{addr:x} {size:x} " + " ".join(map(str, COSTS[addr])))
        CLASSES[addr] = klass(mn)
    if entry is None or ret is None:
        raise SystemExit("bench_pil: ls_drive_step or its call not found in the image")
    dest.write_text("\n".join(lines) + "\n")
    return entry, ret


def one_insn_per_tb() -> list[str]:
    """QEMU's option for one instruction per translation block: ``-singlestep`` up to 8.0,
    ``-accel tcg,one-insn-per-tb=on`` from 8.1 (where -singlestep is deprecated)."""
    v = subprocess.run(["qemu-system-arm", "--version"], capture_output=True, text=True).stdout
    m = re.search(r"version (\d+)\.(\d+)", v)
    new = m is not None and (int(m.group(1)), int(m.group(2))) >= (8, 1)
    return ["-accel", "tcg,one-insn-per-tb=on"] if new else ["-singlestep"]


def count_target(out: Path, elf: Path) -> np.ndarray:
    """(steps, 3): instructions, nominal and upper cycles of every ls_drive_step of the replay."""
    counter = out / "pil_count"
    subprocess.run([os.environ.get("CC", "cc"), "-std=c99", "-O2", str(pil.PIL / "pil_count.c"), "-o",
                    str(counter)], check=True)
    entry, ret = cost_table(elf, out / "costs.txt")
    with tempfile.TemporaryDirectory() as tmp:
        fifo = Path(tmp) / "exec.log"
        os.mkfifo(fifo)
        res = out / "counts.txt"
        with open(res, "w") as f, open(os.devnull, "w") as null:
            # (the counter opens the pipe for reading, QEMU for writing: each waits for the other)
            cnt = subprocess.Popen([str(counter), str(out / "costs.txt"), entry, ret, str(fifo),
                                    str(out / "hits.txt")], stdout=f)
            q = subprocess.Popen(pil.qemu_cmd(elf, *one_insn_per_tb(), "-d", "exec,nochain", "-D", str(fifo)),
                                 cwd=out, stdout=null)
            q.wait()
            cnt.wait()
        if q.returncode or cnt.returncode:
            raise SystemExit("bench_pil: the counting run failed")
    rows = res.read_text().split("\n")
    unknown = int(next(r for r in rows if r.startswith("unknown")).split()[1])
    if unknown:
        raise SystemExit(f"bench_pil: {unknown} executed instructions not in the image's disassembly")
    return np.array([[int(v) for v in r.split()] for r in rows if r and not r.startswith("unknown")])


def breakdown(out: Path) -> dict[str, tuple[float, float]]:
    """Share of the nominal cycles and of the instructions by class, over every counted step."""
    cyc: dict[str, float] = {}
    ins: dict[str, float] = {}
    for ln in (out / "hits.txt").read_text().split("\n"):
        if not ln:
            continue
        a, hits, taken = (int(v, 16) if i == 0 else int(v) for i, v in enumerate(ln.split()))
        k = CLASSES[a]
        bn, _, tn, _ = COSTS[a]
        cyc[k] = cyc.get(k, 0.0) + bn * hits + tn * taken
        ins[k] = ins.get(k, 0.0) + hits
    tc, ti = sum(cyc.values()), sum(ins.values())
    return {k: (100.0 * cyc[k] / tc, 100.0 * ins[k] / ti) for k in sorted(cyc, key=cyc.get, reverse=True)}


def count_x86(out: Path, exe: Path, name: str, steps: int) -> float | None:
    """x86-64 instructions per ls_drive_step of one case (callgrind), or None without valgrind."""
    if shutil.which("valgrind") is None:
        return None
    cg = out / f"callgrind.{name}.out"
    subprocess.run(["valgrind", "--tool=callgrind", "--toggle-collect=ls_drive_step",
                    f"--callgrind-out-file={cg}", str(exe), name], cwd=out, check=True, capture_output=True)
    total = next(int(ln.split()[1]) for ln in cg.read_text().splitlines()
                 if ln.startswith(("summary:", "totals:")))
    return total / steps


def code_size() -> tuple[int | None, int | None, int | None, bool]:
    """The library's code in the linked -Os and -O2 images, bytes, the target and whether the -Os
    figure is within it: tools/check_mcu.sh's figures and verdict (its LIMIT is the one target)."""
    r = subprocess.run([str(ROOT / "tools" / "check_mcu.sh"), str(ROOT / "build" / "arm")], cwd=ROOT,
                       capture_output=True, text=True)
    o2 = re.search(r"-O2 image \(information\): library (\d+) bytes", r.stdout)
    os_ = re.search(r"library (\d+) bytes of code in a linked -Os image", r.stdout + r.stderr) or \
        re.search(r"linked -Os image is (\d+) bytes", r.stderr)
    limit = re.search(r"-Os image.*\(target <= (\d+)", r.stdout + r.stderr)
    return ((int(os_.group(1)) if os_ else None), (int(o2.group(1)) if o2 else None),
            (int(limit.group(1)) if limit else None), r.returncode == 0)


def speed_phases(words: np.ndarray) -> list[tuple[str, np.ndarray]]:
    """The speed case's steps (tools/pil.py's :func:`~pil.speed_case`) by the SPEED step's phase.

    ``SPEED EMF idle``: the injection on and the estimated speed below ``0.9 FUSE_EMF_OFF v_lo``, the
    EMF estimate's filters idle (the sensorless step with the hand-over's bookkeeping). ``SPEED below
    band``: the injection on, the EMF estimate running, the speed below the design's
    ``handover_v_lo``. ``SPEED in band``: the injection on at or above it (the EMF's angle too).
    ``SPEED above band``: the injection faded out (the EMF alone, the HF chain idle). The injection
    counts as on where the step's HF voltage is not 0 within one injection period (16 steps at 1 kHz
    and 16 kHz) either side. The EMF starts at ``FUSE_EMF_ON v_lo`` and stops at ``FUSE_EMF_OFF
    v_lo``: a step between the two may be either, and counts as running (so does the step at the
    stop, hence the 0.9)."""
    from linsense.ctrl import FUSE_EMF_OFF

    v_lo = float(pil.speed_case(True)[1]["observer"]["handover_v_lo"])
    v_hf = words[:, [n for n, _ in pil.OUT_FIELDS].index("v_hf")].view("<f4")
    v_est = words[:, [n for n, _ in pil.OUT_FIELDS].index("v_est")].view("<f4")
    on = np.convolve((v_hf != 0).astype(float), np.ones(33), mode="same") > 0
    band = np.abs(v_est) >= v_lo
    idle = np.abs(v_est) < 0.9 * FUSE_EMF_OFF * v_lo  # (the step at the stop counted as running)
    return [("SPEED EMF idle", on & idle), ("SPEED below band", on & ~idle & ~band),
            ("SPEED in band", on & band), ("SPEED above band", ~on)]


def report(out: Path, names: list, elf: Path, host: Path, opt: str) -> bool:
    """Count the replay of ``elf`` (built at ``opt``) and print the table; True when every mode is
    within the budget."""
    counts = count_target(out, elf)
    if len(counts) != sum(n for _, n in names):
        raise SystemExit(f"bench_pil: {len(counts)} steps counted, {sum(n for _, n in names)} replayed")
    ok = True
    print(f"ls_drive_step on the Cortex-M4F (QEMU mps2-an386, {opt}, every step of the replay; cycles by "
          f"the model of tools/bench_pil.py, nominal/upper; budget {BUDGET:,.0f} cycles = 25 % of 16 kHz at "
          "168 MHz):")
    print(f"  {'case':16s} {'mode':17s} {'steps':>6s} {'M4F instr min/mean/max':>24s} "
          f"{'cycles nominal min/mean/max':>28s} {'upper max':>9s} {'% period':>8s} {'x86 instr':>9s}")
    k = 0
    for name, steps in names:
        c = counts[k:k + steps]
        k += steps
        mode = pil.read_out(out / f"{name}.m4f.out")[:, 5]
        x86 = count_x86(out, host, name, steps) if opt == "-O2" else None
        groups = [(MODES.get(int(m), m), mode == m) for m in sorted(set(mode.tolist()))]
        if name == "speed":
            groups = speed_phases(pil.read_out(out / f"{name}.m4f.out"))
        for label, pick in groups:
            sel = c[pick]
            if not len(sel):
                continue
            worst = int(sel[:, 2].max())
            pct = 100.0 * worst * F_PWM / F_CPU
            ok &= worst <= BUDGET
            print(f"  {name:16s} {label:17s} {len(sel):6d} "
                  f"{sel[:, 0].min():7d} {sel[:, 0].mean():7.0f} {sel[:, 0].max():7d}   "
                  f"{sel[:, 1].min():8d} {sel[:, 1].mean():8.0f} {sel[:, 1].max():8d}  {worst:9d} "
                  f"{pct:7.1f}% "
                  f"{'' if x86 is None else f'{x86:9.0f}'}")
    print("  where the nominal cycles go (share of cycles / of instructions, every step): "
          + ", ".join(f"{k} {c:.0f} % / {i:.0f} %" for k, (c, i) in breakdown(out).items()))
    top = int(counts[:, 2].max())
    verdict = f"for information, the budget is judged at {JUDGED}"
    if opt == JUDGED:
        verdict = "PASS" if ok else "FAIL"
    print(f"  worst step {top} cycles (upper) = {100 * top * F_PWM / F_CPU:.1f} % of the period: "
          f"{verdict} (target <= {BUDGET:,.0f})")
    return ok


def main() -> int:
    out = ROOT / "build" / "pil-bench"
    out.mkdir(parents=True, exist_ok=True)
    if shutil.which("qemu-system-arm") is None:
        print("bench_pil: qemu-system-arm not found (make tools installs it)")
        return 1
    t0 = time.time()
    names = pil.record(out, quick=True)
    host = pil.build_replay(out, "host", "host")
    ok = True
    for opt in ("-O2", pil.SHIPPED):
        elf = pil.build_replay(out, "m4f", "m4f", opt, harness_lto=False)
        ok &= report(out, names, elf, host, opt) or opt != JUDGED
    lib_os, lib_o2, limit, within = code_size()
    if lib_os is None:
        print("  code size: tools/check_mcu.sh gave no figure")
        ok = False
    else:
        ok &= within
        verdict = "PASS" if within else "FAIL"
        print(f"  library code: {lib_os} bytes in the shipped build, {pil.SHIPPED} (target <= {limit}: "
              f"{verdict}), "
              f"{lib_o2} bytes at -O2 (tools/check_mcu.sh's linked images)")
    print(f"bench_pil: {time.time() - t0:.0f} s")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
