"""The certificate of a designed drive: its runs grouped into checks, each with its number, its
bound, and where it fails the likely cause and what to change (docs/tuning.md, "The certificate").
"""

from __future__ import annotations

import copy
import dataclasses
import math
import time
from dataclasses import dataclass, field
from pathlib import Path

from linsense.io import working_folder
from linsense.model.motor import Motor
from linsense.tune.design import SPEED_CAP_MARGIN
from linsense.verify import criteria as C
from linsense.verify.case_runs import MOVES as C_MOVES
from linsense.verify.case_runs import run_cases
from linsense.verify.cases import UNBOUNDED_MM, all_cases

#: the likely cause of a failed check and what to change
REMEDY = {
    "limit cycle": (
        "the dead time, where a phase current sits near zero at a PWM edge (docs/tuning.md): more "
        "injection voltage (--v-inj), less dead time, the square wave (--injection square), or "
        "lower bandwidths"
    ),
    "error": (
        "a steady estimation bias (dead time or model error): calibrate the LUT on the bench "
        "(linsense calibrate) or raise the injection voltage"
    ),
    "settle": "a faster position loop or a higher speed cap (--v-max), within the observer's bandwidth",
    "trajectory": "a smaller speed or acceleration (--v-max, --a-max) or a faster observer",
    "load": "a stiffer position/speed loop, or a smaller load step",
    "fault": ("see the fault: overspeed in a move -> raise --v-max, in a hold (or at its start) the "
              "estimate ran away -> the design's margins and its warnings (docs/tuning.md, \"The "
              "observer\"); overcurrent -> raise --i-max or lower --a-max; travel -> the mover reached an "
              "end stop: a longer --travel"),
    "calibration": (
        "the firmware's calibration (encoder control, the dither, the table integrated point by point) "
        "stopped on this plant: 'observer' is a point not accepted within calibration.t_max or the HF "
        "signal lost (docs/simulator.md, \"Calibration\"); the injection's shape and amplitude set how "
        "well it converges"
    ),
    "off-nominal": (
        "the LUT and gains depend on this parameter: identify the motor (linsense identify) "
        "or calibrate the LUT (linsense calibrate)"
    ),
}


@dataclass
class Check:
    """One line of the certificate.

    Attributes
    ----------
    name : str
        What is checked.
    passed : bool
        Whether it passed.
    value : str
        What the runs gave.
    bound : str
        The bound.
    cause : str
        The likely cause of a failure.
    runs : int
        Runs behind it.
    failed : int
        Runs that failed.
    """

    name: str
    passed: bool
    value: str
    bound: str
    cause: str = ""
    runs: int = 0
    failed: int = 0

    def line(self) -> str:
        """The check as the report prints it (with the likely cause of a failure).

        Returns
        -------
        str
            One or two lines.
        """
        mark = "PASS" if self.passed else "FAIL"
        n_ok = self.runs - self.failed
        out = f"  {mark}  {self.name:34s} {self.value}  (bound {self.bound}; {n_ok}/{self.runs} runs)"
        if not self.passed and self.cause:
            out += f"\n        likely: {self.cause}"
        return out


@dataclass
class Certificate:
    """The checks, the runs behind them and the wall time of the verification.

    Attributes
    ----------
    checks : list of Check
        The checks.
    rows : list of dict
        The judged runs (:func:`linsense.verify.case_runs.judge`).
    wall_s : float
        Wall time, s.
    quick : bool
        Only the quick checks were run.
    extra : dict
        Further keys of :meth:`as_dict`.
    notes : list of str
        Lines of information after the checks (not judged).
    """

    checks: list[Check]
    rows: list[dict]
    wall_s: float
    quick: bool
    extra: dict = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)

    @property
    def passed(self) -> bool:
        """Whether every check passed."""
        return all(c.passed for c in self.checks)

    def lines(self) -> list[str]:
        """The certificate as the report prints it.

        Returns
        -------
        list of str
            A heading, one line per check, the verdict.
        """
        n = len(self.rows)
        head = (
            f"verification ({'quick: ' if self.quick else ''}{n} runs, switching inverter with the drive's "
            f"dead time, {self.wall_s:.1f} s):"
        )
        return [head] + [c.line() for c in self.checks] + self.notes + [self.verdict()]

    @property
    def verified(self) -> bool:
        """Every check of the FULL certificate passed (a quick run never verifies)."""
        return self.passed and not self.quick

    def verdict(self) -> str:
        """The verdict in one line: verified, quick checks passed, or how many checks failed.

        Returns
        -------
        str
            The verdict.
        """
        n_bad = sum(not c.passed for c in self.checks)
        if self.passed:
            return ("verified: every check passed" if not self.quick else
                    "quick checks passed (nominal holds, steps and moves at +-rated load only): not "
                    "verified, run without --quick")
        return f"NOT verified: {n_bad} of {len(self.checks)} checks failed"

    def as_dict(self) -> dict:
        """The certificate as plain data (without the runs' traces and wall times).

        Returns
        -------
        dict
            ``passed``, ``verified``, ``quick``, ``checks``, ``runs`` and :attr:`extra`.
        """
        runs = [{k: v for k, v in r.items() if k not in ("trace", "wall_s")} for r in self.rows]
        return {
            "passed": self.passed,
            "verified": self.verified,
            "quick": self.quick,
            "checks": [c.__dict__ for c in self.checks],
            "notes": [n.strip() for n in self.notes],
            "runs": runs,
            **self.extra,
        }


