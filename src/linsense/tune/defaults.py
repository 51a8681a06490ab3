"""The C library's design defaults, generated from the design (one home for each rule and default).

``ls_drive_default_cfg`` (csrc/ctrl/ls_drive.c) is the design of :mod:`linsense.tune.design` for the
reference motor ``ecce2010`` on the default drive (:class:`~linsense.tune.design.DriveData`): its
gains, injection, filters, dither and bus limits come from ``csrc/ctrl/ls_drive_defaults.h``,
which this module writes (``python -m linsense.tune.defaults csrc/ctrl/ls_drive_defaults.h``;
``tests/test_defaults.py`` fails when the committed header differs from what it would write, or
when ``ls_drive.c`` sets one of these fields from a literal). The library's own constants (filter
Q, delay compensation, clamps of the estimators, the calibration's tolerances ...) stay in C, and
Python reads them from the compiled defaults (``linsense.ctrl.drive_default_cfg``).
"""

from __future__ import annotations

import math
import sys

from linsense.analysis.hf import end_anisotropy, mean_dq
from linsense.model.motor import load_motor
from linsense.scenario.bounds import V_DC_MAX_FRACTION, V_DC_MIN_FRACTION
from linsense.tune.design import DriveData, startup_lock_gain
from linsense.tune.drive_design import design_drive
from linsense.tune.startup import StartupDesign

#: the reference motor whose design the C defaults are
REFERENCE_MOTOR = "ecce2010"
#: 1/A, the start-up's saturation data: the FEA's 1.31 %/A of a thin back iron (linsense fea --polarity)
REFERENCE_POLARITY = 0.0131


def default_values() -> list[tuple[str, float, str]]:
    """``(macro, value, what)`` of every generated default (SI units).

    Returns
    -------
    list of (str, float, str)
        Macro name, value and its unit and meaning.
    """
    m = load_motor(REFERENCE_MOTOR)
    made = design_drive(m, DriveData(), source=REFERENCE_MOTOR, analyse=False, polarity=REFERENCE_POLARITY)
    d, dz = made.drive, made.design
    l_d, l_q = mean_dq(m)
    l_ea, l_eb = end_anisotropy(m)
    return _drive_values(m, d, dz, l_d, l_q, l_ea, l_eb) + _handover_values(made.handover) + \
        _startup_values(made.startup)


def _handover_values(h) -> list:
    """The EMF estimate's and the hand-over's defaults (:mod:`linsense.tune.handover`)."""
    return [
        ("LS_DEF_EMF_ON", 1.0 if h.on else 0.0, "-, 1: the EMF estimate and the hand-over on"),
        ("LS_DEF_EMF_LPF", h.f_lpf, "Hz, the EMF's low-pass"),
        ("LS_DEF_EMF_ERR_R", h.err_r, "-, the resistance's uncertainty of the EMF's bound"),
        ("LS_DEF_EMF_ERR_L", h.err_l, "-, the q inductance's"),
        ("LS_DEF_EMF_U_ERR", h.u_err, "V, the inverter's voltage error of the EMF's bound"),
        ("LS_DEF_EMF_I_NOISE", h.i_noise, "A, the current noise of the EMF's bound"),
        ("LS_DEF_HAND_V_LO", h.v_lo, "m/s, the HF error alone up to it"),
        ("LS_DEF_HAND_V_HI", h.v_hi, "m/s, the EMF error alone from it"),
        ("LS_DEF_INJ_V_ON", h.v_on, "m/s, the injection back in below it"),
        ("LS_DEF_INJ_V_OFF", h.v_off, "m/s, the injection out above it"),
        ("LS_DEF_HAND_T_SETTLE", h.t_settle, "s, the demodulator's settling after a fade"),
    ]


