"""The hand-over between the HF and the EMF estimates and the injection's fade, in closed loop
(docs/theory.md section 11, "The hand-over"; the C blocks ``ls_fuse`` and ``ls_emf`` in ``ls_drive``'s
SPEED step).

Every run is a drive designed as ``linsense tune --v-max V`` designs it
(:func:`~linsense.tune.drive_design.design_drive` and :func:`~linsense.tune.export.scenario_dict`)
and moved as the certificate moves it (:func:`~linsense.verify.cases.trajectory_case`,
:func:`~linsense.verify.case_runs.case_scenario`: the switching inverter with the drive's dead time),
on ecce2010 and on the class motor m60_pos20k, with every PWM period recorded. The drive's state
(the injection's flag and amplitude, the EMF error's weight) is read after each period: the loop is
``ls_sim_continue`` one period at a time, bit for bit one ``ls_sim_run``.

The measures (the docstrings of the tests say which is which, docs/theory.md the numbers):

- the *offset's move* across the band: the error's mean over one pole pitch of travel just outside
  the band on its HF side (up to ``v_lo``) against the same just outside its EMF side (from
  ``v_hi``), electrical degrees. A pitch's mean removes the error's ripple at the electrical period
  (the end effect's, the table's residual).
- the *jump*: the largest change of that one-pitch mean over one pitch of travel, from the band's
  entry to one pitch past its exit: what the estimate moves within a pitch while the weight
  moves. A switch at one speed puts the whole difference of the two estimates' offsets into one
  pitch; the blend spreads it over the band.
- the *transient*: the largest |error| inside the band less the largest |error| in the pitch just
  outside each end: what the hand-over adds to the error the drive has on either side.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from linsense._ctrl import ffi, lib

from conftest import class_drive
from linsense.ctrl import FUSE_EMF_OFF, FUSE_EMF_ON
from linsense.model.motor import load_motor
from linsense.scenario.load import scenario_from_dict
from linsense.sim.build import build
from linsense.sim.core import _c_commands, _outputs
from linsense.tune.design import DriveData
from linsense.tune.drive_design import design_drive
from linsense.tune.export import scenario_dict
from linsense.verify.case_runs import case_scenario
from linsense.verify.cases import trajectory_case

#: the bounds the whole-speed-range work set itself ("Numbers": hand-over jump and transients), electrical deg
JUMP_MAX_DEG = 0.3
TRANSIENT_MAX_DEG = 1.0
#: the peak error asserted over a whole move, electrical deg (the target 3 deg; measured 1.2-1.6 deg)
PEAK_DEG = 2.0
SIGNALS = ("t", "x", "v", "v_est", "theta_err", "duty")


def _design(name: str, v_max: float):
    """The drive ``tune --v-max v_max`` designs: (motor spec, motor, DriveDesign, scenario dict, a_max)."""
    spec, dd = class_drive(name)
    motor = load_motor(spec)
    made = design_drive(motor, DriveData(**{**vars(dd), "v_max": v_max}), source=spec, analyse=False,
                        startup=False)
    assert made.handover is not None and made.handover.on, made.handover
    return spec, motor, made, scenario_dict(made, motor_ref=spec), dd.a_max


def _run(spec: str, base: dict, case, observer: dict | None = None, inverter: dict | None = None) -> dict:
    """One certificate move, every period recorded, the drive's hand-over state read after each."""
    sc = case_scenario(case, base, spec)
    sc["record"]["decimate"] = 1
    sc["observer"].update(observer or {})
    if sc["observer"].get("emf") is False:  # (its band's keys would have no effect: refused)
        for key in ("emf_lpf_hz", "handover_v_lo", "handover_v_hi", "inject_v_on", "inject_v_off",
                    "handover_settle_s"):
            sc["observer"].pop(key, None)
    sc["inverter"].update(inverter or {})
    b = build(scenario_from_dict(sc, source=f"<test_handover: {case.name}>", base_dir="."))
    d, n = b.drive.state, int(b.n_steps)
    arrays, out = _outputs(n + 2, SIGNALS, ())
    cmds, n_cmds = _c_commands(b.commands)
    res, state, one = ffi.new("ls_sim_result *"), ffi.new("ls_sim_state *"), ffi.new("ls_sim_out *")
    stop = ffi.new("int32_t *", 0)  # (kept alive: a struct field does not own it)
    one.stop = out.stop = stop
    assert lib.ls_sim_begin(b.cfg, state) == lib.LS_OK
    hand = np.zeros((n, 4))
    k = 0
    while k < n and not state.ended:
        for f in SIGNALS:
            setattr(one, f, getattr(out, f) + (3 * k if f == "duty" else k))
        assert lib.ls_sim_continue(b.cfg, d, cmds, n_cmds, state, 1, one, res) == lib.LS_OK
        hand[k] = (d.fuse.inject, d.inj.amp, d.fuse.w, d.fuse.emf_run)
        k += 1
    r = {name: a[:k] for name, a in arrays.items()}
    r.update(inject=hand[:k, 0], amp=hand[:k, 1], w=hand[:k, 2], emf_run=hand[:k, 3] > 0,
             fault=int(state.fault), v_dc=float(sc["inverter"]["v_dc"]), err_deg=np.degrees(r["theta_err"]))
    return r