NAN = float("nan")


def _s(v: float | None) -> str:
    return "never" if v is None else f"{v:.3g} s"


def _cause(rows: list[dict]) -> str:
    whys = " ".join(r["why"] for r in rows if not r["passed"])
    if "fault" in whys or "did not finish" in whys:
        return REMEDY["fault"]
    if "limit cycle" in whys:
        return REMEDY["limit cycle"]
    return REMEDY["error"]


def _hold_check(name: str, rows: list[dict], lim_err: float, extra_cause: str = "") -> Check:
    ok = [r for r in rows if "err_deg" in r]
    failed = [r for r in rows if not r["passed"]]
    e = max((r["err_deg"] for r in ok), default=float("nan"))
    pp = max((r["pp_deg"] for r in ok), default=float("nan"))
    value = (f"|x - target| <= {e:.3g} deg, p-p <= {pp:.3g} deg" if ok else
             f"no hold finished ({len(failed)} of {len(rows)} faulted)")
    if failed:
        worst = failed[0]
        value += f"; e.g. {worst['case']}: {worst['why']}"
    return Check(
        name,
        not failed,
        value,
        f"{lim_err:g} deg, {C.HOLD_PP_DEG:g} deg p-p, no fault",
        extra_cause or (_cause(rows) if failed else ""),
        len(rows),
        len(failed),
    )


def _single(r: dict, name: str, value: str, bound: str, remedy: str) -> Check:
    """The check of one run: its value, and where it failed why (every bound it broke) and the
    likely cause of the first."""
    cause = ""
    if r.get("note"):  # (still approaching within the band at the end: said, not failed)
        value = f"{value}; {r['note']}"
    if not r["passed"]:
        # (a step's why says its time; a run that faulted or did not finish has no figures to show)
        faulted = r["fault"] != "none" or "did not finish" in r["why"]
        value = r["why"] if r["kind"] == "step" or faulted else f"{value}; {r['why']}"
        if r["fault"] != "none" or "did not finish" in r["why"]:
            cause = REMEDY["fault"]
        elif r["why"].startswith("limit cycle"):
            cause = REMEDY["limit cycle"]
        else:
            cause = REMEDY[remedy]
    pp = (f", p-p <= {C.HOLD_PP_DEG:g} deg at the end" if r["kind"] in ("step", "move_hold") else
          f", no limit cycle above {C.HOLD_PP_DEG:g} deg p-p at the end")
    return Check(name, r["passed"], value, bound + pp, cause, 1, int(not r["passed"]))


def _moves_check(rows: list[dict], band: tuple[float, float] | None = None) -> Check:
    """The out-and-back moves over the loads: the worst estimation error moving and at rest (``band``:
    the hand-over's ``(v_lo, v_hi)``, m/s, where the drive runs the EMF estimate)."""
    ok = [r for r in rows if "peak_err_deg" in r]
    failed = [r for r in rows if not r["passed"]]
    worst = max(ok, key=lambda r: r["peak_err_deg"], default=None)
    if worst is None:
        value = "no run finished"
    else:
        rest = max(r["est_err_deg"] for r in ok)
        top = min(r["speed_peak_m_s"] for r in ok)
        value = (f"peak estimation error {worst['peak_err_deg']:.3g} deg (at {worst['load_n']:+.3g} N), "
                 f"at rest {rest:.3g} deg; top speed reached >= {top:.3g} m/s")
    cause = ""
    if failed:
        value += f"; e.g. {failed[0]['case']}: {failed[0]['why']}"
        whys = " ".join(r["why"] for r in failed)
        crossed = [r["err_crosses_at_speed"] for r in failed if r.get("err_crosses_at_speed") is not None]
        cause = (REMEDY["fault"] if "fault" in whys or "did not finish" in whys else
                 REMEDY["limit cycle"] if "limit cycle" in whys else
                 _crossing_cause(min(crossed), band) if crossed else
                 REMEDY["trajectory"])
    loads = sorted({r["load_n"] for r in rows})
    span = f"{loads[0]:+.3g}..{loads[-1]:+.3g} N" if len(loads) > 1 else f"{loads[0]:+.3g} N" if loads else ""
    return Check(f"moves at v_max, {span}", not failed, value,
                 f"{C.TRAJ_PEAK_ERR_DEG:g} deg moving, {C.TRAJ_REST_ERR_DEG:g} deg at rest, no fault",
                 cause, len(rows), len(failed))


