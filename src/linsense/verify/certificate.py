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
    """One line of the certificate."""

    name: str
    passed: bool
    value: str
    bound: str
    cause: str = ""
    runs: int = 0
    failed: int = 0

    def line(self) -> str:
        mark = "PASS" if self.passed else "FAIL"
        n_ok = self.runs - self.failed
        out = f"  {mark}  {self.name:34s} {self.value}  (bound {self.bound}; {n_ok}/{self.runs} runs)"
        if not self.passed and self.cause:
            out += f"\n        likely: {self.cause}"
        return out


@dataclass
class Certificate:
    """The checks, the runs behind them and the wall time of the verification."""

    checks: list[Check]
    rows: list[dict]
    wall_s: float
    quick: bool
    extra: dict = field(default_factory=dict)

    @property
    def passed(self) -> bool:
        return all(c.passed for c in self.checks)

    def lines(self) -> list[str]:
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
        n_bad = sum(not c.passed for c in self.checks)
        if self.passed:
            return ("verified: every check passed" if not self.quick else
                    "quick checks passed (nominal holds and steps only): not verified, run without --quick")
        return f"NOT verified: {n_bad} of {len(self.checks)} checks failed"

    def as_dict(self) -> dict:
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
    """The certificate's checks from the judged runs."""
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
    """The certificate's runs, each built once here (so that a configuration any of them refuses
    ends in one InputError before anything runs or is written); returns a callable that runs them
    and returns the :class:`Certificate`. ``travel`` (m): the stroke the moves must stay within."""
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
    """Run the certificate of the tuned scenario ``base`` (a dict, as ``linsense tune`` writes it)
    for ``motor`` (``motor_spec``: its preset name or absolute file path, the controller's model).

    ``v_max``, ``a_max`` (m/s, m/s^2) and ``load`` (N, rated) are the application's."""
    return prepare(motor, motor_spec, base, base_dir, v_max=v_max, a_max=a_max, load=load, quick=quick,
                   workers=workers)()


def motor_ref(motor_spec: str) -> str:
    """The motor as the certificate's scenarios name it (they run from other folders): a preset's
    name, or the motor file's absolute path."""
    from pathlib import Path

    from linsense.model.motor import names_a_file

    return str(Path(motor_spec).resolve()) if names_a_file(motor_spec) else motor_spec


def design_and_verify(motor_spec: str, drive, *, quick: bool = False, workers: int | None = None,
                      base_dir: str | None = None):
    """``(design, certificate)`` of ``linsense tune`` from Python: the design for the motor
    ``motor_spec`` (a preset or a motor-file path) on ``drive`` (a
    :class:`~linsense.tune.design.DriveData`), and its certificate."""
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