def _crossings(r: dict, v_lo: float, v_hi: float) -> list[tuple[int, int, bool]]:
    """The band's crossings: (the last sample at or below v_lo, the first at or above v_hi, True) and
    the other way round (False); |v_est|, the speed the block weighs on."""
    a = np.abs(r["v_est"])
    spans, last, side = [], {"lo": None, "hi": None}, None
    for i, s in enumerate(np.where(a <= v_lo, 1, np.where(a >= v_hi, 2, 0))):
        if s == 0:
            continue
        now = "lo" if s == 1 else "hi"
        if side is not None and side != now and last[side] is not None:
            spans.append((last[side], i, now == "hi"))
        side, last[now] = now, i
    return spans


def _measures(r: dict, tau: float, i0: int, i1: int) -> dict:
    """The offset's move, the jump and the transient of one crossing (module docstring), deg.

    From the pitch of travel before the band's entry (sample i0) to the pitch past its exit (i1), or to
    where the mover stops when that is nearer (a move braking to rest within a pitch of v_lo)."""
    x, e = r["x"], r["err_deg"]
    way = np.sign(x[i1] - x[i0])
    k0 = i0
    while k0 > 0 and abs(x[k0 - 1] - x[i0]) < tau and way * (x[k0] - x[k0 - 1]) > 0.0:
        k0 -= 1
    end = i1
    while end + 1 < len(x) and abs(x[end + 1] - x[i1]) < tau and way * (x[end + 1] - x[end]) > 0.0:
        end += 1  # (one pitch, or to the stop where the move ends within it)
    xs = way * x[k0:end + 1]  # (increasing)
    c = np.concatenate(([0.0], np.cumsum(e[k0:end + 1])))
    j = np.arange(len(xs))
    start = np.searchsorted(xs, xs - tau, side="right")  # (the pitch of travel ending at each sample)
    mean = (c[j + 1] - c[start]) / (j + 1 - start)
    ok = j >= i0 - k0  # (a whole pitch behind: from the band's entry on)
    back = start - 1  # (the pitch ending where this one starts)
    jump = float(np.abs(mean[ok & (back >= i0 - k0)] - mean[back[ok & (back >= i0 - k0)]]).max())
    outside = max(np.abs(e[k0:i0 + 1]).max(), np.abs(e[i1:end + 1]).max())
    return {"move": abs(float(mean[-1] - mean[i0 - k0])), "jump": jump,
            "transient": float(np.abs(e[i0 + 1:i1]).max() - outside)}


#: (motor, v_max designed and moved at): above the band and the injection's v_off (ecce2010's band
#: 0.39-0.77 m/s, v_off 0.90; m60_pos20k's 0.49-0.98 m/s, v_off 1.16)
HANDOVER_RUNS = (("ecce2010", 1.0), ("m60_pos20k", 1.4))


#: pole pitches of travel the ramp takes through the band (its acceleration follows)
BAND_PITCHES = 8.0