def _calibration_check(plant: str, cal: dict | None) -> Check:
    """The calibration of a plant's table: completed, and how far from the plant's own table."""
    if cal is None:
        return Check(f"table measured on {plant}", False, "not run", "completed", REMEDY["fault"], 1, 1)
    ok = bool(cal["completed"])
    value = (f"{cal['points_done']}/{cal['points']} points; within {cal['max_diff_deg']:.3g} deg of the "
             f"plant's own table (the motor file's: {cal['file_diff_deg']:.3g} deg)" if ok else
             f"did not complete ({cal['points_done']} of {cal['points']} points, fault {cal['fault']}): "
             f"the holds and the move with a measured table not run on this plant")
    return Check(f"table measured on {plant}", ok, value, "every point, no fault",
                 "" if ok else REMEDY["calibration"], 1, int(not ok))


def _crossing_cause(v_cross: float, band: tuple[float, float] | None) -> str:
    """What a move whose error crossed the bound at ``v_cross`` (m/s) says, by where it crossed: below
    the hand-over band the HF estimate gives out before the EMF estimate is trusted; inside it the
    two are weighed together (a lower --v-max there only moved the crossing: keep the cap below the
    band); above it the EMF estimate carries alone; without a band the HF estimate carries all."""
    bound = f"{C.TRAJ_PEAK_ERR_DEG:g} deg"
    if band is not None and v_cross < band[0]:
        return (f"the HF estimate's error crosses {bound} at {v_cross:.3g} m/s, below the hand-over band "
                f"{band[0]:.3g} - {band[1]:.3g} m/s (the EMF estimate's bound is within {bound} only from "
                f"{band[1]:.3g} m/s): between them neither holds {bound} on this drive: a --v-max below "
                f"{v_cross:.3g} m/s, or less dead time or current noise (docs/tuning.md, "
                f"\"The speed range\")")
    if band is not None and v_cross <= band[1]:  # (inside the band: the two estimates weighed together)
        return (f"the error crosses {bound} at {v_cross:.3g} m/s, inside the hand-over band {band[0]:.3g} - "
                f"{band[1]:.3g} m/s, where the HF and EMF estimates are weighed together (the EMF's there: "
                f"the magnets' flux harmonics and imbalance, the dead time): a --v-max lower than the band "
                f"needs leaves the EMF estimate off, its speed cap ({SPEED_CAP_MARGIN:g} v_max) below "
                f"{band[0]:.3g} m/s (--v-max under {band[0] / SPEED_CAP_MARGIN:.3g}), the HF estimate then "
                f"carrying alone within its own reach")
    if band is not None:  # (above the band: the EMF estimate alone)
        return (f"the error crosses {bound} at {v_cross:.3g} m/s, above the hand-over band, where the EMF "
                f"estimate carries alone (its errors: the magnets' flux harmonics and imbalance, R_s, L_q, "
                f"the dead time; docs/theory.md, section 9): a --v-max below it")
    return (f"the HF estimate's error grows with the speed and crosses {bound} at {v_cross:.3g} m/s on this "
            f"drive: a --v-max below it")


