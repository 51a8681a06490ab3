"""Start-up from an unknown position with the magnet polarity, in the simulator.

:func:`startup_runs` starts the drive in ``control.mode = "startup"`` (``LS_MODE_STARTUP``,
docs/firmware.md) from positions spread over two electrical periods, its estimate at 0, on the
saturated plant, and reports per run whether the polarity came out right, how far the mover moved
while the drive detected it, how long that took and the pulses' current difference.

A constant load cannot be held before the polarity is known (the sign of the force a q-current
makes is the unknown itself), so a run with a load models what holds a loaded axis at standstill:
Coulomb friction (a guide's static friction or a brake) above the load, ``coulomb`` N.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from linsense.scenario.load import scenario_from_dict
from linsense.sim.build import build
from linsense.sim.core import run_closed_loop

#: s, simulated after the start-up ends (position control at the estimate)
AFTER_S = 0.1


@dataclass
class StartupRun:
    """One simulated start-up and what it did.

    Attributes
    ----------
    x0_mm : float
        True start position, mm.
    load_n : float
        Load, N.
    fidelity : str
        Inverter model.
    right : bool
        Polarity right: ``|theta_est - theta| < 90 deg`` at the end, no fault.
    fault : int
        Fault bits.
    motion_mm : float
        Largest ``|x - x0|`` while the drive was in LS_MODE_STARTUP, mm.
    motion_after_mm : float
        Largest ``|x - x0|`` over the ``AFTER_S`` of position control that follow, mm.
    detect_s : float
        Time in LS_MODE_STARTUP, s.
    i_diff_a : float
        ``mean(|di_+| - |di_-|)``, signed, A.
    flip : bool
        Whether the start-up flipped its estimate by pi.
    err_end_deg : float
        Final estimation error, electrical deg.
    """
    x0_mm: float
    load_n: float
    fidelity: str
    right: bool  # polarity right: |theta_est - theta| < 90 deg at the end, no fault
    fault: int
    motion_mm: float  # largest |x - x0| while the drive was in LS_MODE_STARTUP
    motion_after_mm: float  # largest |x - x0| over the AFTER_S of position control that follow
    detect_s: float  # s, time in LS_MODE_STARTUP
    i_diff_a: float  # A, mean(|di_+| - |di_-|), signed
    flip: bool
    err_end_deg: float  # final estimation error, electrical deg


def base_scenario(motor: str = "ecce2010", polarity: float | None = 0.0131, fidelity: str = "switching",
                  noise: float = 0.01, adc_bits: int = 12, startup: dict | None = None) -> dict:
    """A start-up scenario (dict) on the paper's drive.

    72 V, 16 kHz, 0.8 us dead time, current sensors with ``noise`` A rms and an ADC over +-10 A,
    the saturated plant.

    Parameters
    ----------
    motor : str, optional
        Preset or motor file.
    polarity : float or None, optional
        Polarity signal over the motor's, 1/A (None: the motor file's own ``[saturation]``).
    fidelity : str, optional
        Inverter model.
    noise : float, optional
        Current-sensor noise, A rms.
    adc_bits : int, optional
        ADC resolution.
    startup : dict or None, optional
        ``[startup]`` keys.

    Returns
    -------
    dict
        The scenario's sections.
    """
    sat = {"enabled": True} if polarity is None else {"enabled": True, "polarity": polarity}
    d = {"motor": motor, "scenario": {"name": "startup", "duration": 1.0},
         "inverter": {"fidelity": fidelity}, "control": {"mode": "startup"}, "reference": {"type": "hold"},
         "sensors": {"current_noise": noise, "adc_bits": adc_bits}, "saturation": sat}
    if startup:
        d["startup"] = dict(startup)
    return d


def startup_run(base: dict, x0_mm: float, load_n: float = 0.0, coulomb: float = 30.0, seed: int = 1,
                base_dir=None, coulomb_free: float = 0.0) -> StartupRun:
    """One start-up from the true position ``x0_mm`` (the drive's estimate at startup.guess_mm).

    Parameters
    ----------
    base : dict
        The scenario (:func:`base_scenario`).
    x0_mm : float
        True start position, mm.
    load_n : float, optional
        Load, N.
    coulomb : float, optional
        Coulomb friction with a load, N.
    seed : int, optional
        Current-noise seed.
    base_dir : str or Path or None, optional
        Folder a relative motor path is resolved against.
    coulomb_free : float, optional
        Coulomb friction without a load, N.

    Returns
    -------
    StartupRun
        What the start-up did.
    """
    d = {k: (dict(v) if isinstance(v, dict) else v) for k, v in base.items()}
    d["initial"] = {"position_mm": float(x0_mm)}
    d["load"] = {"force": float(load_n)}
    d.setdefault("scenario", {})["seed"] = int(seed)
    sc = scenario_from_dict(d, base_dir=base_dir)
    su = sc.spec.startup
    fs = sc.spec.inverter.f_pwm
    t_max = su.t_lock + su.t_quiet + (2 * su.pairs + 1) * (su.t_pulse + su.t_rest) + su.t_settle + 0.01
    d["scenario"]["duration"] = t_max + AFTER_S
    sc = scenario_from_dict(d, base_dir=base_dir)
    b = build(sc)
    b.cfg.coulomb = max(float(b.cfg.coulomb), float(coulomb if load_n != 0.0 else coulomb_free))
    raw = run_closed_loop(b.cfg, b.drive.state, b.n_steps, b.commands, signals=("x", "theta_err"))
    s = b.drive.state.su
    n_su = int(s.steps)
    x = raw.arrays["x"]
    dx = np.abs(x - x0_mm * 1e-3)
    in_su = dx[: n_su + 1]
    after = dx[n_su + 1: n_su + 1 + int(AFTER_S * fs)]
    err_end = float(raw.arrays["theta_err"][-1])
    right = raw.fault == 0 and int(s.phase) == 4 and abs(err_end) < math.pi / 2
    return StartupRun(x0_mm=float(x0_mm), load_n=float(load_n), fidelity=sc.spec.inverter.fidelity,
                      right=bool(right), fault=int(raw.fault), motion_mm=float(in_su.max()) * 1e3,
                      motion_after_mm=float(after.max()) * 1e3 if after.size else math.nan,
                      detect_s=n_su / fs, i_diff_a=float(s.i_diff), flip=bool(s.flip),
                      err_end_deg=math.degrees(err_end))


def start_positions(n: int, pole_pitch_mm: float = 56.0, seed: int = 14) -> np.ndarray:
    """``n`` random start positions spread over two electrical periods ``[-tau, tau)``.

    Parameters
    ----------
    n : int
        Positions.
    pole_pitch_mm : float, optional
        ``tau``, mm.
    seed : int, optional
        Random seed.

    Returns
    -------
    ndarray
        mm.
    """
    rng = np.random.default_rng(seed)
    return rng.uniform(-pole_pitch_mm, pole_pitch_mm, n)


def startup_runs(base: dict, n: int = 200, loads=(0.0, 20.0), coulomb: float = 30.0, seed: int = 14,
                 base_dir=None, coulomb_free: float = 0.0) -> list[StartupRun]:
    """:func:`startup_run` at ``n`` random positions over two periods, for each load.

    Parameters
    ----------
    base : dict
        The scenario.
    n : int, optional
        Positions.
    loads : sequence of float, optional
        Loads, N.
    coulomb : float, optional
        Coulomb friction with a load, N.
    seed : int, optional
        Seed of the positions.
    base_dir : str or Path or None, optional
        Folder a relative motor path is resolved against.
    coulomb_free : float, optional
        Coulomb friction without a load, N.

    Returns
    -------
    list of StartupRun
        Load by load, position by position.
    """
    xs = start_positions(n, seed=seed)
    return [startup_run(base, x, load, coulomb, seed=k + 1, base_dir=base_dir, coulomb_free=coulomb_free)
            for load in loads for k, x in enumerate(xs)]


def summary(runs: list[StartupRun]) -> dict:
    """Per load: right / total, worst motion during detection, longest detection, smallest ``|i_diff|``.

    Parameters
    ----------
    runs : list of StartupRun
        The runs.

    Returns
    -------
    dict
        Load (N) to ``right``, ``n``, ``motion_mm``, ``motion_after_mm``, ``detect_s``,
        ``i_diff_min_a``, ``worst_x0_mm``.
    """
    out = {}
    for load in sorted({r.load_n for r in runs}):
        rs = [r for r in runs if r.load_n == load]
        out[load] = {
            "right": sum(r.right for r in rs), "n": len(rs),
            "motion_mm": max(r.motion_mm for r in rs),
            "motion_after_mm": max(r.motion_after_mm for r in rs),
            "detect_s": max(r.detect_s for r in rs),
            "i_diff_min_a": min(abs(r.i_diff_a) for r in rs),
            "worst_x0_mm": max(rs, key=lambda r: r.motion_mm).x0_mm,
        }
    return out