@pytest.mark.parametrize(("name", "v_max"), HANDOVER_RUNS)
def test_handover_jump_and_transient(name, v_max):
    """A slow ramp through the band (a constant acceleration that takes :data:`BAND_PITCHES` pole
    pitches across it, at most the application's: ecce2010 0.50 m/s^2, m60_pos20k 0.76), up and down,
    out and back, rated load opposing and aiding: eight crossings per motor.

    Measured (switching inverter, dead time): jump <= 0.11 / 0.12 deg, transient <= 0.61 / 0.33 deg,
    offset's move <= 0.24 / 0.31 deg, peak 1.62 / 1.34 deg (ecce2010 / m60_pos20k). Asserted: the
    jump <= 0.3 deg (the target's "estimate's jump at hand-over"), the transient <= 1 deg (its
    "hand-over transients"), the offset's move <= 0.5 deg, the peak <= 2 deg (3 the target's), the
    injection off at the top speed and at full amplitude below the band, no fault. Without the
    feature it fails: ``observer.emf = false`` (the HF estimate alone) peaks at 3.1-3.6 / 3.2 deg with
    offset moves to 0.64 / 0.83 deg; a switch instead of the blend (``handover_v_lo`` = 0.999
    ``handover_v_hi``) jumps 0.42-0.60 / 0.62-0.97 deg with transients to 1.24 / 1.20 deg and peaks
    2.6 / 2.2 deg."""
    spec, motor, made, base, a_app = _design(name, v_max)
    h, tau = made.handover, motor.pole_pitch
    a = min(a_app, (h.v_hi**2 - h.v_lo**2) / (2.0 * BAND_PITCHES * tau))
    worst = {"move": 0.0, "jump": 0.0, "transient": -math.inf}
    for sign in (1.0, -1.0):
        case = trajectory_case(tau, v_max, a, sign * made.design.load, v_max**2 / a + 4 * tau)
        r = _run(spec, base, case)
        assert r["fault"] == 0
        spans = _crossings(r, h.v_lo, h.v_hi)
        assert [up for *_, up in spans] == [True, False, True, False]
        for i0, i1, _ in spans:
            m = _measures(r, tau, i0, i1)
            worst = {k: max(worst[k], m[k]) for k in worst}
        assert np.abs(r["err_deg"]).max() <= PEAK_DEG
        top = np.abs(r["v"]) > 0.98 * v_max
        assert top.any() and r["amp"][top].max() == 0.0  # (faded out at the top speed)
        low = (np.abs(r["v_est"]) < h.v_lo) & (np.abs(r["v"]) > 0.05)
        assert r["amp"][low].min() == pytest.approx(base["injection"]["amplitude"], rel=1e-6)
        # the EMF estimate idle well below the band (its filters from FUSE_EMF_ON v_lo: the step's
        # time), running well above that, and weighed only while it runs
        v_est = np.abs(r["v_est"])
        assert not r["emf_run"][v_est < 0.9 * FUSE_EMF_OFF * h.v_lo].any()
        assert r["emf_run"][v_est > 1.1 * FUSE_EMF_ON * h.v_lo].all()
        assert not (r["w"][~r["emf_run"]] > 0.0).any()
    print(f"{name} at {a:.2f} m/s^2: offset move {worst['move']:.3f}, jump {worst['jump']:.3f}, transient "
          f"{worst['transient']:.3f} deg")
    assert worst["jump"] <= JUMP_MAX_DEG
    assert worst["transient"] <= TRANSIENT_MAX_DEG
    assert worst["move"] <= 0.5


@pytest.mark.parametrize(("name", "v_max"), HANDOVER_RUNS)
def test_hover_in_the_band_and_at_v_off(name, v_max):
    """The speed held at the band's middle and at the injection's v_off (a move cruising there over ten
    pole pitches; the estimated speed ripples about +-2 % around it), rated load both ways: in the
    band the injection never toggles, stays at full amplitude and the weight stays inside (0, 1);
    at v_off the injection's flag changes twice per move (off once on the way up, on once braking)
    however often the speed crosses v_off (ecce2010: 258-274 changes with v_on a hair below v_off,
    which fails here), and the error stays within the bound."""
    spec, motor, made, base, a_max = _design(name, v_max)
    h, tau = made.handover, motor.pole_pitch
    amp = base["injection"]["amplitude"]
    for v_c, where in ((0.5 * (h.v_lo + h.v_hi), "band"), (h.v_off, "v_off")):
        for sign in (1.0, -1.0):
            case = trajectory_case(tau, v_c, a_max, sign * made.design.load, v_c**2 / a_max + 10 * tau)
            r = _run(spec, base, case)
            assert r["fault"] == 0
            cruise = np.abs(np.abs(r["v"]) - v_c) < 0.02 * v_c
            assert cruise.sum() / base["inverter"]["f_pwm"] * v_c >= 5.0 * tau  # (5 pitches at least)
            toggles = int(np.abs(np.diff(r["inject"])).sum())
            print(f"{name} hover at {where} ({v_c:.3f} m/s), load {sign:+g}: {toggles} changes of the flag, "
                  f"peak {np.abs(r['err_deg']).max():.2f} deg, cruise |v_est| "
                  f"{np.abs(r['v_est'][cruise]).min():.3f}-{np.abs(r['v_est'][cruise]).max():.3f} m/s")
            if where == "band":
                assert toggles == 0
                assert np.all(r["amp"][cruise] == pytest.approx(amp, rel=1e-6))
                assert 0.0 < r["w"][cruise].min() and r["w"][cruise].max() < 1.0
            else:
                assert toggles == 4  # (off and on, out and back)
                v_c_est = np.abs(r["v_est"][cruise])
                assert v_c_est.max() > h.v_off > v_c_est.min()  # (the speed crosses v_off, often)
            assert np.abs(r["err_deg"]).max() <= PEAK_DEG


