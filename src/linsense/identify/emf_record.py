"""Open-circuit back-EMF records: reading (with every check), writing, emulating, and the magnets'
flux per phase identified from one (``linsense identify --emf``; docs/identify.md, "The magnets'
flux per phase").

The mover is pushed at speed with the winding open; the record is a CSV with one row per sample:
``time_s, position_mm`` and either the three phase-to-star-point voltages ``VA, VB, VC`` or the
three line-to-line ones ``VAB, VBC, VCA`` (V, instantaneous), told apart by the header. The fit is
:func:`linsense.identify.open_circuit.pm_phases_from_emf`'s; this module adds the file, the checks a
bench needs before it (travel, reversal, wiring, speed against the record's noise) and the
standard errors. Every problem raises :class:`~linsense.errors.InputError` naming the file, the
row (line number, the header is row 1) or the column, the value and what is needed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from linsense.errors import InputError
from linsense.identify.open_circuit import phase_values_of_line, pm_phases_from_emf
from linsense.io import check_width, csv_rows, finite_cell
from linsense.model.motor import PmPhases
from linsense.model.motor_schema import PHASES

#: the columns every record has, in the order written
BASE_COLUMNS = ("time_s", "position_mm")
#: the voltages of the phase-to-star form, V
STAR_COLUMNS = ("VA", "VB", "VC")
#: the voltages of the line-to-line form (no star point), V
LINE_COLUMNS = ("VAB", "VBC", "VCA")
#: rad (phase) and relative (amplitude): the largest standard error the record's noise may leave on
#: a phase's ``shift_deg_abc`` (and, the same number, on its ``scale_abc``)
STDERR_MAX = math.radians(0.1)
#: the fundamental of ``VA + VB + VC`` above this share of the phases' mean fundamental is a wiring
#: error (a reversed phase gives 2; the zero sequence of a plausible imbalance stays far below)
STAR_SUM_MAX = 0.5
#: the highest harmonic order of the waveform model whose residual gives the record's noise
NOISE_ORDERS = 15
#: the API's name in the messages of its argument checks
_SRC = "linsense.identify.emf_record"


@dataclass(frozen=True)
class EmfRecord:
    """The samples of an open-circuit back-EMF record (SI units).

    Parameters
    ----------
    time : ndarray, shape (N,)
        Sample times, s, increasing.
    position : ndarray, shape (N,)
        Mover position, m (the HF bench's origin: theta = 0 on the d axis).
    voltage : ndarray, shape (N, 3)
        ``VA, VB, VC`` to the star point, or ``VAB, VBC, VCA`` with ``line_to_line``, V.
    line_to_line : bool
        Whether ``voltage`` holds line-to-line voltages.
    row : ndarray of int, shape (N,), optional
        Line number of each sample in the file (the header is line 1), for messages.
    source : str
        File name, for messages.
    """

    time: np.ndarray
    position: np.ndarray
    voltage: np.ndarray
    line_to_line: bool = False
    row: np.ndarray | None = None
    source: str = "open-circuit record"

    def __post_init__(self) -> None:
        if self.row is None:
            object.__setattr__(self, "row", np.arange(2, np.asarray(self.time).shape[0] + 2))

    @property
    def columns(self) -> tuple[str, ...]:
        """The voltage columns of the record's form."""
        return LINE_COLUMNS if self.line_to_line else STAR_COLUMNS


@dataclass(frozen=True)
class OpenCircuitFit:
    """The magnets' flux per phase identified from a record, with its uncertainty.

    Attributes
    ----------
    phases : PmPhases
        The motor file's ``[pm_flux] scale_abc, shift_deg_abc`` (shift in rad).
    stderr : tuple of float
        Standard error of each phase's shift, rad, and equally of its scale (relative).
    noise_rms : float
        The record's noise, V rms per phase (residual of a harmonic waveform model).
    speed : float
        Mean speed, m/s (signed).
    samples : int
        Number of samples.
    periods : float
        Electrical periods travelled.
    positive : complex
        The positive sequence ``P`` of the fundamentals (docs/theory.md section 10; 1 when balanced).
    negative : complex
        Their negative sequence ``N`` (0 when balanced).
    line_to_line : bool
        Whether the record held line-to-line voltages (per-phase values less their zero sequence).
    source : str
        The record's file.
    """

    phases: PmPhases
    stderr: tuple[float, float, float]
    noise_rms: float
    speed: float
    samples: int
    periods: float
    positive: complex
    negative: complex
    line_to_line: bool
    source: str


# ---------------------------------------------------------------------- reading
def _form(header: list[str], src: str) -> tuple[bool, tuple[str, ...]]:
    """Whether the header is the line-to-line form, and its columns; raise naming a missing one."""
    has = set(header)
    line = not all(c in has for c in STAR_COLUMNS) and any(c in has for c in LINE_COLUMNS)
    cols = BASE_COLUMNS + (LINE_COLUMNS if line else STAR_COLUMNS)
    for c in cols:
        if c not in has:
            raise InputError(src, f"row 1, column {c}", "missing column (need "
                             f"{','.join(BASE_COLUMNS + STAR_COLUMNS)} for phase-to-star voltages, or "
                             f"{','.join(BASE_COLUMNS + LINE_COLUMNS)} for line-to-line ones)")
    return line, cols


def read_emf_csv(path: str | Path) -> EmfRecord:
    """Read and check an open-circuit back-EMF record (docs/identify.md).

    Checks, each naming row and column: missing columns, a row with another number of fields than
    the header, empty, non-numeric and non-finite cells (NaN), times that do not increase.

    Parameters
    ----------
    path : str or Path
        The record.

    Returns
    -------
    EmfRecord
        Its samples, SI units.

    Raises
    ------
    InputError
        The first problem found, naming the row and the column.
    """
    src = str(path)
    rows_in = csv_rows(path, "open-circuit record")
    header = next(rows_in)[1]
    if any(";" in h for h in header) and "time_s" not in header:
        raise InputError(src, "row 1", "semicolon separators are not read: separate the columns with "
                                       "commas (and decimal commas are not read: use a point)")
    line, cols = _form(header, src)
    idx = [header.index(c) for c in cols]
    rows, data = [], []
    for r, row in rows_in:
        check_width(src, r, row, header)
        rows.append(r)
        data.append([finite_cell(src, r, c, row[j].strip()) for c, j in zip(cols, idx, strict=True)])
    if not data:
        raise InputError(src, "", "no data rows after the header")
    a = np.array(data, dtype=float)
    rows_a = np.array(rows)
    bad = np.nonzero(np.diff(a[:, 0]) <= 0.0)[0]
    if bad.size:
        i = int(bad[0]) + 1
        raise InputError(src, f"row {rows_a[i]}, column time_s", f"time {a[i, 0]:.12g} s does not increase "
                         f"(row {rows_a[i - 1]} has {a[i - 1, 0]:.12g} s): one sample a row, in time order")
    return EmfRecord(time=a[:, 0], position=a[:, 1] * 1e-3, voltage=a[:, 2:], line_to_line=line,
                     row=rows_a, source=src)


def emf_to_csv(rec: EmfRecord) -> str:
    """CSV text of a record (12 significant digits; positions in mm).

    Parameters
    ----------
    rec : EmfRecord
        The samples.

    Returns
    -------
    str
        The record's text.
    """
    vals = np.column_stack([rec.time, np.asarray(rec.position) * 1e3, rec.voltage])
    lines = [",".join(BASE_COLUMNS + rec.columns)]
    lines += [",".join(f"{v:.12g}" for v in row) for row in vals]
    return "\n".join(lines) + "\n"


# ---------------------------------------------------------------------- emulation
def emulate_emf(motor, speed: float = 0.5, periods: float = 2.0, rate: float = 10e3, noise: float = 0.0,
                seed: int = 0, line_to_line: bool = False) -> EmfRecord:
    """An open-circuit back-EMF record of ``motor``'s model, with measurement noise.

    The mover runs at the constant ``speed`` from position 0 over (at least) ``periods`` pole
    pitches, sampled at ``rate`` from time 0, both ends included; each phase's voltage is
    ``omega d psi_k / d theta``
    (:meth:`~linsense.model.motor.Motor.psi_pm_abc`, its ``[pm_flux]`` imbalance and harmonics
    included), ``omega = 2 pi speed / pole_pitch``. Gaussian noise of standard deviation ``noise``
    times the balanced phase EMF's peak ``|omega| psi_pm`` is added to each voltage, independently,
    from ``numpy.random.default_rng(seed)`` (after the line-to-line difference, if asked).

    Parameters
    ----------
    motor : Motor
        The motor.
    speed : float
        m/s, nonzero (negative: the mover runs backwards).
    periods : float
        Electrical periods travelled, > 0.
    rate : float
        Sampling rate, Hz, > 0.
    noise : float
        Relative noise, e.g. 0.01 for 1 % of the EMF's peak.
    seed : int
        Seed of the random generator.
    line_to_line : bool
        Record ``VAB, VBC, VCA`` instead of ``VA, VB, VC``.

    Returns
    -------
    EmfRecord
        The samples, source ``"emulated <motor name>"``.

    Raises
    ------
    InputError
        An argument out of range, naming it.
    """
    import numbers

    from linsense._check import real
    from linsense.limits import MAX_TABLE_ROWS
    from linsense.plausible import KINDS

    src = f"{_SRC}.emulate_emf"
    if isinstance(seed, bool) or not isinstance(seed, numbers.Integral) or seed < 0:
        raise InputError(src, "seed", f"must be an integer >= 0, got {seed!r}")
    v = real(speed, src, "speed", what="a finite speed in m/s")
    if v == 0.0:
        raise InputError(src, "speed", "the back-EMF needs the mover moving: give a nonzero speed in m/s")
    periods = real(periods, src, "periods", 0.0, low_open=True, what="a positive number of periods")
    rate = real(rate, src, "rate", 0.0, low_open=True, what="a positive sampling rate in Hz")
    noise = real(noise, src, "noise", 0.0, KINDS["relative_noise"].high, what="a fraction (0.01 = 1 %)",
                 kind="relative_noise")
    n = math.ceil(periods * motor.pole_pitch / abs(v) * rate) + 1  # (the last sample at the end)
    if not 8 <= n <= MAX_TABLE_ROWS:
        raise InputError(src, "rate", f"{n:,} samples (periods {periods:g}, speed {v:g} m/s, rate {rate:g} "
                         f"Hz): a record has 8 .. {MAX_TABLE_ROWS:,} (docs/limits.md)")
    t = np.arange(n) / rate
    x = v * t
    omega = 2.0 * math.pi * v / motor.pole_pitch
    e = omega * motor.psi_pm_abc(motor.theta_of_x(x), 1)
    if line_to_line:
        e = e - np.roll(e, -1, axis=1)
    rng = np.random.default_rng(seed)
    e = e + noise * abs(omega) * motor.psi_pm * rng.standard_normal(e.shape)
    return EmfRecord(time=t, position=x, voltage=e, line_to_line=line_to_line,
                     source=f"emulated {motor.name}")


# ---------------------------------------------------------------------- identification
def pm_phases_from_record(rec: EmfRecord, pole_pitch: float, psi_pm: float) -> OpenCircuitFit:
    """The magnets' flux per phase from an open-circuit back-EMF record, with its standard errors.

    ``theta = 2 pi x / pole_pitch``, the speed ``dx/dt`` from the positions and times (central
    differences), then :func:`~linsense.identify.open_circuit.pm_phases_from_emf` (docs/theory.md
    section 10). Before the fit, each refused naming the file: less than one electrical period of
    travel, a stop or a reversal, phase-to-star voltages whose sum's fundamental exceeds
    :data:`STAR_SUM_MAX` of a phase's (a wiring error), and a speed too low for the record's noise
    (a standard error above :data:`STDERR_MAX`, with the speed that is needed).

    Parameters
    ----------
    rec : EmfRecord
        The record.
    pole_pitch : float
        m, converts the positions to ``theta``.
    psi_pm : float
        The motor's PM flux linkage, Wb (``force_constant pole_pitch / (3 pi)``).

    Returns
    -------
    OpenCircuitFit
        The per-phase amplitudes and phases, their standard errors and the record's noise.

    Raises
    ------
    InputError
        Naming the record, the row or columns, the value and what is needed.
    """
    rec, pole_pitch, psi_pm = _record_args(rec, pole_pitch, psi_pm)
    src, cols = rec.source, ", ".join(rec.columns)
    theta = 2.0 * math.pi * np.asarray(rec.position) / pole_pitch
    _check_travel(rec, theta, pole_pitch)
    speed = np.gradient(np.asarray(rec.position), np.asarray(rec.time))
    _check_direction(rec, speed)
    omega = 2.0 * math.pi * speed / pole_pitch
    v = np.asarray(rec.voltage)
    e = phase_values_of_line(v) if rec.line_to_line else v
    orders = _orders(theta)
    sigma, amplitude = _noise_fit(theta, e, omega, orders)
    if not rec.line_to_line:
        _check_star_sum(rec, theta, e / omega[:, None], float(np.mean(amplitude)))
    stderr = sigma * math.sqrt(2.0 * float(np.mean(omega ** -2.0)) / theta.size) / amplitude
    _check_noise(rec, stderr, sigma, float(np.mean(speed)), float(np.mean(np.abs(omega))) * amplitude)
    try:
        phases = pm_phases_from_emf(theta, v, omega, psi_pm, line_to_line=rec.line_to_line, orders=orders)
    except InputError as exc:
        raise InputError(src, f"columns {cols}", exc.message) from None
    c = np.array(phases.scale) * np.exp(1j * np.array(phases.shift))
    a = np.exp(2j * math.pi / 3.0) ** np.arange(3)
    return OpenCircuitFit(
        phases=phases, stderr=tuple(float(s) for s in stderr), noise_rms=float(np.sqrt(np.mean(sigma ** 2))),
        speed=float(np.mean(speed)), samples=int(theta.size), periods=float(np.ptp(theta) / (2.0 * math.pi)),
        positive=complex(c.sum() / 3.0), negative=complex((c * a).sum() / 3.0),
        line_to_line=rec.line_to_line, source=src)


def _record_args(rec, pole_pitch, psi_pm) -> tuple[EmfRecord, float, float]:
    """:func:`pm_phases_from_record`'s arguments checked (one InputError naming the one at fault):
    a record of finite samples of matching shapes, a positive pole pitch and flux linkage."""
    from linsense._check import instance, real, reals
    from linsense.plausible import check

    src = f"{_SRC}.pm_phases_from_record"
    instance(rec, src, "rec", EmfRecord, "an EmfRecord (read_emf_csv, emulate_emf)")
    t = reals(rec.time, src, "rec.time", "sample times in s", ndim=1)
    x = reals(rec.position, src, "rec.position", "positions in m", ndim=1)
    v = reals(rec.voltage, src, "rec.voltage", "voltages in V", ndim=2)
    if not (x.shape == t.shape and v.shape == (t.size, 3) and t.size >= 2):
        raise InputError(src, "rec", f"expected time (N,), position (N,) and voltage (N, 3), N >= 2; got "
                         f"{t.shape}, {x.shape}, {v.shape}")
    if np.any(np.diff(t) <= 0.0):
        raise InputError(src, "rec.time", "the sample times must increase")
    pole_pitch = real(pole_pitch, src, "pole_pitch", 0.0, low_open=True, what="a pole pitch in m",
                      kind="pole_pitch")
    check(src, "pole_pitch", pole_pitch, "pole_pitch")  # (the motor file's plausible range: not mm)
    psi_pm = real(psi_pm, src, "psi_pm", 0.0, low_open=True, what="a flux linkage in Wb")
    return rec, pole_pitch, psi_pm


def _check_travel(rec: EmfRecord, theta: np.ndarray, pole_pitch: float) -> None:
    """Refuse a record covering less than one electrical period."""
    span = float(np.ptp(theta))
    if span < 2.0 * math.pi:
        raise InputError(rec.source, "column position_mm",
                         f"the mover travelled {float(np.ptp(rec.position)) * 1e3:.4g} mm, "
                         f"{math.degrees(span):.4g} electrical degrees: the fit needs at least one "
                         f"electrical period, one pole pitch ({pole_pitch * 1e3:.4g} mm) of travel at speed")


def _check_direction(rec: EmfRecord, speed: np.ndarray) -> None:
    """Refuse a record in which the mover stops or reverses (the EMF over a speed near zero)."""
    bad = np.nonzero(~(np.sign(speed) == np.sign(speed[0])) | (speed == 0.0))[0]
    if bad.size:
        i = int(bad[0])
        raise InputError(rec.source, f"row {rec.row[i]}, columns time_s, position_mm",
                         f"the mover stops or reverses here ({speed[i]:.4g} m/s from the positions and "
                         f"times; row {rec.row[0]}: {speed[0]:.4g} m/s): record one stroke in one "
                         "direction at speed")


def _orders(theta: np.ndarray) -> int:
    """The harmonic orders fitted beside the fundamental: :data:`NOISE_ORDERS`, fewer when the
    samples are fewer than four per period of the highest order."""
    periods = max(float(np.ptp(theta)) / (2.0 * math.pi), 1.0)
    return max(1, min(NOISE_ORDERS, int(theta.size / periods / 4.0)))


def _noise_fit(theta: np.ndarray, e: np.ndarray, omega: np.ndarray,
               orders: int) -> tuple[np.ndarray, np.ndarray]:
    """Each phase's noise, V rms, and its fundamental of ``e / omega``, Wb/rad: least squares of
    ``e_k`` over an offset and ``omega`` times the orders 1 .. ``orders``, the noise from the
    residual (``RSS / (N - p)``)."""
    n = np.arange(1, orders + 1)
    basis = np.concatenate([np.cos(np.outer(theta, n)), np.sin(np.outer(theta, n))], axis=1)
    A = np.column_stack([np.ones_like(theta), omega[:, None] * basis])
    coef, *_ = np.linalg.lstsq(A, e, rcond=None)
    rss = np.sum((e - A @ coef) ** 2, axis=0)
    sigma = np.sqrt(rss / max(theta.size - A.shape[1], 1))
    amplitude = np.hypot(coef[1], coef[1 + orders])
    return sigma, amplitude


def _check_star_sum(rec: EmfRecord, theta: np.ndarray, dpsi: np.ndarray, amplitude: float) -> None:
    """Refuse phase-to-star voltages whose sum's fundamental is above :data:`STAR_SUM_MAX` of a
    phase's: the floating star point's three EMFs sum to their zero sequence, small (the triplen
    harmonics, which are not the fundamental, aside)."""
    s = dpsi.sum(axis=1)
    (c, d), *_ = np.linalg.lstsq(np.column_stack([np.cos(theta), np.sin(theta)]), s, rcond=None)
    share = math.hypot(c, d) / amplitude
    if not share <= STAR_SUM_MAX:
        raise InputError(rec.source, "columns VA, VB, VC",
                         f"the three phase-to-star voltages do not sum to about zero: the fundamental of "
                         f"VA + VB + VC is {share:.3g} of a phase's (at most {STAR_SUM_MAX:g}): a wiring "
                         "error (a phase reversed, a channel on another phase, a voltage not measured to "
                         "the star point)? Without the star point, record VAB, VBC, VCA")


def _check_noise(rec: EmfRecord, stderr: np.ndarray, sigma: np.ndarray, speed: float,
                 emf: np.ndarray) -> None:
    """Refuse a record whose noise leaves a standard error above :data:`STDERR_MAX`, saying the
    speed needed (the standard error goes as 1/speed at the same samples)."""
    k = int(np.argmax(stderr))
    if not stderr[k] <= STDERR_MAX:
        need = abs(speed) * stderr[k] / STDERR_MAX
        raise InputError(rec.source, f"columns {', '.join(rec.columns)}",
                         f"speed too low for the record's noise: at {abs(speed):.4g} m/s phase "
                         f"{PHASES[k]}'s back-EMF of {emf[k]:.4g} V peak against {sigma[k]:.3g} V rms of "
                         f"noise over {rec.time.size} samples leaves a standard error of "
                         f"{math.degrees(stderr[k]):.3g} deg on its shift (at most "
                         f"{math.degrees(STDERR_MAX):g} deg): record at least {need:.3g} m/s with as many "
                         f"samples, or {math.ceil(rec.time.size * (stderr[k] / STDERR_MAX) ** 2):,} "
                         "samples at this speed")