def checks(rows: list[dict], calibrations: dict | None = None,
           band: tuple[float, float] | None = None) -> list[Check]:
    """The certificate's checks from the judged runs.

    Parameters
    ----------
    rows : list of dict
        The judged runs.
    calibrations : dict or None, optional
        Plant name -> its calibration's summary (:func:`calibration_summary`), for the plants of
        :data:`~linsense.verify.criteria.CALIBRATED`.
    band : tuple of float or None, optional
        The hand-over band ``(v_lo, v_hi)``, m/s, where the drive runs the EMF estimate (the moves'
        advice where the error crosses the bound below it).

    Returns
    -------
    list of Check
        Holds of the nominal plant, each step, the moves, the load step, then for each off-nominal
        plant its holds (and, where its table is measured, the calibration and a move).
    """
    calibrations = calibrations or {}
    out = []
    nominal = [r for r in rows if r["kind"] == "hold" and r["plant"] == "nominal"]
    out.append(_hold_check("holds, nominal plant", nominal, C.HOLD_ERR_DEG))
    e_nom = max((r.get("err_deg", 0.0) for r in nominal), default=0.0)
    trajectories = [r for r in rows if r["kind"] == "trajectory" and r["plant"] == "nominal"]
    for r in rows:
        if r["plant"] != "nominal":
            continue
        if r["kind"] == "step":
            out.append(
                _single(
                    r,
                    r["case"],
                    f"settled in {_s(r.get('settle_s'))}",
                    f"{C.STEP_SETTLE_S:g} s within {C.SETTLE_BAND_DEG:g} deg",
                    "settle",
                )
            )
        elif r is (trajectories[0] if trajectories else None):
            out.append(_moves_check(trajectories, band))
        elif r["kind"] in ("reversal", "move_hold"):
            out.append(_move_check(r, "reversal through zero speed" if r["kind"] == "reversal" else
                                   "hold after the fastest move"))
        elif r["kind"] == "load_step":
            out.append(
                _single(
                    r,
                    r["case"],
                    f"back within {C.SETTLE_BAND_DEG:g} deg after "
                    f"{_s(r.get('recover_s'))}; peak {r.get('peak_dev_deg', NAN):.3g} deg "
                    f"({r.get('peak_dev_mm', NAN):.3g} mm), stiffness "
                    f"{r.get('stiffness_n_per_mm', NAN):.3g} N/mm",
                    f"{C.LOAD_RECOVER_S:g} s",
                    "load",
                )
            )
    for plant in C.OFF_NOMINAL:
        measured = plant in C.CALIBRATED
        rs = [r for r in rows if r["plant"] == plant and r["kind"] == "hold"
              and r["table"] == ("measured" if measured else "design")]
        if measured and plant in calibrations:  # (a calibration that did not complete fails here)
            out.append(_calibration_check(plant, calibrations[plant]))
        if not rs:
            continue
        c = _hold_check(
            f"holds, {plant}" + (", measured table" if measured else ""),
            rs,
            C.HOLD_ERR_DEG if measured else C.OFF_ERR_DEG,
            REMEDY["off-nominal"]
            if any(not r["passed"] and "limit cycle" not in r["why"] for r in rs) and not measured
            else "",
        )
        e = max((r["err_deg"] for r in rs if "err_deg" in r), default=float("nan"))
        # (no cost where a hold did not finish: its error is unknown)
        if all("err_deg" in r for r in rs) and math.isfinite(e - e_nom):
            c.value += f"; cost {e - e_nom:+.3g} deg over nominal"
        if not c.passed and not c.cause:
            c.cause = _cause(rs)
        out.append(c)
        for r in rows:
            if r["plant"] == plant and r["kind"] in C_MOVES:
                out.append(_move_check(r, f"move at v_max, {plant}, measured table"))
    return out


def _move_check(r: dict, name: str) -> Check:
    """The check of one move (a reversal, a hold after a move, an off-nominal plant's)."""
    bound = f"{C.TRAJ_PEAK_ERR_DEG:g} deg moving, {C.TRAJ_REST_ERR_DEG:g} deg at rest"
    if r["kind"] == "move_hold":
        bound += f", then {C.HOLD_ERR_DEG:g} deg"
    return _single(
        r,
        name,
        f"peak estimation error {r.get('peak_err_deg', NAN):.3g} deg at up to "
        f"{r.get('speed_peak_m_s', NAN):.3g} m/s, {r.get('load_n', NAN):+.3g} N; at rest "
        f"{r.get('est_err_deg', NAN):.3g} deg, |x - target| {r.get('err_deg', NAN):.3g} deg",
        bound,
        "trajectory",
    )


def _calibration_base(base: dict, motor_spec: str, travel: float | None, tau: float) -> dict:
    """The drive under test as the calibration runs it: the controller's model pinned to the
    nominal motor, its own table left out (the calibration measures one)."""
    from linsense.tune.export import end_stops

    sc = copy.deepcopy(base)
    sc["motor"] = motor_spec
    sc.setdefault("controller", {}).setdefault("model", {})["motor"] = motor_spec
    for key in ("lut_model", "lut_file", "compensation"):
        sc.get("observer", {}).pop(key, None)
    sc["travel"] = (end_stops(tau, travel) if travel is not None else
                    {"min_mm": -UNBOUNDED_MM, "max_mm": UNBOUNDED_MM})
    sc["reference"] = {"type": "hold"}
    return sc