def test_the_fade_frees_the_voltage():
    """ecce2010 designed for and moved at 1.4 m/s against 1.3 times the rated load (32.5 N opposing
    the move out): with the EMF estimate the injection is off at the top speed, the mover reaches
    1.4 m/s and the fundamental takes more than the 41.6 - 12 = 29.6 V the injection would leave of the
    linear range (34.4 V, the duties' mean over an injection period); with ``observer.emf = false``
    the current loop is limited to that 29.6 V and the mover tops out below 1.2 m/s (1.12 measured).
    (m60_pos20k's bus leaves room for its injection up to its bus-limited speed: not shown there.)"""
    v_max, load_share = 1.4, 1.3
    spec, motor, made, base, a_max = _design("ecce2010", v_max)
    tau = motor.pole_pitch
    v_lin = base["inverter"]["v_dc"] / math.sqrt(3.0)
    v_inj = base["injection"]["amplitude"]
    n_inj = round(base["inverter"]["f_pwm"] / base["injection"]["frequency"])
    case = trajectory_case(tau, v_max, a_max, load_share * made.design.load, v_max**2 / a_max + 10 * tau)
    peaks = {}
    for emf in (True, False):
        r = _run(spec, base, case, observer={"emf": emf})
        assert r["fault"] == 0
        out = (r["v"] > 0) & (r["t"] < 0.5 * r["t"][-1])
        peaks[emf] = float(r["v"][out].max())
        if emf:
            du = r["duty"]
            va = (2 * du[:, 0] - du[:, 1] - du[:, 2]) / 3.0 * r["v_dc"]
            vb = (du[:, 1] - du[:, 2]) / math.sqrt(3.0) * r["v_dc"]
            k = np.ones(n_inj) / n_inj
            v_fund = np.hypot(np.convolve(va, k, "same"), np.convolve(vb, k, "same"))
            top = out & (r["v"] > 0.98 * v_max)
            print(f"fundamental at the top speed: median {np.median(v_fund[top]):.1f} V, linear range "
                  f"{v_lin:.1f} V, less the injection {v_lin - v_inj:.1f} V")
            assert r["amp"][top].max() == 0.0
            assert np.median(v_fund[top]) > v_lin - v_inj + 2.0
    print(f"top speed out: {peaks[True]:.3f} m/s with the EMF estimate, {peaks[False]:.3f} without")
    assert peaks[True] >= 0.99 * v_max
    assert peaks[False] < 0.9 * v_max


def test_the_band_leaves_the_emf_filters_time_to_settle():
    """The EMF estimate's filters are idle below ``FUSE_EMF_ON v_lo`` (the SPEED step's time
    budget); the design keeps ``v_lo`` where, accelerating at ``a_max``, they have
    :data:`~linsense.tune.handover.SETTLE_TAUS` time constants of their low-pass before the speed
    reaches ``v_lo``. ecce2010's application (1 m/s^2) leaves the band where the EMF's bound puts it;
    at 100 m/s^2 the band moves up to that speed, ``v_hi`` with it, and the design says why."""
    from linsense.tune.handover import BAND_RATIO, SETTLE_TAUS, design_handover

    motor = load_motor("ecce2010")
    kw = dict(v_dc=72.0, f_pwm=16e3, dead_time=1e-6, i_mag=2.0, demod_lpf=300.0, ramp_time=0.01,
              v_cap=3.0, shape="pulsating")
    slow = design_handover(motor, a_max=1.0, **kw)
    fast = design_handover(motor, a_max=100.0, **kw)
    t_emf = SETTLE_TAUS / (2.0 * math.pi * slow.f_lpf)
    for h, a in ((slow, 1.0), (fast, 100.0)):
        assert h.on
        assert (1.0 - FUSE_EMF_ON) * h.v_lo >= a * t_emf * (1.0 - 1e-12)
        assert h.v_hi >= BAND_RATIO * h.v_lo * (1.0 - 1e-12)
    assert slow.v_hi == pytest.approx(slow.v_emf) and "settled" not in slow.limit
    assert fast.v_lo == pytest.approx(100.0 * t_emf / (1.0 - FUSE_EMF_ON))
    assert fast.v_lo > slow.v_lo and fast.v_hi > slow.v_hi
    assert "settled" in fast.limit


