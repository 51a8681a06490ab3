"""make bench: every shipped motor (ecce2010, small30, harmonic and the test motors of
src/linsense/examples/motors/class with their drive data) designed by `linsense tune` and verified
in full and quick (switching inverter with dead time): bandwidths, settling times, stiffness, worst
hold error and p-p, the worst estimation error over the moves at v_max and the speed reached, the
measured tables' distance from the plant's, the certificates' wall times against their targets
(full <= 60 s, quick <= 15 s), and the checks that fail. The square wave's designs follow, for
information (docs/tuning.md, "The square wave")."""

from __future__ import annotations

import time
from pathlib import Path

from class_table import shipped

from linsense.tune.design import DriveData
from linsense.verify.certificate import design_and_verify

ROOT = Path(__file__).parents[1]
FULL_S, QUICK_S = 60.0, 15.0


def main() -> int:
    print(f"{'motor':12s} {'obs':>5s} {'spd':>5s} {'kp_x':>5s} {'step .1':>8s} {'step .75':>8s} "
          f"{'N/mm':>6s} {'hold e':>6s} {'hold pp':>7s} {'move e':>6s} {'v m/s':>5s} {'table':>5s} "
          f"{'full s':>6s} {'quick s':>7s}  failed checks")
    bad = []
    motors = shipped()
    runs = [(n, s, dd, "pulsating") for n, (s, dd) in motors.items()]
    runs += [(n, s, dd, "square") for n, (s, dd) in motors.items() if n != "harmonic"]
    for name, spec, dd0, shape in runs:
        dd = DriveData(**{**vars(dd0), "shape": shape})
        t0 = time.perf_counter()
        dz, cert = design_and_verify(spec, dd, base_dir=str(ROOT))
        full_s = time.perf_counter() - t0
        t0 = time.perf_counter()
        design_and_verify(spec, dd, quick=True, base_dir=str(ROOT))
        quick_s = time.perf_counter() - t0
        rows = cert.rows
        nominal = [r for r in rows if r["plant"] == "nominal"]
        steps = [r.get("settle_s") for r in nominal if r["kind"] == "step"]
        ls = next((r for r in nominal if r["kind"] == "load_step"), {})
        holds = [r for r in nominal if r["kind"] == "hold" and "err_deg" in r]
        moves = [r for r in nominal if "peak_err_deg" in r]
        cals = cert.extra.get("calibrations", {})

        def s(v):
            return "never" if v is None else f"{v:.3f}"

        failed = [c.name for c in cert.checks if not c.passed]
        if shape == "pulsating" and (failed or full_s > FULL_S or quick_s > QUICK_S):
            bad.append(name)
        label = f"{name[:7]} {shape[:3]}"
        print(f"{label:12s} {dz.observer_bw:5.3g} {dz.speed_bw:5.3g} {dz.kp_x:5.3g} {s(steps[0]):>8s} "
              f"{s(steps[1]):>8s} {ls.get('stiffness_n_per_mm', float('nan')):6.3g} "
              f"{max((r['err_deg'] for r in holds), default=float('nan')):6.3g} "
              f"{max((r['pp_deg'] for r in holds), default=float('nan')):7.3g} "
              f"{max((r['peak_err_deg'] for r in moves), default=float('nan')):6.3g} "
              f"{min((r['speed_peak_m_s'] for r in moves), default=float('nan')):5.3g} "
              f"{max((c['max_diff_deg'] for c in cals.values()), default=float('nan')):5.2g} "
              f"{full_s:6.1f} {quick_s:7.1f}  {len(failed)}/{len(cert.checks)}: {', '.join(failed)}",
              flush=True)
    n = len(motors)
    print(f"certificate: {n - len(bad)} of {n} shipped motors verified within {FULL_S:g} s (quick within "
          f"{QUICK_S:g} s) (target: all) {'PASS' if not bad else 'FAIL: ' + ', '.join(bad)}")
    return 1 if bad else 0


if __name__ == "__main__":
    raise SystemExit(main())