def calibrate_plant(motor: Motor, motor_spec: str, base: dict, base_dir: str, plant: str,
                    travel: float | None = None, route: str = "calibrate"):
    """The firmware's calibration (paper Fig. 9) with the drive under test on an off-nominal plant,
    or its sensorless commissioning (``route = "commission"``).

    Parameters
    ----------
    motor : Motor
        The nominal motor (the drive's model).
    motor_spec : str
        Its preset name or absolute file path.
    base : dict
        The tuned scenario.
    base_dir : str
        Folder the scenario is relative to.
    plant : str
        A key of :data:`~linsense.verify.criteria.OFF_NOMINAL`.
    travel : float or None, optional
        The stroke, m.
    route : str, optional
        ``"calibrate"`` (default: with the encoder) or ``"commission"`` (without: the drive's bus,
        PWM, dead time, current limit and injection commissioned by
        :func:`linsense.studies.commission.commission`, its stroke the travel's).

    Returns
    -------
    linsense.studies.calibrate.Calibration
        The measured table; its ``psi_model`` is the plant's own.
    """
    from linsense.scenario.load import scenario_from_dict
    from linsense.studies.calibrate import calibrate
    from linsense.verify.cases import off_nominal_motor

    if route == "commission":
        return _commission_plant(motor, base, plant, travel)
    sc = scenario_from_dict(_calibration_base(base, motor_spec, travel, motor.pole_pitch),
                            source=f"the certificate's calibration on {plant}", base_dir=base_dir)
    return calibrate(scenario=sc, plant=off_nominal_motor(motor, plant), positions=C.CAL_POSITIONS,
                     load=0.0, fidelity="switching")


def _commission_plant(motor: Motor, base: dict, plant: str, travel: float | None):
    """The sensorless commissioning of an off-nominal plant with the drive under test's bus, PWM,
    dead time, current limit and injection (its table's stamp is that drive's)."""
    from linsense.studies.commission import commission
    from linsense.verify.cases import off_nominal_motor

    keys = {"v_dc": ("inverter", "v_dc"), "f_pwm": ("inverter", "f_pwm"),
            "dead_time": ("inverter", "dead_time"), "i_max": ("controller", "i_max"),
            "v_inj": ("injection", "amplitude"),
            "f_inj": ("injection", "frequency"), "quad": ("injection", "quadrature")}
    drive = {k: base.get(sec, {}).get(key) for k, (sec, key) in keys.items()}
    return commission(motor, plant=off_nominal_motor(motor, plant), points=C.CAL_POSITIONS, drive=drive,
                      stroke_mm=None if travel is None else 0.8 * travel * 1e3,
                      source=f"the certificate's commissioning on {plant}")


def calibration_summary(cal, motor: Motor) -> dict:
    """A calibration as the certificate reports it: the measured table against the plant's own and
    the motor file's (electrical deg).

    Parameters
    ----------
    cal : linsense.studies.calibrate.Calibration
        The calibration on the plant.
    motor : Motor
        The nominal motor (the file's table is its model's, for the injection the drive runs).

    Returns
    -------
    dict
        ``completed``, ``points``, ``points_done``, ``fault``, ``max_diff_deg`` (measured against the
        plant's own table), ``file_diff_deg`` (the file's against the plant's), and the tables
        ``theta_deg``, ``psi_measured_deg``, ``psi_plant_deg``, ``psi_file_deg``.
    """
    import numpy as np

    from linsense.compensation.lut import build_lut

    m = cal.metrics
    n = int(m["points"])
    psi_file = build_lut(motor, n, f_inj=m["f_inj_hz"], quad=m["injection_quad"],
                         injection=m["injection_shape"]).values
    deg = np.degrees
    meas = deg(cal.psi_measured)
    ok = np.isfinite(meas)

    def rnd(a) -> list:
        return [None if not np.isfinite(v) else round(float(v), 6) for v in a]

    return {
        "completed": bool(cal.completed),
        "points": n,
        "points_done": int(m["points_done"]),
        "fault": m["fault"],
        "max_diff_deg": float(np.max(np.abs(meas[ok] - deg(cal.psi_model)[ok]))) if ok.any() else NAN,
        "file_diff_deg": float(np.max(np.abs(deg(psi_file - cal.psi_model)))),
        "theta_deg": rnd(deg(cal.theta)),
        "psi_measured_deg": rnd(meas),
        "psi_plant_deg": rnd(deg(cal.psi_model)),
        "psi_file_deg": rnd(deg(psi_file)),
    }


def _file_table_notes(rows: list[dict], calibrations: dict, route: str = "calibrate") -> list[str]:
    """The cost of the motor file's table on the plants whose table the certificate measured (for
    information: not judged), naming the command that measured it (``route``)."""
    out = []
    for plant, (_, _, k_e) in C.OFF_NOMINAL.items():
        rs = [r for r in rows if r["plant"] == plant and r["table"] == "design" and "err_deg" in r]
        if plant not in C.CALIBRATED or not rs:
            continue
        e = max(r["err_deg"] for r in rs)
        per10 = e / (abs(k_e - 1.0) * 10.0)
        out.append(f"  info  {plant} with the motor file's table: |x - target| <= {e:.3g} deg at no load "
                   f"({per10:.2g} deg per 10 % of dM0; the bound is {C.HOLD_ERR_DEG:g} deg): measure the "
                   f"table on the machine (linsense {route}), as this certificate did")
    return out


