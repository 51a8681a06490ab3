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
pil_closed = _load("pil_closed")


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


@pytest.mark.parametrize("target", ["m4f", "m4f_os"])
@pytest.mark.parametrize("field", ["duty_a", "fault", "pos_est.period", "pos_est.theta", "psi_cal"])
def test_compare_fails_on_one_bit_of_one_output(tmp_path, field, target, capsys):
    """Any output of either target build, floats included, one bit off in one step: a failure."""
    ref = _outputs(50)
    tags = ("sim", *pil.REPLAYS)
    _write_case(tmp_path, "c", {t: ref for t in tags})
    assert pil.compare(tmp_path, [("c", 50)])
    capsys.readouterr()
    bad = ref.copy()
    j = [n for n, _ in pil.OUT_FIELDS].index(field)
    bad[17, j] ^= 1  # the last bit of one word of one step
    _write_case(tmp_path, "c", {**{t: ref for t in tags}, target: bad})
    assert not pil.compare(tmp_path, [("c", 50)])
    out = capsys.readouterr().out
    assert "1 steps differ" in out
    largest = out.split("largest |target - host| per output")[1]
    assert f" {field} 0," not in largest and f" {field} 0\n" not in largest  # (its difference printed)


def test_compare_fails_on_a_sign_of_zero(tmp_path):
    """-0 against +0 differs by 0 in value but not in bits: a failure (bit for bit, not a tolerance)."""
    ref = _outputs(10)
    ref[:, 0] = np.float32(0.0).view("<u4")
    neg = ref.copy()
    neg[4, 0] = np.float32(-0.0).view("<u4")
    _write_case(tmp_path, "c", {**{t: ref for t in ("sim", *pil.REPLAYS)}, "m4f": neg})
    assert not pil.compare(tmp_path, [("c", 10)])


def test_the_replays_are_the_host_and_the_target_at_two_optimisations():
    assert pil.REPLAYS == {"host": ("host", "-O2"), "m4f": ("m4f", "-O2"), "m4f_os": ("m4f", pil.SHIPPED)}
    assert pil.SHIPPED.split()[0] == "-Os" and "-flto" in pil.SHIPPED.split()  # (the toolchain file's)
    assert pil.TARGETS == ["m4f", "m4f_os"] and pil.BOUND == 0.0


def test_compare_fails_on_an_incomplete_recording_or_a_short_replay(tmp_path):
    ref = _outputs(30)
    other = ref.copy()
    other[3, 0] ^= 4
    _write_case(tmp_path, "c", {"sim": other, **{t: ref for t in pil.REPLAYS}})
    assert not pil.compare(tmp_path, [("c", 30)])  # the host replay is not the closed loop's steps
    for t in pil.TARGETS:
        _write_case(tmp_path, "c", {"sim": ref, **{u: ref for u in pil.REPLAYS}, t: ref[:-1]})
        assert not pil.compare(tmp_path, [("c", 30)])


def test_compare_accepts_nan_payloads_only(tmp_path):
    """NaN equals NaN whatever its payload (x86's default NaN is negative, the M4F's positive)."""
    ref = _outputs(10)
    ref[2, 0] = np.float32(np.nan).view("<u4")
    other = ref.copy()
    other[2, 0] = np.uint32(0xFFC00000)
    _write_case(tmp_path, "c", {**{t: ref for t in ("sim", *pil.REPLAYS)}, "m4f_os": other})
    assert pil.compare(tmp_path, [("c", 10)])
    other[2, 0] = np.float32(1.0).view("<u4")  # a NaN against a number: a failure
    _write_case(tmp_path, "c", {**{t: ref for t in ("sim", *pil.REPLAYS)}, "m4f_os": other})
    assert not pil.compare(tmp_path, [("c", 10)])


def test_closed_loop_metrics_must_match_bit_for_bit():
    """tools/pil_closed.py: every metric but the timing compared; -0 is not +0, NaN is NaN."""
    host = {"bias_deg": 0.25, "final_error_mm": 0.0, "samples": 16000, "stable": True, "fault": "none",
            "settling_time_s": None, "limit_cycle_deg": float("nan"), "wall_s": 1.0, "realtime_factor": 2.0}
    same = {**host, "wall_s": 3.0, "realtime_factor": 0.5}
    assert pil_closed.metric_differences(same, host) == ({}, {})
    d, m = pil_closed.metric_differences({**same, "bias_deg": np.nextafter(0.25, 1.0), "final_error_mm": -0.0,
                                          "stable": False}, host)
    assert set(d) == {"bias_deg", "final_error_mm"} and d["final_error_mm"] == 0.0 and d["bias_deg"] > 0
    assert m == {"stable": [False, True]}
    _, m = pil_closed.metric_differences({k: v for k, v in same.items() if k != "fault"}, host)
    assert m == {"fault": [None, "none"]}


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
