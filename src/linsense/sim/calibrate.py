"""The firmware's LUT calibration (paper Fig. 9) run in the simulator: ``linsense calibrate``.

At each of ``positions`` points over one electrical period the drive moves there under encoder
control, settles, then injects and demodulates on the encoder angle and integrates the
compensation angle until the mean demodulated error (the sensorless observer's error against the
encoder) over a window vanishes (``LS_MODE_CALIBRATION``, docs/firmware.md). A small q-current
dither sweeps the phase currents through zero meanwhile, so that the inverter's dead time averages
out instead of biasing the table at no load (docs/simulator.md). The measured table is compared
with the model's: the resistance-aware LUT for the same injection, and the paper's eq. (12).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from linsense.analysis.hf import psi_lut, psi_lut_resistive
from linsense.model.motor import Motor
from linsense.sim.build import build
from linsense.sim.core import run_closed_loop
from linsense.sim.metrics import fault_reason
from linsense.sim.scenario import scenario_from_dict

#: simulated-time budget per point (s) beyond the move and the settling: the drive's own t_max trips
#: an unconverged point long before
_BUDGET_PER_POINT = 1.5


@dataclass
class Calibration:
    """A measured compensation table and how it compares with the model (angles in rad)."""

    theta: np.ndarray  # rad, table positions, 2 pi k / points
    psi_measured: np.ndarray  # rad, the calibration's table (NaN where not reached)
    psi_model: np.ndarray  # rad, the model LUT with R_s for the same injection
    psi_eq12: np.ndarray  # rad, paper eq. (12)
    metrics: dict = field(default_factory=dict)

    @property
    def completed(self) -> bool:
        return bool(self.metrics.get("completed"))


def calibrate(
    motor: Motor | str,
    positions: int = 56,
    load: float = 0.0,
    fidelity: str = "switching",
    quad: float = 0.0,
    source: str = "<calibrate>",
    **sections,
) -> Calibration:
    """Run the calibration on ``motor`` (a Motor, a preset name or a motor-file path).

    Parameters
    ----------
    positions : points over one electrical period (the paper: 56).
    load : N, constant load opposing positive motion (the drive starts balanced against it).
    fidelity : inverter model, ``"switching"`` (default) or ``"average"``.
    quad : the injection's q-axis share kappa; 0 (default) is the paper's pulsating injection,
        with which the table is three times stiffer (docs/theory.md).
    sections : further scenario sections (e.g. ``inverter={"dead_time": 0.0}``).
    """
    spec = motor if isinstance(motor, str) else None
    data = {
        "motor": spec or "ecce2010",
        "scenario": {"name": "calibrate", "duration": 1.0},
        "inverter": {"fidelity": fidelity},
        "control": {"mode": "calibration"},
        "injection": {"quadrature": float(quad)},
        "reference": {"type": "hold"},
        "load": {"force": float(load)},
        "initial": {"load_balanced": True},
        "calibration": {"points": int(positions)},
        "record": {"decimate": 16},
    }
    for sec, vals in sections.items():
        data.setdefault(sec, {}).update(vals)
    sc = scenario_from_dict(data, source)
    cal = sc.spec.calibration
    per_point = _BUDGET_PER_POINT + cal.t_settle
    sc = sc.replace(scenario={"duration": positions * per_point})
    b = build(sc, None if spec is not None else motor)
    raw = run_closed_loop(b.cfg, b.drive.state, b.n_steps, b.commands)
    done = int(b.drive.state.cal_index)
    table = np.array([b.extra["cal_table"][k] for k in range(positions)], dtype=float)
    table[done:] = np.nan
    m = b.motor
    theta = 2.0 * np.pi * np.arange(positions) / positions
    f_inj = sc.spec.injection.frequency
    model = psi_lut_resistive(m, theta, f_inj, quad=float(quad))
    eq12 = psi_lut(m, theta)
    ok = np.isfinite(table)
    metrics = {
        "completed": bool(done == positions and raw.fault == 0),
        "points": int(positions),
        "points_done": done,
        "max_diff_deg": _max_deg(table[ok] - model[ok]),
        "max_diff_eq12_deg": _max_deg(table[ok] - eq12[ok]),
        "load_n": float(load),
        "fidelity": fidelity,
        "f_inj_hz": float(f_inj),
        "injection_quad": float(quad),
        "dead_time_s": float(sc.spec.inverter.dead_time),
        "saturated": bool(sc.spec.saturation.enabled),
        "fault": fault_reason(raw.fault),
        "sim_s": round(raw.steps_done / sc.spec.inverter.f_pwm, 6),
        "wall_s": round(raw.wall_s, 6),
        "motor": m.name,
    }
    return Calibration(theta, table, model, eq12, metrics)


def _max_deg(d: np.ndarray) -> float | None:
    return round(float(np.degrees(np.max(np.abs(d)))), 6) if d.size else None


def lut_csv(cal: Calibration) -> str:
    """``theta_deg,psi_lut_deg`` rows of the measured table (the points reached)."""
    lines = ["theta_deg,psi_lut_deg"]
    for th, p in zip(np.degrees(cal.theta), np.degrees(cal.psi_measured), strict=True):
        if math.isfinite(p):
            lines.append(f"{th:.6g},{p:.6f}")
    return "\n".join(lines) + "\n"