def prepare(motor: Motor, motor_spec: str, base: dict, base_dir: str, *, v_max: float, a_max: float,
            load: float, travel: float | None = None, quick: bool = False, workers: int | None = None,
            table_route: str = "calibrate"):
    """The certificate's runs, each kind built once here; a callable that runs them.

    So that a configuration any of them refuses ends in one InputError before anything runs or is
    written. The callable first measures the table of each plant of
    :data:`~linsense.verify.criteria.CALIBRATED` with the drive under test (the firmware's
    calibration; the tables go through the same stamped file a user gives, in a temporary folder),
    then runs every case.

    Parameters
    ----------
    motor : Motor
        The nominal motor.
    motor_spec : str
        Its preset name or absolute file path (the controller's model).
    base : dict
        The tuned scenario.
    base_dir : str
        Folder the scenarios are relative to.
    v_max : float
        The application's speed, m/s.
    a_max : float
        Its acceleration, m/s^2.
    load : float
        Rated load, N.
    travel : float or None, optional
        The stroke the moves must stay within, m.
    quick : bool, optional
        Only the quick checks.
    workers : int or None, optional
        Worker threads (default: one per core).
    table_route : str, optional
        How the off-nominal plants' tables are measured: ``"calibrate"`` (the encoder) or
        ``"commission"`` (without a sensor, :func:`calibrate_plant`).

    Returns
    -------
    callable
        ``run() -> Certificate``.

    Raises
    ------
    linsense.errors.InputError
        A run's configuration refused.
    """
    cases = all_cases(motor.pole_pitch, v_max, a_max, load, quick, travel=travel)
    # the tolerances scale the linear model, not a saturated plant's data: those runs would judge the
    # nominal motor again, so they are not run and the certificate says so
    saturated = bool(base.get("saturation", {}).get("enabled"))
    if saturated:
        cases = [c for c in cases if c.plant == "nominal"]
    calibrated = sorted({c.plant for c in cases if c.table == "measured"})
    _build_each_kind(cases, calibrated, motor, motor_spec, base, base_dir, travel)

    def run() -> Certificate:
        import tempfile

        from linsense.sim.cluster import thread_map

        t0 = time.perf_counter()
        cals = dict(zip(calibrated, thread_map(
            lambda p: calibrate_plant(motor, motor_spec, base, base_dir, p, travel, table_route), calibrated,
            workers,
            "linsense-calibrate"), strict=True))
        summaries = {p: calibration_summary(cal, motor) for p, cal in cals.items()}
        with tempfile.TemporaryDirectory(prefix="linsense-cert-") as tmp:
            rows = run_cases(_with_tables(cases, cals, tmp), base, motor_spec, motor, base_dir, workers)
        cks = _for_friction(_for_shape(checks(rows, summaries, _band(base)), base), base)
        if saturated and not quick:
            cks.append(Check("holds, off-nominal plants", False, "not run: the tolerances scale the linear "
                             "inductance model, not the saturation data", "run", "verify the linear plant "
                             "(a scenario without [saturation]) for the tolerances", 0, 0))
        return Certificate(cks, rows, time.perf_counter() - t0, quick,
                           extra={"calibrations": summaries, "table_route": table_route},
                           notes=_file_table_notes(rows, summaries, table_route))

    return run


#: the limit cycle's remedy that names the square wave (not said to a drive that runs it)
_SQUARE_HINT = ", the square wave (--injection square)"


def _for_shape(cks: list[Check], base: dict) -> list[Check]:
    """The checks' causes for the drive's injection: a square-wave drive is not told to try the
    square wave."""
    if base.get("injection", {}).get("shape") == "square":
        for c in cks:
            c.cause = c.cause.replace(_SQUARE_HINT, "")
    return cks


def _for_friction(cks: list[Check], base: dict) -> list[Check]:
    """The limit cycle's cause for a motor with Coulomb friction (``controller.friction_coulomb``, its
    file's, fed forward): at rest the loop hunts across the friction's step (stick-slip) where the
    injection's dither is too slow to smooth it, which the dead time's remedies do not remove (a 15 kg
    mover with 15 N failed 14 of 16 checks at 1.5 and at 0.3 us of dead time and was verified
    without its friction, every failed check blaming the dead time)."""
    f_c = float(base.get("controller", {}).get("friction_coulomb", 0.0) or 0.0)
    if f_c > 0.0:
        for c in cks:
            if c.cause.startswith(REMEDY["limit cycle"][:40]):
                c.cause = (f"the motor's Coulomb friction, {f_c:g} N (its file's friction_coulomb, fed "
                           f"forward): at rest the loop hunts across its step (stick-slip), which more "
                           f"injection or less dead time does not remove; or {c.cause}")
    return cks


def _band(base: dict) -> tuple[float, float] | None:
    """The hand-over band ``(v_lo, v_hi)`` (m/s) of a designed scenario's keys, or None without the
    EMF estimate."""
    obs = base.get("observer", {})
    return (float(obs["handover_v_lo"]), float(obs["handover_v_hi"])) if obs.get("emf") else None