def _drive_values(m, d: DriveData, dz, l_d: float, l_q: float, l_ea: float, l_eb: float) -> list:
    """The drive's and its blocks' defaults (all but the start-up's)."""
    return [
        ("LS_DEF_FS", d.f_pwm, "Hz, PWM and control rate"),
        ("LS_DEF_I_MAX", d.i_max, "A, current-reference limit"),
        ("LS_DEF_L_D", l_d, "H, mean L_d of the reference motor"),
        ("LS_DEF_L_Q", l_q, "H, mean L_q"),
        ("LS_DEF_L_EA", l_ea, "H, the end effect's stationary anisotropy, diagonal"),
        ("LS_DEF_L_EB", l_eb, "H, the end effect's stationary anisotropy, off-diagonal"),
        ("LS_DEF_TAU", m.pole_pitch, "m, pole pitch"),
        ("LS_DEF_KF", m.force_constant, "N/A, force constant"),
        ("LS_DEF_MASS", m.mass, "kg, moving mass"),
        ("LS_DEF_R_S", m.R_s, "ohm, phase resistance"),
        ("LS_DEF_CURRENT_KP", dz.current_kp, "V/A, current-loop kp (linsense.tune.design.current_gains)"),
        ("LS_DEF_CURRENT_KI", dz.current_ki, "V/(A s), current-loop ki (linsense.tune.design.current_gains)"),
        ("LS_DEF_SPEED_KP", dz.speed_kp, "N s/m, speed-loop gain (m w_v)"),
        ("LS_DEF_SPEED_KI", dz.speed_ki, "N/m, speed-loop ki (m w_v^2 / 4; 0 sensorless with load_ff)"),
        ("LS_DEF_KP_X", dz.kp_x, "1/s, position-loop gain"),
        ("LS_DEF_V_CAP", dz.v_cap, "m/s, speed-reference cap (and a step's speed)"),
        ("LS_DEF_INJ_AMPLITUDE", dz.v_inj, "V, injection amplitude"),
        ("LS_DEF_INJ_FREQ", dz.f_inj, "Hz, injection frequency"),
        ("LS_DEF_INJ_QUAD", dz.quad, "-, elliptical share kappa"),
        ("LS_DEF_INJ_RAMP_RATE", dz.inj_ramp_rate, "V/s, the injection's ramp"),
        ("LS_DEF_DEMOD_LPF", dz.demod_lpf, "Hz, demodulator low-pass"),
        ("LS_DEF_DEMOD_NOTCH", dz.demod_notch, "Hz, the low-pass's zeros (2 f_inj)"),
        ("LS_DEF_DEMOD_GAIN", dz.demod_gain, "-, L_q / (L_q - L_d) of the means"),
        ("LS_DEF_HF_DELAY", dz.hf_delay, "s, the HF path's delay the estimate is advanced by"),
        ("LS_DEF_OBSERVER_BW", dz.observer_bw, "Hz, HF observer bandwidth (all its poles)"),
        ("LS_DEF_STARTUP_LOCK_GAIN", startup_lock_gain(dz.observer_type, dz.observer_bw, dz.demod_lpf),
         "-, the start-up's gain on the demodulated error while the observer locks"),
        ("LS_DEF_OBSERVER_MECH", 1.0 if dz.observer_type == "mech" else 0.0,
         "-, 1: the mechanical observer with its load estimate fed forward; 0: the PLL"),
        ("LS_DEF_DEAD_TIME", d.dead_time, "s, inverter dead time"),
        ("LS_DEF_V_DC_MIN", d.v_dc * V_DC_MIN_FRACTION, "V, under-voltage trip"),
        ("LS_DEF_V_DC_MAX", d.v_dc * V_DC_MAX_FRACTION, "V, over-voltage trip"),
        ("LS_DEF_TRAJ_V_MAX", d.v_max, "m/s, trajectory speed"),
        ("LS_DEF_TRAJ_A_MAX", d.a_max, "m/s^2, trajectory acceleration"),
        ("LS_DEF_TRAJ_A_STEP", dz.a_step, "m/s^2, a step command's acceleration"),
        ("LS_DEF_DITHER_AMP", dz.dither_a, "A, calibration dither"),
        ("LS_DEF_DITHER_FREQ", dz.dither_hz, "Hz, calibration dither frequency"),
    ]


