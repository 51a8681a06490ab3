"""make bench: each test motor of src/linsense/examples/motors/class (and ecce2010) designed by
`linsense tune` and verified in full (switching inverter with dead time): bandwidths, settling times,
stiffness, worst hold error and p-p, verification wall time, and the checks that fail (issue 22)."""

from __future__ import annotations

import tomllib
from pathlib import Path

from linsense.tune.design import DriveData
from linsense.verify.certificate import design_and_verify

ROOT = Path(__file__).parents[1]
CLASS = ROOT / "src/linsense/examples" / "motors" / "class"


def main() -> int:
    drives = tomllib.loads((CLASS / "drives.toml").read_text())
    drives["ecce2010"] = dict(
        v_dc=72.0, f_pwm=16000.0, dead_time=0.8e-6, i_max=2.5, v_max=0.2, a_max=1.0, load=40.0
    )
    print(
        f"{'motor':11s} {'obs':>5s} {'spd':>5s} {'kp_x':>5s} {'step .1':>8s} {'step .75':>8s} "
        f"{'N/mm':>6s} {'hold e':>6s} {'hold pp':>7s} {'wall':>5s}  failed checks"
    )
    n_failed = 0
    runs = [(name, d, shape) for shape in ("pulsating", "square") for name, d in drives.items()]
    for name, d, shape in runs:
        spec = "ecce2010" if name == "ecce2010" else str(CLASS / f"{name}.toml")
        dd = DriveData(**d, shape=shape)
        dz, cert = design_and_verify(spec, dd, base_dir=str(ROOT))
        rows = cert.rows
        steps = [r.get("settle_s") for r in rows if r["kind"] == "step"]
        ls = next(r for r in rows if r["kind"] == "load_step")
        holds = [r for r in rows if r["kind"] == "hold" and r["plant"] == "nominal" and "err_deg" in r]

        def s(v):
            return "never" if v is None else f"{v:.3f}"

        failed = [c.name for c in cert.checks if not c.passed]
        n_failed += bool(failed)
        label = f"{name[:6]} {shape[:3]}"
        print(
            f"{label:11s} {dz.observer_bw:5.3g} {dz.speed_bw:5.3g} {dz.kp_x:5.3g} {s(steps[0]):>8s} "
            f"{s(steps[1]):>8s} {ls.get('stiffness_n_per_mm', float('nan')):6.3g} "
            f"{max(r['err_deg'] for r in holds):6.3g} {max(r['pp_deg'] for r in holds):7.3g} "
              f"{sum(r['passed'] for r in holds):3d}/{len(holds):2d} "
            f"{cert.wall_s:5.1f}  {len(failed)}/{len(cert.checks)}: {', '.join(failed)}",
            flush=True,
        )


    print(f"certificate: {len(runs) - n_failed} of {len(runs)} designs verified (target: all) "
          f"{'PASS' if n_failed == 0 else 'FAIL'}")
    return 1 if n_failed else 0


if __name__ == "__main__":
    raise SystemExit(main())
