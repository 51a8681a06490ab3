"""The closed loop under the inverter's dead time (docs/simulator.md):
sensorless hold anywhere in the period and the LUT calibration, on the switching inverter."""

from __future__ import annotations

import json

import numpy as np
import pytest

import linsense
from linsense.cli import main
from linsense.studies.calibrate import calibrate

POSITIONS_MM = [56.0 * k / 8 for k in range(8)]


def _hold(x_mm: float, fidelity: str, seconds: float = 3.0):
    r = linsense.simulate(
        {
            "motor": "ecce2010",
            "scenario": {"name": "hold", "duration": seconds},
            "inverter": {"fidelity": fidelity},
            "initial": {"position_mm": x_mm},
            "reference": {"type": "hold"},
            # the former slow loops (README.md's claim; the default design's faster loops, 8 Hz and
            # 20 1/s, hold as well: tests/test_claims.py::test_hold_table)
            "controller": {"speed_bandwidth_hz": 4.0, "kp_x": 10.0},
        }
    )
    w = r.t >= r.t[-1] - 0.3
    err = np.degrees(r.theta_err[w])
    return r.metrics, float(np.mean(err)), float(np.max(np.abs(err))), float(np.ptp(r.x[w])) * 1e3


@pytest.mark.parametrize("x_mm", POSITIONS_MM)
def test_sensorless_hold_switching_no_limit_cycle(x_mm):
    """Switching inverter, 0.8 us dead time, 12 V / 1 kHz on d (the default elliptical injection):
    steady estimation error at most 0.5 deg and no limit cycle (true position within 0.01 mm peak
    to peak) at 8 positions over the period: README.md's claim for the slow loops (4 Hz speed loop).
    (Measured: |bias| <= 0.30 deg, pp <= 0.0004 mm.)"""
    m, bias, peak, pp = _hold(x_mm, "switching")
    assert m["fault"] == "none" and m["stable"], m["unstable_reason"]
    assert abs(bias) <= 0.5, bias
    assert pp <= 0.01, pp
    assert m["bias_deg"] == pytest.approx(bias, abs=1e-3)
    assert m["limit_cycle_mm"] == pytest.approx(pp, abs=1e-5)


def test_average_model_within_what_it_says():
    """The average inverter model does not reach the 0.2 deg agreement on the bias nor every
    limit-cycle verdict at this margin; it says so in metrics.json, and stays within what it says
    (docs/simulator.md, "Fidelity"): its bias within about 0.8 deg of the switching model's, its
    cycles below 0.1 mm (measured: 0.77 deg apart, cycles up to 0.095 mm at holds where the
    switching model is still to 0.001 mm)."""
    for x_mm in POSITIONS_MM:
        ms, bs, _, _ = _hold(x_mm, "switching")
        ma, ba, _, ppa = _hold(x_mm, "average")
        assert "fidelity_note" in ma and "switching" in ma["fidelity_note"] and "fidelity_note" not in ms
        assert abs(ba - bs) <= 0.8 and abs(ba) <= 1.0, (x_mm, ba, bs)
        assert ppa <= 0.1, (x_mm, ppa)


@pytest.mark.parametrize("load", [0.0, 20.0, 40.0])
def test_calibration_as_the_paper(load):
    """The firmware's calibration (paper Fig. 9, its pulsating injection) completes at 0, 20 and
    40 N, on the switching inverter with dead time, and the measured table is within 0.1 deg of the
    model LUT with R_s, README.md's claim (measured: 0.031, 0.037 and 0.030 deg; at 0 N
    without the dither and with the interpolating residual model: 0.75 deg)."""
    cal = calibrate("ecce2010", 56, load, "switching", quad=0.0)
    m = cal.metrics
    assert cal.completed and m["points_done"] == 56 and m["fault"] == "none", m
    assert m["max_diff_deg"] <= 0.1, m
    # the table differs from eq. 12 (no resistance) by the resistive correction, as the model says
    assert m["max_diff_eq12_deg"] > 0.2
    # and without the dither the no-load table would carry the dead-time bias with the interpolating
    # residual model (not a vacuous test: 0.75 deg); the forward model needs no dither (0.20 deg):
    # the numbers docs/simulator.md ("Calibration") writes
    if load == 0.0:
        plain = calibrate("ecce2010", 56, load, "switching", quad=0.0, calibration={"dither_a": 0.0},
                          observer={"dead_time_model": "interpolated"})
        assert f"{plain.metrics['max_diff_deg']:.2f}" == "0.75", plain.metrics["max_diff_deg"]
        fwd = calibrate("ecce2010", 56, load, "switching", quad=0.0, calibration={"dither_a": 0.0})
        assert f"{fwd.metrics['max_diff_deg']:.2f}" == "0.20", fwd.metrics["max_diff_deg"]


def test_calibrate_cli(tmp_path, capsys):
    with pytest.raises(SystemExit) as e:
        main(
            [
                "calibrate",
                "--motor",
                "ecce2010",
                "--positions",
                "16",
                "--load",
                "20",
                "--fidelity",
                "switching",  # (the average model puts the elliptical table 0.31-0.41 deg off)
                "--out",
                str(tmp_path / "c"),
            ]
        )
    assert e.value.code == 0
    m = json.loads((tmp_path / "c" / "metrics.json").read_text())
    assert m["completed"] and m["points"] == 16 and m["max_diff_deg"] <= 0.3
    rows = (tmp_path / "c" / "lut_measured.csv").read_text().splitlines()
    assert rows[0] == "theta_deg,psi_lut_deg" and len(rows) == 17
    assert (tmp_path / "c" / "calibration.png").stat().st_size > 10000
    assert "a 16-point table" in capsys.readouterr().err  # (the firmware's interpolation between points)
    with pytest.raises(SystemExit) as e:
        main(["calibrate", "--motor", "ecce2010", "--quad", "1.5", "--out", str(tmp_path / "d")])
    err = capsys.readouterr().err.strip()
    assert e.value.code == 2 and "--quad" in err and "1.5" in err and err.count("\n") == 0
    # a load beyond the drive's force (K_f i_max = 50 N): no equilibrium to calibrate in, refused in
    # one line naming it (it once ran and stopped on "fault encoder")
    with pytest.raises(SystemExit) as e:
        main(["calibrate", "--motor", "ecce2010", "--positions", "4", "--load", "1000", "--fidelity",
              "average", "--out", str(tmp_path / "e")])
    err = capsys.readouterr().err.strip()
    assert e.value.code == 2 and "load.force: 1000 N" in err and "50 N" in err and err.count("\n") == 0, err
    # a tolerance no window meets: no point is reached; exit 1 with one line, and the figure and
    # metrics still written (no traceback on the empty table)
    sc = tmp_path / "tight.toml"
    sc.write_text('motor = "ecce2010"\n[scenario]\nduration = 1.0\n[reference]\ntype = "hold"\n'
                  "[calibration]\ntol_deg = 1e-9\nt_max = 0.6\n")
    with pytest.raises(SystemExit) as e:
        main(["calibrate", "--scenario", str(sc), "--positions", "4", "--fidelity", "average", "--out",
              str(tmp_path / "e")])
    out, err = capsys.readouterr()
    assert e.value.code == 1 and err.count("\n") == 1 and "did not complete (0 of 4 points" in err, err
    assert "n/a" in out
    m = json.loads((tmp_path / "e" / "metrics.json").read_text())
    assert not m["completed"] and m["points_done"] == 0 and m["max_diff_deg"] is None
    assert (tmp_path / "e" / "calibration.png").stat().st_size > 10000
