"""``linsense fea``: geometry file -> FEA -> one output set (see docs/fea.md)."""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

from linsense.fea import outputs
from linsense.fea.geometry import load_geometry
from linsense.fea.solver import run


def _progress(k: int, n: int) -> None:
    sys.stderr.write(f"\rfea: position {k}/{n}")
    if k == n:
        sys.stderr.write("\n")
    sys.stderr.flush()


def run_fea(spec: str, out: str, positions: int = 56, level: str = "default", lut_points: int = 360,
            progress: bool = False, load_current: float = 0.0, workers: int = 1):
    """Solve and write the output set; return (written files, summary lines, warnings)."""
    from linsense.analysis.summary import summarize
    from linsense.compensation.lut import build_lut, to_csv
    from linsense.errors import InputError, ModelError
    from linsense.io import output_set
    from linsense.model.motor import load_motor
    from linsense.report.figures import fig_inductances, fig_lut, png_bytes

    g = load_geometry(spec)
    if not math.isfinite(load_current) or abs(load_current) > 1e6:
        raise InputError("--load-current", "", f"must be a finite current in A, got {load_current!r}")
    if load_current and g.bh_rod is None and g.bh_arm is None:
        raise InputError("--load-current", "", f"{g.source} has linear iron: the incremental inductances do "
                         "not depend on the load (give rod.bh or armature.bh, a B-H curve)")
    warnings: list[str] = []
    with output_set(out, "fea") as s:
        res = run(g, positions, level, progress=_progress if progress else None, load_current=load_current,
                  workers=workers)
        s.write("inductances.csv", outputs.inductances_csv(res))
        s.write("motor.toml", outputs.motor_toml(res))
        fit = outputs.eq3_fit(res)
        try:
            motor = load_motor(s.path("motor.toml"))
        except ModelError as exc:  # a valid table, but no HF sensorless control with it
            motor = None
            shown = str(exc).replace(str(s.path("motor.toml")), str(Path(out) / "motor.toml"))
            warnings.append(f"{shown}; motor.toml is written but does not pass load_motor's checks, "
                            "no lut.csv")
        summ = summarize(motor) if motor is not None else None
        hf = {"ok": motor is not None, "problem": None if motor is not None else warnings[0]}
        s.write("geometry.json", json.dumps(g.regions(), indent=2) + "\n")
        s.write("fea.json", outputs.fea_json(res, {"eq3_fit": fit, "hf_sensorless": hf, "summary": summ}))
        s.write("field_lines.png", png_bytes(outputs.fig_field(res)))
        s.write("inductances_fea.png", png_bytes(outputs.fig_table(res)))
        if motor is not None:
            lut = build_lut(motor, lut_points)
            s.write("lut.csv", to_csv(lut))
            fig = fig_inductances(motor, f"{g.name}: table model (ABC, dq)")
            s.write("inductances_model.png", png_bytes(fig))
            s.write("lut.png", png_bytes(fig_lut(motor, lut)))
    v = fit["values_H"]
    names = ("L0", "L2", "M0", "M2", "dM0")
    lines = [
        f"{g.name}: {res.mesh.mesh.t.shape[1]} triangles, {res.keep['solver'].ndofs} dofs, "
        f"{positions} positions in {res.times['solve_s']:.1f} s"
        + (f", Newton iterations max {res.newton['max']}, mean {res.newton['mean']:.1f}, load "
           f"{res.load_current:g} A" if res.newton else ""),
        "eq. 3 fit: " + ", ".join(f"{k} {v[k] * 1e3:.3f} mH" for k in names if k in v),
        f"psi_pm {res.psi_pm_amplitude:.4f} Wb, force constant {outputs.force_constant(res) or 0:.2f} N/A",
    ]
    if summ is not None:
        sal = summ["saliency_range_H"]
        lines[-1] += (f", saliency {sal[0] * 1e3:.3f} .. {sal[1] * 1e3:.3f} mH, "
                      f"Psi_LUT peak {summ['psi_lut_peak_deg']:.2f} deg")
    return s.files, lines, warnings