@pytest.mark.parametrize("shape", ["rotating", "square"])
def test_the_shapes_without_an_emf_step_say_so(run_cli, tmp_path, shape):
    """The rotating vector and the square wave have no EMF step: the design's hand-over is off and
    its line says why (it said the speed cap stayed below the band, with the cap above it)."""
    from linsense.tune.handover import design_handover

    kw = dict(v_dc=72.0, f_pwm=16e3, dead_time=1e-6, i_mag=2.0, demod_lpf=300.0, ramp_time=0.01, a_max=1.0,
              v_cap=3.0)
    h = design_handover(load_motor("ecce2010"), shape=shape, **kw)
    assert not h.on and h.v_lo < 3.0 and f"the {shape} injection has no EMF step" in h.limit
    assert design_handover(load_motor("ecce2010"), shape="pulsating", **kw).on
    for v_max in ("1.0", "0.2"):  # (the cap above the band's start and below it)
        r = run_cli("tune", "--motor", "ecce2010", "--v-max", v_max, "--injection", shape, "--no-verify",
                    "--out", str(tmp_path / "d.toml"))
        assert r.code == 0, r.err
        line = next(ln for ln in (r.out + r.err).splitlines() if "hand-over" in ln)
        assert f"off: the {shape} injection has no EMF step" in line and "stays below" not in line, v_max


@pytest.mark.parametrize("section, keys, text", [
    ("observer", {"emf": False, "handover_v_lo": 0.4},
     "observer.handover_v_lo: 0.4 has no effect with observer.emf"),
    ("observer", {"emf": False, "emf_lpf_hz": 200.0}, "observer.emf_lpf_hz: 200.0 has no effect"),
    ("observer", {"dead_time_model": "interpolated", "dead_time_adapt": True},
     "observer.dead_time_adapt: True has no effect with observer.dead_time_model = 'interpolated'"),
    ("calibration", {"slope": 0.5},
     "calibration.slope: 0.5 has no effect with control.mode = 'sensorless_lut'"),
    ("observer", {"emf": True, "handover_v_lo": 385.0, "handover_v_hi": 771.0, "inject_v_on": 784.0,
                  "inject_v_off": 901.0}, "did you type mm/s? (385 mm/s is 0.385 m/s)"),
    # (one key in mm/s is named itself, not the next key of the order; a key given against a
    # designed one is the one named; a band beyond the observer's clamp never hands over)
    ("load", {"type": "step", "force": 10.0, "force_after": 20.0},
     "load.force: 10.0 has no effect with load.type = 'step' at load.time = 0"),
    ("observer", {"emf": True, "handover_v_lo": 400.0, "handover_v_hi": 0.8},
     "observer.handover_v_lo: 400 m/s is outside the range of linear motors [0, 20] m/s: did you type mm/s?"),
    ("observer", {"emf": True, "handover_v_lo": 0.4, "handover_v_hi": 5.0},
     "observer.handover_v_hi: must be at most observer.inject_v_on = "),
    ("observer", {"emf": True, "handover_v_lo": 3.0, "handover_v_hi": 4.0, "inject_v_on": 4.0,
                  "inject_v_off": 4.5},
     "observer.handover_v_lo: 3 m/s must be below the speed of the observer's clamp"),
])
def test_a_key_of_the_speed_range_that_does_nothing_is_refused(section, keys, text):
    """No key silently ignored: the EMF's band keys with the EMF estimate off, the adaptation with the
    interpolated dead-time model, the commissioning's slope in another mode (each ran bit for bit as
    without it), and a band typed in mm/s (it ran with a band the speed never reached)."""
    from linsense.errors import InputError

    data = {"motor": "ecce2010", "scenario": {"duration": 0.05}, "reference": {"type": "hold"},
            section: dict(keys)}
    with pytest.raises(InputError) as e:
        build(scenario_from_dict(data, source="s.toml"))
    assert text in str(e.value), str(e.value)