def _build_each_kind(cases: list, calibrated: list[str], motor: Motor, motor_spec: str, base: dict,
                     base_dir: str, travel: float | None) -> None:
    """Build one run of each kind and plant of ``cases`` (and the calibration's, if any plant is
    ``calibrated``), so that a configuration any of them refuses raises before anything runs."""
    from linsense.scenario.load import scenario_from_dict
    from linsense.sim.build import build
    from linsense.studies.calibrate import calibration_scenario
    from linsense.verify.case_runs import case_scenario
    from linsense.verify.cases import off_nominal_motor

    seen = set()
    for c in cases:
        if (c.kind, c.plant) in seen:
            continue
        seen.add((c.kind, c.plant))
        sc = scenario_from_dict(case_scenario(c, base, motor_spec), source=f"the certificate's {c.kind} run",
                                base_dir=base_dir)
        build(sc, motor=off_nominal_motor(motor, c.plant))
    if calibrated:
        sc = scenario_from_dict(_calibration_base(base, motor_spec, travel, motor.pole_pitch),
                                source="the certificate's calibration", base_dir=base_dir)
        calibration_scenario(scenario=sc, positions=C.CAL_POSITIONS)


def _with_tables(cases: list, cals: dict, tmp: str) -> list:
    """``cases`` whose measured-table runs read the table measured on their plant (written, stamped,
    in ``tmp``); the runs of a plant whose calibration did not complete are left out."""
    from linsense.io import write_atomic
    from linsense.studies.calibrate import measured_json

    files = {}
    for i, (p, cal) in enumerate(cals.items()):
        if cal.completed:
            files[p] = str(write_atomic(Path(tmp) / f"table{i}.json", measured_json(cal)))
    todo = []
    for c in cases:
        if c.table == "measured":
            if c.plant not in files:  # (no table measured: those runs are not run)
                continue
            obs = {"lut_model": "measured", "lut_file": files[c.plant]}
            c = dataclasses.replace(c, sections={**c.sections, "observer": obs})
        todo.append(c)
    return todo


#: what a firmware header says of the certificate its drive passed (tune --format c, firmware export)
VERIFIED_BY = {
    True: ("the quick certificate of linsense tune (switching inverter with dead time: nominal holds, "
           "steps, moves at v_max at +-rated load) only: linsense tune --format c without --quick runs the "
           "full one"),
    False: "the full certificate of linsense tune (switching inverter with dead time), data sha256 below",
}


def certificate_base(sc: dict) -> dict:
    """The tuned scenario the certificate varies: the designed sensorless drive (its mode, start-up
    and the scenario's own reference, travel, start and load are the certificate's, per run).

    Parameters
    ----------
    sc : dict
        The tuned scenario (:func:`linsense.tune.export.scenario_dict`).

    Returns
    -------
    dict
        Its drive's sections.
    """
    base = {k: (dict(v) if isinstance(v, dict) else v) for k, v in sc.items()}
    for k in ("control", "startup", "reference", "travel", "initial", "load"):
        base.pop(k, None)
    return base


def failed_summary(cert: Certificate) -> str:
    """The failed checks in one line (for a refusal and a header's comment).

    Parameters
    ----------
    cert : Certificate
        The certificate.

    Returns
    -------
    str
        ``"<verdict>: <check>: <value>; ..."``.
    """
    bad = [f"{c.name}: {c.value}" for c in cert.checks if not c.passed]
    return cert.verdict() + (": " + "; ".join(bad) if bad else "")


#: the columns of :func:`summary_row` (docs/tuning.md's class table, tools/class_table.py)
SUMMARY_COLUMNS = (
    "motor", "verdict", "holds: worst error / p-p (deg)", "steps 0.1 / 0.75 pitch (s)",
    "moves: worst error moving (deg, at load) / at rest", "top speed (m/s)",
    "reversal / hold after move (deg)",
    "load step (s)", "dM0 -25 / +25 %, measured table: holds (deg)", "table vs the plant's (deg)",
    "the file's table at dM0 +-25 % (deg)")


