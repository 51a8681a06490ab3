"""The processor-in-the-loop tools (tools/pil.py, tools/bench_pil.py, tools/pil_cgen.py).

``make pil`` (in ``make test``) runs the replay itself on the target under QEMU; these tests check,
without QEMU, that its comparison fails on any difference it must catch, that the drive's C
initializer is exact, and the cycle model's classes.
"""

from __future__ import annotations

import importlib.util
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]


def _load(name: str):
    sys.path.insert(0, str(ROOT / "tools"))
    try:
        spec = importlib.util.spec_from_file_location(name, ROOT / "tools" / f"{name}.py")
        mod = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(mod)
        return mod
    finally:
        sys.path.remove(str(ROOT / "tools"))


pil = _load("pil")
bench_pil = _load("bench_pil")
pil_cgen = _load("pil_cgen")


def _outputs(steps: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    a = np.zeros((steps, len(pil.OUT_FIELDS)), dtype="<u4")
    for j, (_, kind) in enumerate(pil.OUT_FIELDS):
        if kind == "f":
            a[:, j] = rng.standard_normal(steps).astype("<f4").view("<u4")
        else:
            a[:, j] = rng.integers(0, 3, steps)
    return a


def _write_case(tmp: Path, name: str, arrays: dict) -> None:
    for tag, a in arrays.items():
        a.tofile(tmp / f"{name}.{tag}.out")


@pytest.mark.parametrize("field", ["duty_a", "fault", "pos_est.period", "psi_cal"])
def test_compare_fails_on_one_bit_of_one_output(tmp_path, field, capsys):
    ref = _outputs(50)
    tags = ("sim", *pil.REPLAYS)
    _write_case(tmp_path, "c", {t: ref for t in tags})
    assert pil.compare(tmp_path, [("c", 50)])
    bad = ref.copy()
    j = [n for n, _ in pil.OUT_FIELDS].index(field)
    bad[17, j] ^= 1  # the last bit of one word of one step
    _write_case(tmp_path, "c", {**{t: ref for t in tags}, "m4f_c": bad})
    assert not pil.compare(tmp_path, [("c", 50)])
    assert "1 steps differ" in capsys.readouterr().out


def test_compare_fails_on_an_incomplete_recording_or_a_short_replay(tmp_path):
    ref = _outputs(30)
    other = ref.copy()
    other[3, 0] ^= 4
    _write_case(tmp_path, "c", {"sim": other, **{t: ref for t in pil.REPLAYS}})
    assert not pil.compare(tmp_path, [("c", 30)])  # the host replay is not the closed loop's steps
    _write_case(tmp_path, "c", {"sim": ref, **{t: ref for t in pil.REPLAYS}, "m4f": ref[:-1]})
    assert not pil.compare(tmp_path, [("c", 30)])


def test_compare_reports_but_accepts_float_differences_of_the_libms(tmp_path):
    ref = _outputs(20)
    libm = ref.copy()
    libm[5, 0] ^= 1  # a float output: reported, not a failure
    _write_case(tmp_path, "c", {**{t: ref for t in ("sim", *pil.REPLAYS)}, "m4f": libm})
    assert pil.compare(tmp_path, [("c", 20)])
    libm[5, 4] ^= 1  # the fault bits: a failure
    _write_case(tmp_path, "c", {**{t: ref for t in ("sim", *pil.REPLAYS)}, "m4f": libm})
    assert not pil.compare(tmp_path, [("c", 20)])


def test_differences_treat_nan_as_equal_and_measure_floats():
    a = _outputs(4)
    b = a.copy()
    a[0, 0] = np.float32(np.nan).view("<u4")
    b[0, 0] = np.uint32(0xFFC00000)  # another NaN (x86's default NaN)
    b[1, 1] = np.float32(a[1, 1].view("<f4") + np.float32(0.25)).view("<u4")
    d = pil.differences(a, b)
    assert d["duty_a"] == (0.0, 0)
    assert d["duty_b"][1] == 1 and d["duty_b"][0] == pytest.approx(0.25, rel=1e-6)


@pytest.mark.skipif(shutil.which("cc") is None, reason="no C compiler")
def test_the_drive_initializer_is_exact(tmp_path):
    """Every field of a built drive written as C and read back in C: the same bits."""
    from linsense._ctrl import ffi

    from linsense.sim.build import build

    b = build(pil._scenario(dict(pil.cases(quick=True))["lut_pulsating"]))
    w = pil_cgen.DriveWriter(ffi, "t")
    src = tmp_path / "t.c"
    # the C program prints the fields pil_cgen walks, in its order, as bits
    walk = []

    def leaves(ctype, expr):
        if ctype.kind == "struct":
            for n, f in ctype.fields:
                leaves(f.type, f"{expr}.{n}")
        elif ctype.kind == "array":
            for k in range(ctype.length):
                leaves(ctype.item, f"{expr}[{k}]")
        elif ctype.kind != "pointer":
            walk.append((expr, ctype.cname))

    leaves(ffi.typeof("ls_drive"), "d")
    prints = "\n".join(
        f'    {{ float f = (float){e}; uint32_t u; memcpy(&u, &f, 4); printf("%08x\\n", u); }}'
        if c in ("float", "double") else f'    printf("%lld\\n", (long long){e});' for e, c in walk)
    src.write_text('#include <stdio.h>\n#include <string.h>\n#include "linsense/ls_drive.h"\n'
                   'typedef struct { const char *name; const ls_drive *drive0; } pil_case;\n'
                   + w.drive(b.drive.state) + "\nint main(void)\n{\n    const ls_drive d = t_drive;\n"
                   + prints + "\n    return 0;\n}\n")
    exe = tmp_path / "t"
    subprocess.run(["cc", "-std=c99", f"-I{ROOT / 'csrc/include'}", str(src), "-o", str(exe)], check=True)
    got = subprocess.run([str(exe)], check=True, capture_output=True, text=True).stdout.split()
    want = []
    for e, c in walk:
        v = eval(e.replace("d.", "b.drive.state[0].", 1), {"b": b})  # noqa: S307 (field paths built above)
        want.append(f"{np.float32(v).view('<u4'):08x}" if c in ("float", "double") else str(int(v)))
    assert got == want


@pytest.mark.parametrize(("insn", "ops", "expected"), [
    ("vdiv.f32", "s0, s1, s2", (14, 14, 0, 0)),
    ("vsqrtpl.f32", "s0, s1", (14, 14, 0, 0)),
    ("vmla.f32", "s0, s1, s2", (3, 3, 0, 0)),
    ("vmul.f32", "s0, s1, s2", (1, 1, 0, 0)),
    ("vldr", "s15, [r3, #4]", (2, 2, 0, 0)),
    ("vpush", "{d8-d9}", (5, 5, 0, 0)),
    ("ldr.w", "r3, [r0, #8]", (2, 2, 0, 0)),
    ("ldrbne.w", "r3, [r0, #8]", (2, 2, 0, 0)),
    ("str", "r3, [r0]", (1, 2, 0, 0)),
    ("bne.n", "944 <x>", (1, 1, 2, 3)),
    ("bls.w", "944 <x>", (1, 1, 2, 3)),
    ("bl", "944 <ls_drive_step>", (1, 1, 2, 3)),
    ("cbz", "r2, 974 <x>", (1, 1, 2, 3)),
    ("pop", "{r4, r5, r6, pc}", (5, 5, 2, 3)),
    ("push", "{r4, r5, r6, lr}", (5, 5, 0, 0)),
    ("ite", "gt", (0, 1, 0, 0)),
    ("movs", "r0, #1", (1, 1, 0, 0)),
    ("mla", "r0, r1, r2, r3", (2, 2, 0, 0)),
])
def test_cycle_model(insn, ops, expected):
    assert bench_pil.cost(insn, ops) == expected
