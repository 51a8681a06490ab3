"""The certificate of a designed drive: its runs grouped into checks, each with its number, its
bound, and where it fails the likely cause and what to change (docs/tuning.md, "The certificate").
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

from linsense.model.motor import Motor
from linsense.verify import criteria as C
from linsense.verify.cases import all_cases
from linsense.verify.run import run_cases

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
    "fault": "see the fault: overspeed -> raise --v-max; overcurrent -> raise --i-max or lower --a-max",
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
        The judged runs (:func:`linsense.verify.run.judge`).
    wall_s : float
        Wall time, s.
    quick : bool
        Only the quick checks were run.
    extra : dict
        Further keys of :meth:`as_dict`.
    """

    checks: list[Check]
    rows: list[dict]
    wall_s: float
    quick: bool
    extra: dict = field(default_factory=dict)

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
        return [head] + [c.line() for c in self.checks] + [self.verdict()]

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
                    "quick checks passed (nominal holds and steps only): not verified, run without --quick")
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
    value = f"|x - target| <= {e:.3g} deg, p-p <= {pp:.3g} deg"
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
        value = r["why"] if r["kind"] == "step" else f"{value}; {r['why']}"  # (a step's why says its time)
        if r["fault"] != "none" or "did not finish" in r["why"]:
            cause = REMEDY["fault"]
        elif r["why"].startswith("limit cycle"):
            cause = REMEDY["limit cycle"]
        else:
            cause = REMEDY[remedy]
    pp = (f", p-p <= {C.HOLD_PP_DEG:g} deg at the end" if r["kind"] == "step" else
          f", no limit cycle above {C.HOLD_PP_DEG:g} deg p-p at the end")
    return Check(name, r["passed"], value, bound + pp, cause, 1, int(not r["passed"]))


def checks(rows: list[dict]) -> list[Check]:
    """The certificate's checks from the judged runs.

    Parameters
    ----------
    rows : list of dict
        The judged runs.

    Returns
    -------
    list of Check
        Holds of the nominal plant, each step, the trajectory, the load step, then the holds of
        each off-nominal plant.
    """
    out = []
    nominal = [r for r in rows if r["kind"] == "hold" and r["plant"] == "nominal"]
    out.append(_hold_check("holds, nominal plant", nominal, C.HOLD_ERR_DEG))
    e_nom = max((r.get("err_deg", 0.0) for r in nominal), default=0.0)
    for r in rows:
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
        elif r["kind"] == "trajectory":
            out.append(
                _single(
                    r,
                    "trajectory",
                    f"peak estimation error {r.get('peak_err_deg', NAN):.3g} deg, "
                    f"at rest {r.get('est_err_deg', NAN):.3g} deg",
                    f"{C.TRAJ_PEAK_ERR_DEG:g} deg, {C.TRAJ_REST_ERR_DEG:g} deg at rest",
                    "trajectory",
                )
            )
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
        rs = [r for r in rows if r["plant"] == plant]
        if not rs:
            continue
        c = _hold_check(
            f"holds, {plant}",
            rs,
            C.OFF_ERR_DEG,
            REMEDY["off-nominal"]
            if any(not r["passed"] and "limit cycle" not in r["why"] for r in rs)
            else "",
        )
        e = max((r.get("err_deg", float("nan")) for r in rs), default=float("nan"))
        c.value += f"; cost {e - e_nom:+.3g} deg over nominal"
        if not c.passed and not c.cause:
            c.cause = _cause(rs)
        out.append(c)
    return out


def prepare(motor: Motor, motor_spec: str, base: dict, base_dir: str, *, v_max: float, a_max: float,
            load: float, travel: float | None = None, quick: bool = False, workers: int | None = None):
    """The certificate's runs, each kind built once here; a callable that runs them.

    So that a configuration any of them refuses ends in one InputError before anything runs or is
    written.

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

    Returns
    -------
    callable
        ``run() -> Certificate``.

    Raises
    ------
    linsense.errors.InputError
        A run's configuration refused.
    """
    from linsense.sim.build import build
    from linsense.sim.scenario import scenario_from_dict
    from linsense.verify.cases import off_nominal_motor
    from linsense.verify.run import case_scenario

    cases = all_cases(motor.pole_pitch, v_max, a_max, load, quick, travel=travel)
    # the tolerances scale the linear model, not a saturated plant's data: those runs would judge the
    # nominal motor again, so they are not run and the certificate says so
    saturated = bool(base.get("saturation", {}).get("enabled"))
    if saturated:
        cases = [c for c in cases if c.plant == "nominal"]
    seen = set()
    for c in cases:
        if (c.kind, c.plant) in seen:
            continue
        seen.add((c.kind, c.plant))
        sc = scenario_from_dict(case_scenario(c, base, motor_spec), source=f"the certificate's {c.kind} run",
                                base_dir=base_dir)
        build(sc, motor=off_nominal_motor(motor, c.plant))

    def run() -> Certificate:
        t0 = time.perf_counter()
        rows = run_cases(cases, base, motor_spec, motor, base_dir, workers)
        cks = checks(rows)
        if saturated and not quick:
            cks.append(Check("holds, off-nominal plants", False, "not run: the tolerances scale the linear "
                             "inductance model, not the saturation data", "run", "verify the linear plant "
                             "(a scenario without [saturation]) for the tolerances", 0, 0))
        return Certificate(cks, rows, time.perf_counter() - t0, quick)

    return run


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
    from pathlib import Path

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
    from pathlib import Path

    from linsense.model.motor import load_motor
    from linsense.tune.design import design
    from linsense.tune.export import scenario_dict

    spec = motor_ref(motor_spec)
    motor = load_motor(spec)
    dz = design(motor, drive, spec, analyse=False)
    base = scenario_dict(dz, drive, spec, pole_pitch=motor.pole_pitch)
    cert = prepare(motor, spec, base, base_dir or str(Path.cwd()), v_max=drive.v_max, a_max=drive.a_max,
                   load=dz.load, travel=drive.travel, quick=quick, workers=workers)()
    return dz, cert