def summary_row(name: str, cert: Certificate) -> list[str]:
    """A certificate as one row of the class table (docs/tuning.md, "Where the design stands").

    Parameters
    ----------
    name : str
        The motor.
    cert : Certificate
        Its full certificate.

    Returns
    -------
    list of str
        One cell per :data:`SUMMARY_COLUMNS`.
    """
    rows = cert.rows

    def worst(rs, key):
        vals = [r[key] for r in rs if r.get(key) is not None]
        return max(vals) if vals else NAN

    nominal = [r for r in rows if r["plant"] == "nominal"]
    holds = [r for r in nominal if r["kind"] == "hold"]
    steps = [r for r in nominal if r["kind"] == "step"]
    trajs = [r for r in nominal if r["kind"] == "trajectory" and "peak_err_deg" in r]
    top = max(trajs, key=lambda r: r["peak_err_deg"], default=None)
    other = {r["kind"]: r for r in nominal if r["kind"] in ("reversal", "move_hold", "load_step")}
    measured = {p: [r for r in rows if r["plant"] == p and r["table"] == "measured" and r["kind"] == "hold"]
                for p in C.CALIBRATED}
    filed = {p: [r for r in rows if r["plant"] == p and r["table"] == "design"] for p in C.CALIBRATED}
    cals = cert.extra.get("calibrations", {})

    def s(v, fmt=".2f"):
        return "never" if v is None else f"{v:{fmt}}"

    def pair(p):
        return " / ".join(f"{worst(p[k], 'err_deg'):.2f}" for k in sorted(p, reverse=True))

    failed = sum(not c.passed for c in cert.checks)
    return [
        name,
        "**verified**" if cert.verified else f"{failed} of {len(cert.checks)} failed",
        f"{worst(holds, 'err_deg'):.2f} / {worst(holds, 'pp_deg'):.3f}",
        " / ".join(s(r.get("settle_s")) for r in steps),
        "n/a" if top is None else (f"{top['peak_err_deg']:.2f} ({top['load_n']:+.3g} N) / "
                                   f"{worst(trajs, 'est_err_deg'):.2f}"),
        f"{min((r['speed_peak_m_s'] for r in trajs), default=NAN):.2f}",
        " / ".join(f"{other[k].get('peak_err_deg', NAN):.2f}" for k in ("reversal", "move_hold")
                   if k in other),
        s(other["load_step"].get("recover_s")) if "load_step" in other else "n/a",
        pair(measured),
        " / ".join(f"{cals[p]['max_diff_deg']:.2f}" for p in sorted(cals, reverse=True)),
        pair(filed),
    ]


def verify(
    motor: Motor,
    motor_spec: str,
    base: dict,
    base_dir: str,
    *,
    v_max: float,
    a_max: float,
    load: float,
    quick: bool = False,
    workers: int | None = None,
) -> Certificate:
    """Run the certificate of a tuned scenario.

    Parameters
    ----------
    motor : Motor
        The motor.
    motor_spec : str
        Its preset name or absolute file path, the controller's model.
    base : dict
        The tuned scenario, as ``linsense tune`` writes it.
    base_dir : str
        Folder the scenarios are relative to.
    v_max : float
        The application's speed, m/s.
    a_max : float
        Its acceleration, m/s^2.
    load : float
        Rated load, N.
    quick : bool, optional
        Only the quick checks.
    workers : int or None, optional
        Worker threads.

    Returns
    -------
    Certificate
        The checks and runs.

    Raises
    ------
    linsense.errors.InputError
        A run's configuration refused (:func:`prepare`).
    """
    return prepare(motor, motor_spec, base, base_dir, v_max=v_max, a_max=a_max, load=load, quick=quick,
                   workers=workers)()


def motor_ref(motor_spec: str) -> str:
    """The motor as the certificate's scenarios name it (they run from other folders).

    Parameters
    ----------
    motor_spec : str
        Preset or motor-file path.

    Returns
    -------
    str
        A preset's name, or the motor file's absolute path.
    """
    from linsense.model.motor import names_a_file

    return str(Path(motor_spec).resolve()) if names_a_file(motor_spec) else motor_spec


def design_and_verify(motor_spec: str, drive, *, quick: bool = False, workers: int | None = None,
                      base_dir: str | None = None):
    """The design and certificate of ``linsense tune``, from Python.

    Parameters
    ----------
    motor_spec : str
        A preset or a motor-file path.
    drive : DriveData
        The drive (:class:`~linsense.tune.design.DriveData`).
    quick : bool, optional
        Only the quick checks.
    workers : int or None, optional
        Worker threads.
    base_dir : str or None, optional
        Folder the scenarios are relative to (None: the working folder).

    Returns
    -------
    design : Design
        The design.
    certificate : Certificate
        Its certificate.

    Raises
    ------
    linsense.errors.InputError
        A bad motor or drive, or a run's configuration refused.
    """


    from linsense.model.motor import load_motor
    from linsense.tune.drive_design import design_drive
    from linsense.tune.export import scenario_dict

    spec = motor_ref(motor_spec)
    motor = load_motor(spec)
    made = design_drive(motor, drive, source=spec, analyse=False, startup=False)
    dz = made.design
    base = scenario_dict(made, motor_ref=spec)
    cert = prepare(motor, spec, base, base_dir or str(working_folder()), v_max=drive.v_max, a_max=drive.a_max,
                   load=dz.load, travel=drive.travel, quick=quick, workers=workers)()
    return dz, cert
