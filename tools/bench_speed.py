"""make bench: the usable speed per motor: every shipped motor (ecce2010,
small30, harmonic and the test motors of src/linsense/examples/motors/class with their drive data)
designed by `linsense tune` for `v_max = V` (linsense.tune.drive_design.design_drive, as tune does)
at each V of a grid up to the bus-limited speed (and at it; then bisected where the 3 deg bound is
crossed), moved out and back at V over at least ten pole pitches on the switching inverter with
dead time, the rated load opposing one way and aiding the other (+- rated, the certificate's quick
loads; linsense.verify.cases.trajectory_case, judged as the certificate's moves at v_max,
linsense.verify.case_runs). Per motor and V: the peak estimation error while moving and once at rest
(electrical deg), a fault, the speed reached; per motor the usable speed (the highest V up to which
every V run has peak <= 3 deg and no fault) against the bus-limited speed, and the errors at 0.8
of it.

The bus-limited speed is the design's own bound on v_max (linsense.tune.design.DriveInputs.v_bus_speed,
what `linsense tune` accepts): at the bus V_dc and the current the application needs (its rated load
+ m a_max, over the force constant, less the rotating or square injection's d-current's share), where the
steady-state voltage (the back-EMF with R_s i_q on one axis, omega L_q i_q normal to them;
linsense.tune.design.fundamental_speed) takes the linear range V_dc / sqrt(3). The same at the
under-voltage trip's bus (V_DC_MIN_FRACTION V_dc) is printed beside it, for information.

The targets (peak <= 3 deg, <= 1 deg at rest at 0.8 of the bus-limited speed) are printed beside
the numbers; missing them is not a failure here (a motor whose EMF estimate the design leaves off,
m20_hv, keeps the HF estimate's speed: docs/tuning.md, "The speed range"). Exit 1 only when a run
errors.

    .venv/bin/python tools/bench_speed.py                       # every motor, the whole grid
    .venv/bin/python tools/bench_speed.py --quick               # ecce2010 and small30, five speeds
    .venv/bin/python tools/bench_speed.py --motors ecce2010,m30_low
"""

from __future__ import annotations

import argparse
import math
import time
import traceback
from pathlib import Path

from class_table import shipped

from linsense.errors import InputError
from linsense.model.motor import load_motor
from linsense.plausible import KINDS
from linsense.tune.design import (
    SPEED_CAP_MARGIN,
    V_DC_MIN_FRACTION,
    DriveData,
    DriveInputs,
)
from linsense.tune.drive_design import design_drive
from linsense.tune.export import scenario_dict
from linsense.verify import criteria as C
from linsense.verify.case_runs import run_cases
from linsense.verify.cases import move_distance, trajectory_case, with_room
from linsense.verify.certificate import motor_ref

ROOT = Path(__file__).parents[1]
PITCHES = 10.0  # each move covers at least this many pole pitches
TARGET_SHARE = 0.8  # the speed the targets are judged at, a share of the bus-limited speed
GRID = (0.25, 0.5, 0.75, 1.0, 1.25, 1.5, 1.75, 2.0, 2.5, 3.0, 3.5, 4.0, 5.0, 6.0, 8.0, 10.0, 12.0, 15.0)
BISECT = 3  # halvings of the step between the last speed that passes and the next (0.25 -> 0.03 m/s)
QUICK_MOTORS, QUICK_GRID = ("ecce2010", "small30"), (0.25, 0.5, 0.75, 1.0)


def bus_limited_speed(motor, dd: DriveData) -> float:
    """The speed at which the fundamental at the application's current takes the bus's linear range,
    m/s: the design's own bound on ``v_max`` (``DriveInputs.v_bus_speed``, what ``linsense tune``
    accepts), within the speed cap's plausible range (``SPEED_CAP_MARGIN v_max`` at most the speed of
    linear motors, 20 m/s)."""
    top = KINDS["speed"].high / SPEED_CAP_MARGIN  # (a speed cap beyond linear motors' speeds: refused)
    return min(DriveInputs(motor, dd).v_bus_speed, top)


def under_voltage_speed(motor, dd: DriveData) -> float:
    """The same at the under-voltage trip's bus (``V_DC_MIN_FRACTION V_dc``), m/s: for information."""
    return DriveInputs(motor, dd).speed_driven(V_DC_MIN_FRACTION * dd.v_dc / math.sqrt(3.0))


def run_speed(spec: str, dd0: DriveData, v: float, workers: int | None) -> dict:
    """Design the drive for ``v_max = v`` and run the moves at ``v``: the worst row's figures."""
    spec = motor_ref(spec)
    motor = load_motor(spec)
    dd = DriveData(**{**vars(dd0), "v_max": v})
    try:
        made = design_drive(motor, dd, source=spec, analyse=False, startup=False)
    except InputError as e:  # (tune refuses this speed: a result, not an error of the bench)
        return {"refused": str(e)}
    base = scenario_dict(made, motor_ref=spec)
    tau = motor.pole_pitch
    d = max(PITCHES * tau, move_distance(tau, v, dd.a_max))
    cases = [with_room(trajectory_case(tau, v, dd.a_max, f * made.design.load, d), tau)
             for f in C.TRAJ_LOADS_QUICK]
    rows = run_cases(cases, base, spec, motor, str(ROOT), workers)
    faults = [f"{r['why'].removeprefix('fault: ')} ({r['load_n']:+.3g} N)" for r in rows
              if r["fault"] != "none" or r["why"] == "did not finish"]
    done = [r for r in rows if "peak_err_deg" in r]  # (a run that faulted has no figures)
    nan = float("nan")
    return {
        "peak": max((r["peak_err_deg"] for r in done), default=nan),
        "rest": max((r["est_err_deg"] for r in done), default=nan),
        "reached": min((r["speed_peak_m_s"] for r in done), default=nan),
        "fault": ", ".join(faults),
        "distance": d,
    }


