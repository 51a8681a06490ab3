"""``linsense identify``: bench file -> measured table -> fit -> motor file, LUTs, report, figures.

Everything is computed, checked and rendered in memory by :func:`identify` and
:func:`render_outputs`; the caller writes the returned files only when all of it succeeded, so a
failed run writes nothing.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from linsense.analysis.hf import psi_lut
from linsense.analysis.model_table import table_to_csv
from linsense.compensation.lut import Lut, build_lut, export
from linsense.errors import InputError
from linsense.identify.bench import BenchData, read_bench_csv
from linsense.identify.emf_record import OpenCircuitFit, pm_phases_from_record, read_emf_csv
from linsense.identify.fit import PITCH_RESIDUAL_SHARE, T_SIGNIFICANT, FitResult, best_pitch, fit_inductances
from linsense.identify.measured_outputs import measured_columns, measured_lut_csv
from linsense.identify.process import MeasuredTable, process_bench
from linsense.model.inductance import InductanceModel
from linsense.model.motor import Friction, Motor, PmPhases, check_motor, check_plausible, motor_to_toml
from linsense.plausible import KINDS, check
from linsense.version import __version__


@dataclass(frozen=True)
class Identification:
    """Result of identifying a motor from a bench file.

    Attributes
    ----------
    data : BenchData
        The bench file's rows.
    table : MeasuredTable
        The measured inductances at the distinct positions.
    fit : FitResult
        The fitted eq. (3) parameters.
    motor : Motor
        The identified motor.
    measured : dict of str to ndarray
        The ``linsense model`` columns at the measured positions
        (:func:`~linsense.identify.measured_outputs.measured_columns`).
    psi_measured : ndarray
        The compensation angle at the measured positions, rad.
    lut_fit : Lut
        The LUT built from the fit.
    resistance_source : str
        Where R_s came from.
    motor_sources : dict of str to str
        Where the pole pitch, force constant and mass came from.
    warnings : list of str
        What was assumed or ignored.
    open_circuit : OpenCircuitFit or None
        The magnets' flux per phase from the open-circuit back-EMF record, if one was given.
    """

    data: BenchData
    table: MeasuredTable
    fit: FitResult
    motor: Motor
    measured: dict[str, np.ndarray]
    psi_measured: np.ndarray
    lut_fit: Lut
    resistance_source: str
    motor_sources: dict[str, str]
    warnings: list[str] = field(default_factory=list)
    open_circuit: OpenCircuitFit | None = None


def _motor_name(name: str | None, bench: str) -> str:
    raw = name if name else Path(bench).stem
    return re.sub(r"[^0-9A-Za-z_.-]", "_", raw) or "identified"


def identify(
    bench: str | Path,
    base: Motor | None = None,
    harmonics: int = 1,
    pole_pitch: float | None = None,
    force_constant: float | None = None,
    mass: float | None = None,
    resistance: float | None = None,
    name: str | None = None,
    points: int = 360,
    emf: str | Path | None = None,
) -> Identification:
    """Identify the HF model of a motor from a bench file.

    Parameters
    ----------
    bench : path
        Bench file (docs/identify.md).
    base : Motor, optional
        A motor whose pole pitch, force constant, mass, friction, PM-flux harmonics (and, for
        amplitude-only data, resistance) complete the identified one.
    harmonics : int
        ``K``: fit even orders 2 .. 2K (1 = the five parameters of eq. 3).
    pole_pitch, force_constant, mass : float, optional
        m, N/A, kg; override ``base``. Required without ``base``.
    resistance : float, optional
        Phase resistance, ohm, for amplitude-only data (0 neglects the resistive drop).
        Ignored (with a warning) for phasor data, which measure it.
    name : str, optional
        Motor name (default: the bench file's stem).
    points : int
        Length of the LUT built from the fit.
    emf : path, optional
        An open-circuit back-EMF record (docs/identify.md): the motor's ``[pm_flux] scale_abc,
        shift_deg_abc`` come from it (else from ``base``, else balanced).

    Returns
    -------
    Identification
        The data, the measured table, the fit and the motor.

    Raises
    ------
    InputError, ModelError
        Bad options or data; a fitted model that :func:`check_motor` refuses.
    """
    src = str(bench)
    tau, k_f, m, sources = _mechanics(base, pole_pitch, force_constant, mass, resistance)
    data = read_bench_csv(bench)
    record = read_emf_csv(emf) if emf is not None else None
    table, R_s, r_note, r_used, warnings = _processed(data, tau, base, resistance)
    warnings = table.warnings + warnings

    fit = fit_inductances(table.theta, table.entries, harmonics, source=src)
    _check_pitch(src, data, tau, harmonics, sources["pole_pitch"], r_used if data.amplitude_only else None)
    model = fit.model()
    _check_fitted(model, src)  # (before the Motor's own range check, which cannot name the bench's units)
    motor = Motor(
        name=_motor_name(name, src), R_s=R_s, pole_pitch=tau, force_constant=k_f, mass=m,
        inductance=model, friction=base.friction if base is not None else Friction(),
        pm_harmonics=base.pm_harmonics if base is not None else (), source=f"{src} (fitted model)",
        pm_phases=base.pm_phases if base is not None else PmPhases(),
    )
    oc = None
    if record is not None:
        oc = pm_phases_from_record(record, tau, motor.psi_pm)
        motor = replace(motor, pm_phases=oc.phases)
        warnings += _against_force_constant(oc, k_f, sources["force_constant"])
    check_plausible(motor)  # (the rest of the table, as the written motor.toml is loaded)
    if base is not None:
        warnings += _against_base(motor, base)
    check_motor(motor)
    measured = measured_columns(table.theta, table.entries)
    psi_meas = np.radians(measured["psi_lut_deg"])
    return Identification(
        data=data, table=table, fit=fit, motor=motor, measured=measured, psi_measured=psi_meas,
        lut_fit=build_lut(motor, points), resistance_source=r_note, motor_sources=sources,
        warnings=warnings, open_circuit=oc,
    )


def _mechanics(base: Motor | None, pole_pitch: float | None, force_constant: float | None,
               mass: float | None, resistance: float | None) -> tuple[float, float, float, dict[str, str]]:
    """The pole pitch, force constant and mass (the options', else ``base``'s), each checked
    against the motor file's table of plausible values, and where each came from."""
    sources: dict[str, str] = {}

    def pick(opt_value, key: str, option: str, why: str):
        if opt_value is not None:
            sources[key] = option
            return float(opt_value)
        if base is not None:
            sources[key] = f"--motor {base.source or base.name}"
            return float(getattr(base, key))
        raise InputError(option, "", f"missing: {why}; give {option} or --motor NAME|PATH")

    tau = pick(pole_pitch, "pole_pitch", "--pole-pitch", "the pole pitch converts position_mm to theta")
    k_f = pick(force_constant, "force_constant", "--force-constant", "motor.toml needs the force constant")
    m = pick(mass, "mass", "--mass", "motor.toml needs the moving mass")
    # (the motor file's table of plausible values, before the bench is read: a pole pitch in mm
    # was refused as "need at least 8 distinct electrical positions")
    for arg, value, kind in (("pole_pitch", pole_pitch, "pole_pitch"), ("force_constant", force_constant,
                                                                         "force_constant"),
                             ("mass", mass, "mass"), ("resistance", resistance, "resistance")):
        if value is not None:
            check("linsense.identify.identify", arg, float(value), kind)
    return tau, k_f, m, sources


def _processed(data: BenchData, tau: float, base: Motor | None,
               resistance: float | None) -> tuple[MeasuredTable, float, str, float | None, list[str]]:
    """The bench data processed (:func:`process_bench`), the resistance, where it came from, the
    resistance given for amplitude-only data (None for phasor data) and the option warnings."""
    r_used = None
    warnings: list[str] = []
    if data.amplitude_only:
        if resistance is not None:
            r_used, r_src = float(resistance), "--resistance"
        elif base is not None:
            r_used, r_src = float(base.R_s), f"R_s of --motor {base.source or base.name}"
        else:
            r_used, r_src = None, ""
        table = process_bench(data, tau, r_used, r_src)
        R_s, r_note = float(r_used), r_src
    else:
        if resistance is not None:
            warnings.append(f"--resistance {resistance:g} ignored: phasor data measure the resistance")
        table = process_bench(data, tau)
        R_s = table.resistance
        r_note = f"identified: mean Re(V_fed/I) over {data.rows} rows"
    return table, R_s, r_note, r_used, warnings


def _check_pitch(src: str, data: BenchData, tau: float, harmonics: int, given: str,
                 resistance: float | None) -> None:
    """Refuse a bench file read with a pole pitch that is not its motor's: another pitch explains
    its inductances much better (:func:`~linsense.identify.fit.best_pitch`, on the physical positions
    as measured). A bench of a 60 mm motor read with the 56 mm of ``--motor ecce2010`` gave a fitted
    motor file without a word (its residual 6.5 times its own pitch's), and read with 30 mm, a
    refusal blaming the fitted model's saliency."""
    span = float(np.ptp(data.position))
    table = process_bench(data, 4.0 * span + 8.0 * tau, resistance, cover=False)  # (no position wraps)
    here = fit_inductances(2.0 * np.pi * table.position / tau, table.entries, harmonics).residual_rms
    pitch, rms = best_pitch(table.position, table.entries, tau, harmonics)
    if rms < PITCH_RESIDUAL_SHARE * here:
        raise InputError(src, "column position_mm",
                         f"read with the pole pitch {tau * 1e3:.4g} mm ({given}), the measured inductances "
                         f"leave {here * 1e6:.3g} uH rms of the model's fit; with a pole pitch of "
                         f"{pitch * 1e3:.4g} mm {rms * 1e6:.3g} uH: the bench of a motor of another pole "
                         f"pitch? give that motor (--motor), or --pole-pitch {pitch * 1e3:.4g}")


#: the fitted inductance this factor off the --motor's is said: a bench file in other units
BASE_FACTOR_MAX = 10.0


def _mean_self(model: InductanceModel) -> float:
    """An inductance model's mean phase self-inductance, H (``L0``, or the mean of its table)."""
    if model.params:
        return float(model.params["L0"])
    theta = np.linspace(0.0, 2.0 * np.pi, 360, endpoint=False)
    return float(np.mean(model.entries(theta)[..., :3]))


def _bench_units(high: bool) -> str:
    """The bench file's slips of unit that make the fitted inductance ``high`` (else low)."""
    return ("column freq_hz in kHz (1 for 1000 Hz), or the voltages in mV" if high else
            "the current (I_re, I_im, or I) in mA, or the voltages in kV")


def _against_base(motor: Motor, base: Motor) -> list[str]:
    """A warning when the fitted mean self-inductance is more than :data:`BASE_FACTOR_MAX` times
    off the one of the ``--motor`` that gives the mechanics (a bench file in mA within the range of
    currents was identified as a motor 500 times below it without a word)."""
    L_fit, L_base = _mean_self(motor.inductance), _mean_self(base.inductance)
    if not L_base > 0.0 or 1.0 / BASE_FACTOR_MAX <= L_fit / L_base <= BASE_FACTOR_MAX:
        return []
    high = L_fit > L_base
    return [f"the fitted L0 = {L_fit:.4g} H is {max(L_fit / L_base, L_base / L_fit):.3g} times "
            f"{'above' if high else 'below'} the L0 = {L_base:.4g} H of --motor {base.name}: is "
            f"{_bench_units(high)}? A bench file is in Hz, A and V peak (docs/identify.md)"]


#: the back-EMF's positive sequence this share off the force constant's psi_pm is said: the force
#: constant given is not this motor's (an imbalance of the end phases moves it by a few per cent)
PSI_PM_WARN = 0.1


def _against_force_constant(oc: OpenCircuitFit, k_f: float, given: str) -> list[str]:
    """A warning when the record's positive sequence ``|P|`` is more than :data:`PSI_PM_WARN` off 1:
    the scales are relative to the ``psi_pm`` of the force constant given, which the back-EMF then
    contradicts (the force constant it implies, ``|P| cos(arg P) k_f``, is named)."""
    p = abs(oc.positive)
    if abs(p - 1.0) <= PSI_PM_WARN:
        return []
    k_emf = p * np.cos(np.angle(oc.positive)) * k_f
    return [f"the back-EMF of {Path(oc.source).name} links {p:.3g} times the psi_pm of the force constant "
            f"{k_f:.4g} N/A ({given}): scale_abc carries it; is that this motor's force constant? The "
            f"thrust per q ampere it implies is {k_emf:.4g} N/A"]


def _check_fitted(model: InductanceModel, src: str) -> None:
    """Refuse a fitted model outside the range of real linear motors, naming the bench file's units
    that explain it: its mean self-inductance 1000 times off is a frequency in kHz or voltages in mV
    (above), currents in mA or voltages in kV (below). A bench file in mA was identified as a 2.75 uH
    motor, one in kHz written as a motor file that linsense then refused to load."""
    k = KINDS["inductance"]
    L0 = _mean_self(model)
    if not k.holds(L0):
        units = _bench_units(L0 > k.high)
        raise InputError(src, "", f"the fitted mean self-inductance L0 = {L0:.4g} H is outside the range of "
                         f"{k.of} [{k.low:g}, {k.high:g}] H: is {units}? A bench file is in Hz, A and V "
                         "peak (docs/identify.md)")


def fit_report(ident: Identification) -> dict:
    """The content of ``fit.json`` (SI units, rad).

    Parameters
    ----------
    ident : Identification
        The identification.

    Returns
    -------
    dict
        ``format``, ``fit`` (parameters, standard errors), ``end_effect``, ``reciprocity``, ``lut``...
    """
    t, f, mo = ident.table, ident.fit, ident.motor
    i_worst, pair = t.reciprocity_worst()
    lut_diff = np.angle(np.exp(1j * (ident.psi_measured - psi_lut(mo, t.theta))))
    return {
        "format": "linsense-identify",
        "version": 1,
        "generator": f"linsense {__version__}",
        "source": ident.data.source,
        "form": "amplitude-only" if ident.data.amplitude_only else "phasor",
        "rows": ident.data.rows,
        "positions": int(t.theta.size),
        "frequency_hz": t.frequency,
        "pole_pitch_m": mo.pole_pitch,
        "motor": {"name": mo.name, "R_s": mo.R_s, "force_constant": mo.force_constant, "mass": mo.mass,
                  "sources": {"R_s": ident.resistance_source, **ident.motor_sources}},
        "resistance": {"R_s": mo.R_s, "std_over_rows": t.resistance_std, "source": ident.resistance_source},
        "fit": {
            "harmonics": f.harmonics,
            "orders": list(range(2, 2 * f.harmonics + 1, 2)),
            "unit": "H",
            "parameters": f.values,
            "standard_errors": f.stderr,
            "residual_rms": f.residual_rms,
            "sigma": f.sigma,
            "dof": f.dof,
            "method": "ordinary linear least squares over the six entries at every measured position; "
                      "standard errors from sigma^2 (A'A)^-1, sigma^2 = RSS/(n-p) of the self and of "
                      "the mutual entries",
        },
        "end_effect": {
            "dM0": f.values["dM0"],
            "stderr": f.stderr["dM0"],
            "t": f.end_effect_t,
            "threshold": T_SIGNIFICANT,
            "significant": f.end_effect_significant,
        },
        "reciprocity": {
            "max_relative": t.reciprocity_max,
            "rms_relative": t.reciprocity_rms,
            "worst_pair": pair,
            "worst_position_m": float(t.position[i_worst]),
            "definition": "(M_jk from k fed - M_kj from j fed) / |mean of the two|",
        },
        "lut": {
            "measured_points": int(t.theta.size),
            "fit_points": ident.lut_fit.points,
            "psi_lut_peak_measured_rad": float(np.max(np.abs(ident.psi_measured))),
            "psi_lut_peak_fit_rad": float(np.max(np.abs(psi_lut(mo, np.linspace(0, 2 * np.pi, 3600))))),
            "measured_minus_fit_max_rad": float(np.max(np.abs(lut_diff))),
        },
        "warnings": list(ident.warnings),
        **({"open_circuit": open_circuit_report(ident.open_circuit)} if ident.open_circuit else {}),
    }


def open_circuit_report(oc: OpenCircuitFit) -> dict:
    """The ``open_circuit`` entry of ``fit.json``: the record's magnets' flux per phase, its
    standard errors and sequences (SI units, rad).

    Parameters
    ----------
    oc : OpenCircuitFit
        The fit of the record.

    Returns
    -------
    dict
        ``source``, ``form``, ``samples``, ``periods``, ``speed_m_s``, ``noise_rms_v``, ``scale_abc``,
        ``shift_abc_rad``, ``stderr`` (rad, and relative for the scales), ``positive``, ``negative``.
    """
    return {
        "source": oc.source,
        "form": "line-to-line" if oc.line_to_line else "phase-to-star",
        "samples": oc.samples,
        "periods": oc.periods,
        "speed_m_s": oc.speed,
        "noise_rms_v": oc.noise_rms,
        "scale_abc": list(oc.phases.scale),
        "shift_abc_rad": list(oc.phases.shift),
        "stderr": list(oc.stderr),
        "positive": {"magnitude": abs(oc.positive), "angle_rad": float(np.angle(oc.positive))},
        "negative": {"magnitude": abs(oc.negative), "angle_rad": float(np.angle(oc.negative))},
        "method": "least squares of each phase's back-EMF over the speed against the fundamental (with an "
                  "offset and the harmonics as nuisance terms); the standard error of a phase's shift "
                  "(and relative scale) is sigma sqrt(2 mean(1/omega^2)/N) / A_k, sigma the noise",
    }


def render_outputs(ident: Identification) -> dict[str, str]:
    """The model, tables and record of ``linsense identify``, rendered in memory.

    Its figures are :func:`linsense.report.identify_figures.identify_figure_files`'s.

    Parameters
    ----------
    ident : Identification
        The identification.

    Returns
    -------
    dict of str to str
        Relative path to content: ``motor.toml``, ``inductances.csv``, ``lut.csv``, ``lut_fit.csv``,
        ``fit.json``.
    """
    mo = ident.motor
    header = (
        f"# Identified by linsense {__version__} from {Path(ident.data.source).name}: HF model fitted "
        f"with even orders up to {2 * ident.fit.harmonics} (see fit.json).\n"
    )
    return {
        "motor.toml": header + motor_to_toml(mo),
        "inductances.csv": table_to_csv(ident.measured),
        "lut.csv": measured_lut_csv(ident.table.theta, ident.psi_measured),
        "lut_fit.csv": export(ident.lut_fit, "csv"),
        "fit.json": json.dumps(fit_report(ident), indent=1) + "\n",
    }


def summary_lines(ident: Identification) -> list[str]:
    """Human-readable summary for stdout: parameters, end-effect significance, reciprocity.

    Parameters
    ----------
    ident : Identification
        The identification.

    Returns
    -------
    list of str
        The lines.
    """
    f, t = ident.fit, ident.table
    lines = [f"{ident.motor.name}: {t.theta.size} positions, {ident.data.rows} rows, "
             f"R_s = {ident.motor.R_s:.4g} ohm ({ident.resistance_source})"]
    for k, v in f.values.items():
        lines.append(f"  {k:>4} = {v * 1e3:+.5f} mH  +- {f.stderr[k] * 1e3:.5f} mH")
    lines.append(f"  residual RMS {f.residual_rms * 1e6:.3g} uH")
    verdict = "significant" if f.end_effect_significant else "not significant"
    lines.append(f"end-effect dM0 = {f.values['dM0'] * 1e3:+.4f} mH, t = {f.end_effect_t:.1f}: {verdict} "
                 f"(|t| > {T_SIGNIFICANT:g})")
    lines.append(f"reciprocity error: max {100 * t.reciprocity_max:.2f} %, "
                 f"RMS {100 * t.reciprocity_rms:.2f} %")
    oc = ident.open_circuit
    if oc is not None:
        scale = ", ".join(f"{g:.4f}" for g in oc.phases.scale)
        shift = ", ".join(f"{np.degrees(d):+.3f}" for d in oc.phases.shift)
        lines.append(f"magnets' flux per phase ({Path(oc.source).name}, {oc.periods:.3g} periods at "
                     f"{oc.speed:.3g} m/s): scale_abc [{scale}], shift_deg_abc [{shift}] "
                     f"+- {np.degrees(max(oc.stderr)):.2g} deg")
    return lines