@pytest.mark.parametrize("motor, band, refused", [
    ("ecce2010", (0.002, 0.004), True), ("ecce2010", (0.075, 0.15), True), ("ecce2010", (0.15, 0.3), False),
    ("m45_24v", (0.04, 0.08), True)])
def test_a_band_given_where_the_emf_cannot_be_trusted_is_refused(motor, band, refused):
    """A hand-made band whose top lies below the speed where the EMF estimate's error bound is within
    10 deg (``EPS_TRUST``; ecce2010 on the switching inverter, a 1 m/s move at 4 m/s^2: 0.30 m/s) is
    refused before the run, naming ``observer.handover_v_hi`` and that speed: such bands ran away
    (2-4 mm/s on ecce2010 to 180 deg and an over-speed fault; m45_24v at 0.04-0.08 m/s, which a
    45 deg bound let through, over-speed at 0.29 s). A band at 0.15-0.3 m/s, half the design's
    (0.40-0.79), runs (1.4 deg)."""
    import linsense
    from linsense.errors import InputError

    data = {"motor": motor, "scenario": {"name": "band", "duration": 1.5},
            "inverter": {"fidelity": "switching"},
            "observer": {"emf": True, "handover_v_lo": band[0], "handover_v_hi": band[1]},
            "reference": {"type": "trajectory", "waypoints_mm": [300.0], "v_max": 1.0, "a_max": 4.0}}
    if motor != "ecce2010":
        data["motor"] = str(class_drive(motor)[0])
        data["inverter"].update(v_dc=24.0, f_pwm=1e4, dead_time=0.5e-6)
        data["controller"] = {"i_max": 4.0, "rated_load": 10.0}
        data["reference"].update(a_max=1.0, waypoints_mm=[800.0])
    if refused:
        with pytest.raises(InputError) as exc:
            linsense.simulate(data)
        assert exc.value.key == "observer.handover_v_hi", str(exc.value)
        assert "where the EMF estimate's error bound" in str(exc.value), str(exc.value)
        assert motor != "ecce2010" or "at least 0.299 m/s" in str(exc.value), str(exc.value)
    else:
        r = linsense.simulate(data)
        assert r.metrics["fault"] == "none" and r.metrics["max_abs_err_deg"] < 3.0, r.metrics


def test_a_band_given_in_a_mode_the_estimate_does_not_steer_is_not_refused():
    """The sensored mode runs the EMF estimate beside the encoder, which steers: a band at 2-4 mm/s is
    no danger there, and not refused (it was, by the check above, before it looked at the mode)."""
    import linsense

    r = linsense.simulate({"motor": "ecce2010", "scenario": {"name": "band", "duration": 1.0},
                           "control": {"mode": "sensored"},
                           "observer": {"emf": True, "handover_v_lo": 0.002, "handover_v_hi": 0.004},
                           "reference": {"type": "trajectory", "waypoints_mm": [200.0], "v_max": 1.0,
                                         "a_max": 4.0}})
    assert r.metrics["fault"] == "none", r.metrics


def test_a_band_the_design_leaves_off_is_refused_not_ignored():
    """Hand-over keys in a file that does not say ``observer.emf``, on a drive whose design leaves the
    EMF estimate off (the default 0.2 m/s: its cap below the band), were silently ignored (the HF drive
    ran); refused, naming the first key given and why the estimate is off."""
    import linsense
    from linsense.errors import InputError

    data = {"motor": "ecce2010", "scenario": {"name": "band", "duration": 1.0},
            "observer": {"handover_v_lo": 0.5, "handover_v_hi": 0.7},
            "reference": {"type": "trajectory", "waypoints_mm": [100.0]}}
    with pytest.raises(InputError) as exc:
        linsense.simulate(data)
    assert exc.value.key == "observer.handover_v_lo", str(exc.value)
    assert "has no effect: the design leaves the EMF estimate off (the speed cap 0.25 m/s" in str(exc.value)
    data["observer"].update(emf=True, handover_v_lo=0.4)  # (on, and a cap that reaches the band)
    data["reference"]["v_max"] = 1.0
    assert linsense.simulate(data).metrics["fault"] == "none"