def passes(r: dict) -> bool:
    """Whether a speed's moves are usable: designed, no fault, peak <= 3 deg."""
    return "refused" not in r and not r["fault"] and r["peak"] <= C.TRAJ_PEAK_ERR_DEG


def bracket(results: list[tuple[float, dict]]) -> tuple[float, float | None]:
    """The last speed of the grid's passing run from the bottom (0: none) and the first that does
    not pass (None: every one passes)."""
    lo = 0.0
    for v, r in sorted(results, key=lambda vr: vr[0]):
        if not passes(r):
            return lo, v
        lo = v
    return lo, None


def run_and_print(name: str, spec: str, dd: DriveData, v: float, mark: str, workers: int | None,
                  results: list[tuple[float, dict]]) -> bool:
    """Run the moves at ``v``, print their row and append it to ``results``; False when it errors."""
    t0 = time.perf_counter()
    try:
        r = run_speed(spec, dd, v, workers)
    except Exception:  # (a run that errors: reported, and the bench fails)
        traceback.print_exc()
        return False
    results.append((v, r))
    if "refused" in r:
        print(f"{name:11s} {v:5.3g}{mark} {'':>7s} {'':>8s} {'':>8s} {'':>7s}  {'':>6s}  "
              f"refused: {r['refused']}", flush=True)
        return True
    line = (f"{name:11s} {v:5.3g}{mark} {r['distance'] * 1e3:7.0f} {r['peak']:8.2f} {r['rest']:8.2f} "
            f"{r['reached']:7.3g}  {time.perf_counter() - t0:6.1f}  {r['fault'] or '-'}")
    print(line.replace("     nan", "       -"), flush=True)
    return True


def usable(results: list[tuple[float, dict]]) -> float:
    """The highest speed up to which every speed run has peak <= 3 deg and no fault (0: none)."""
    return bracket(results)[0]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="ecce2010 and small30, 0.25 to 1 m/s and 0.8 of "
                    "the bus-limited speed")
    ap.add_argument("--motors", help="comma-separated names (default: every shipped motor)")
    ap.add_argument("--workers", type=int, default=None, help="threads for the runs (default: one per core)")
    args = ap.parse_args()
    motors = shipped()
    names = args.motors.split(",") if args.motors else list(QUICK_MOTORS if args.quick else motors)
    unknown = [n for n in names if n not in motors]
    if unknown:
        ap.error(f"--motors: unknown {', '.join(unknown)} (one of {', '.join(motors)})")
    grid = QUICK_GRID if args.quick else GRID
    print(f"moves out and back over >= {PITCHES:g} pole pitches at V, +-rated load, switching inverter with "
          f"dead time; target at {TARGET_SHARE:g} v_bus: peak <= {C.TRAJ_PEAK_ERR_DEG:g} deg, at rest <= "
          f"{C.TRAJ_REST_ERR_DEG:g} deg, no fault")
    print(f"{'motor':11s} {'V m/s':>6s} {'move mm':>7s} {'peak deg':>8s} {'rest deg':>8s} {'reached':>7s}  "
          f"{'wall s':>6s}  fault / refusal")
    summary, errors = [], []
    for name in names:
        spec, dd = motors[name]
        motor = load_motor(motor_ref(spec))
        v_bus, v_uv = bus_limited_speed(motor, dd), under_voltage_speed(motor, dd)
        v_target = round(TARGET_SHARE * v_bus, 3)
        top = math.floor(v_bus * 1e3) / 1e3  # (rounded down: tune refuses a v_max beyond v_bus)
        speeds = sorted({v for v in grid if v < top} | {v_target, top})
        results = []
        for v in speeds:
            if not run_and_print(name, spec, dd, v, "*" if v == v_target else " ", args.workers, results):
                errors.append(f"{name} at {v:g} m/s")
        for _ in range(BISECT):  # (the usable speed between the last speed that passes and the next)
            lo, hi = bracket(results)
            if hi is None:
                break
            v = round(0.5 * (lo + hi), 3)
            if not run_and_print(name, spec, dd, v, "~", args.workers, results):
                errors.append(f"{name} at {v:g} m/s")
                break
        at = dict(results).get(v_target, {})
        summary.append((name, usable(results), v_bus, v_uv, v_target, at))
    print(f"\n{'motor':11s} {'usable m/s':>10s} {'v_bus m/s':>9s} {'share':>5s} {'v_uv m/s':>8s}   "
          "at 0.8 v_bus: "
          f"{'V':>5s} {'peak':>6s} {'rest':>6s}  (target <= {C.TRAJ_PEAK_ERR_DEG:g} / <= "
          f"{C.TRAJ_REST_ERR_DEG:g} deg, no fault)")
    for name, v_ok, v_bus, v_uv, v_target, at in summary:
        fig = ("refused" if "refused" in at else "error" if not at else
               f"{at['peak']:6.2f} {at['rest']:6.2f}  {'fault: ' + at['fault'] if at['fault'] else ''}")
        fig = fig.replace("   nan", "     -")
        print(f"{name:11s} {v_ok:10.3g} {v_bus:9.3g} {v_ok / v_bus:5.0%} {v_uv:8.3g}   {'':13s} "
              f"{v_target:5.3g} {fig}")
    if errors:
        print(f"bench_speed: FAIL, runs that errored: {'; '.join(errors)}")
        return 1
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