def _startup_values(su: StartupDesign) -> list:
    """The start-up's defaults: the start-up of :func:`~linsense.tune.drive_design.design_drive` for
    the reference motor with :data:`REFERENCE_POLARITY` (10 mA rms of current noise, a 12-bit ADC);
    the pulse's amplitude to 0.1 V and the decision's threshold to 0.1 mA, as the library has always
    had them. (``t_lock``, which the lock's bandwidth sets, is not a generated default.)"""
    return [
        ("LS_DEF_STARTUP_ERR_LOCK", su.err_lock, "rad, the lock is accepted within it"),
        ("LS_DEF_STARTUP_T_QUIET", su.t_quiet, "s, the injection ramp-down before the pulses, with a margin"),
        ("LS_DEF_STARTUP_V_PULSE", round(su.v_pulse, 1), "V, pulse amplitude (to 0.1 V)"),
        ("LS_DEF_STARTUP_T_PULSE", su.t_pulse, "s, pulse length"),
        ("LS_DEF_STARTUP_T_REST", su.t_rest, "s, zero voltage before each pulse"),
        ("LS_DEF_STARTUP_PAIRS", float(su.pairs), "-, (+, -) pulse pairs for a decision 6 sigma clear"),
        ("LS_DEF_STARTUP_I_MIN", round(su.i_min, 4), "A, smallest |i_diff| for a decision (to 0.1 mA)"),
        ("LS_DEF_STARTUP_T_SETTLE", su.t_settle, "s, HF relock after the pulses"),
    ]


def header() -> str:
    """The text of ``csrc/ctrl/ls_drive_defaults.h``.

    Returns
    -------
    str
        The header's text.

    Raises
    ------
    ValueError
        When a designed default is not finite.
    """
    lines = [
        "/* Generated by `python -m linsense.tune.defaults` from linsense.tune.design: the design for the",
        f" * reference motor {REFERENCE_MOTOR} on the default drive. Do not edit: change the design and",
        " * regenerate (tests/test_defaults.py checks it). Internal to the library (not an API header). */",
        "#ifndef LS_DRIVE_DEFAULTS_H",
        "#define LS_DRIVE_DEFAULTS_H",
        "",
    ]
    for name, value, what in default_values():
        if not math.isfinite(value):
            raise ValueError(f"{name}: not finite ({value!r})")
        lit = f"{value:.9g}"
        if not any(c in lit for c in ".e"):
            lit += ".0"  # (LS_R pastes an f: 16000f would not be a float literal)
        lines.append(f"#define {name} LS_R({lit}) /* {what} */")
    lines += ["", "#endif /* LS_DRIVE_DEFAULTS_H */", ""]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    """``python -m linsense.tune.defaults [OUT]``: the header to OUT, or to standard output.

    Parameters
    ----------
    argv : list of str or None, optional
        The arguments (None: ``sys.argv[1:]``).

    Raises
    ------
    SystemExit
        0 after ``-h``/``--help``, 2 after bad arguments (the usage printed).
    """
    args = sys.argv[1:] if argv is None else argv
    if len(args) > 1 or (args and args[0].startswith("-")):
        sys.stdout.write("usage: python -m linsense.tune.defaults [OUT.h]\n"
                         "  writes csrc/ctrl/ls_drive_defaults.h's text to OUT.h, or to standard output\n")
        raise SystemExit(0 if args and args[0] in ("-h", "--help") else 2)
    text = header()
    if not args:
        sys.stdout.write(text)
        return
    with open(args[0], "w", encoding="utf-8", newline="\n") as f:
        f.write(text)


if __name__ == "__main__":
    main()
