"""Bench measurement files: reading (with every check), writing, and emulating them from a motor.

A bench file is a CSV with one row per position and fed phase (docs/identify.md). Two forms:

* phasor form: ``position_mm, phase, freq_hz, I_re, I_im, VA_re, VA_im, VB_re, VB_im, VC_re, VC_im``,
  the fed phase's current phasor (A, peak) and the three phase-to-star-point voltage phasors
  (V, peak), all on one time reference;
* amplitude-only form (what the paper measured, eq. 2): ``position_mm, phase, freq_hz, I, VA, VB, VC``,
  the peak magnitudes only.

Columns may come in any order; other columns are ignored. Every problem raises
:class:`~linsense.errors.InputError` naming the file, the row (line number, the header is row 1)
and the column.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from linsense.errors import InputError
from linsense.io import check_width, csv_rows, finite_cell
from linsense.plausible import KINDS, implausible

#: Phases in storage order (index 0, 1, 2).
PHASES = ("A", "B", "C")
#: Columns of the phasor form, in the order written.
PHASOR_COLUMNS = (
    "position_mm", "phase", "freq_hz", "I_re", "I_im", "VA_re", "VA_im", "VB_re", "VB_im", "VC_re", "VC_im",
)
#: Columns of the amplitude-only form, in the order written.
AMPLITUDE_COLUMNS = ("position_mm", "phase", "freq_hz", "I", "VA", "VB", "VC")
#: Largest relative spread of the excitation frequency accepted in one file.
FREQ_TOLERANCE = 0.01
#: A current below this fraction of the largest one counts as zero.
ZERO_CURRENT_RATIO = 1e-6
#: Two positions closer than this (mm) are the same position.
POSITION_TOLERANCE_MM = 1e-6


@dataclass(frozen=True)
class BenchData:
    """The rows of a bench file (SI units).

    Parameters
    ----------
    position : ndarray, shape (R,)
        Mover position, m.
    phase : ndarray of int, shape (R,)
        Fed phase, 0, 1, 2 for A, B, C.
    freq : ndarray, shape (R,)
        Excitation frequency, Hz.
    current : ndarray of complex, shape (R,)
        Current phasor of the fed phase, A peak (real magnitude in the amplitude-only form).
    voltage : ndarray of complex, shape (R, 3)
        Phase-to-star-point voltage phasors of A, B, C, V peak (magnitudes if amplitude-only).
    amplitude_only : bool
        True for the amplitude-only form (no phases, no signs).
    row : ndarray of int, shape (R,)
        Line number of each row in the file (the header is line 1), for messages.
    source : str
        File name, for messages.
    """

    position: np.ndarray
    phase: np.ndarray
    freq: np.ndarray
    current: np.ndarray
    voltage: np.ndarray
    amplitude_only: bool = False
    row: np.ndarray | None = None
    source: str = "bench"

    def __post_init__(self) -> None:
        n = np.asarray(self.position).shape[0]
        if self.row is None:
            object.__setattr__(self, "row", np.arange(2, n + 2))

    @property
    def rows(self) -> int:
        """Number of measurement rows."""
        return int(np.asarray(self.position).shape[0])


# ---------------------------------------------------------------------- reading
def _header_form(header: list[str], src: str) -> tuple[str, tuple[str, ...]]:
    """Which form the header describes; raise naming the first missing column."""
    has = set(header)
    phasor_hint = any(c in has for c in PHASOR_COLUMNS[3:])
    if not phasor_hint and "I" in has:
        form, cols = "amplitude", AMPLITUDE_COLUMNS
    else:
        form, cols = "phasor", PHASOR_COLUMNS
    for c in cols:
        if c not in has:
            need = ",".join(cols)
            other = ",".join(AMPLITUDE_COLUMNS if form == "phasor" else PHASOR_COLUMNS)
            raise InputError(src, f"row 1, column {c}", f"missing column (need {need}, or {other})")
    return form, cols


def read_bench_csv(path: str | Path) -> BenchData:
    """Read and check a bench file (either form, docs/identify.md).

    Checks, each naming row and column: missing columns, empty cells, non-numeric and non-finite
    values, an unknown phase, a non-positive frequency, negative magnitudes (amplitude-only), zero
    current, duplicate rows (same position and fed phase), frequencies differing by more than
    ``FREQ_TOLERANCE``, and a phase that is never fed.

    Parameters
    ----------
    path : str or Path
        The bench file.

    Returns
    -------
    BenchData
        Its rows, SI units.

    Raises
    ------
    InputError
        The first problem found, naming the row and the column.
    """
    src = str(path)
    form, rows, phase, col = _bench_cells(path, src)
    freq = col["freq_hz"]
    bad = np.nonzero(freq <= 0)[0]
    if bad.size:
        i = bad[0]
        raise InputError(src, f"row {rows[i]}, column freq_hz",
                         f"frequency must be positive, got {freq[i]:.12g}")
    current, voltage, i_cols, v_cols = _bench_phasors(src, form, col, rows)
    _check_magnitudes(src, rows, current, voltage, i_cols, v_cols)
    pos_mm = col["position_mm"]
    _check_bench_rows(src, rows, freq, pos_mm, phase)
    return BenchData(
        position=pos_mm * 1e-3, phase=phase, freq=freq, current=current, voltage=voltage,
        amplitude_only=form == "amplitude", row=rows, source=src,
    )


def _bench_cells(path: str | Path,
                 src: str) -> tuple[str, np.ndarray, np.ndarray, dict[str, np.ndarray]]:
    """The bench file's form (``"phasor"`` or ``"amplitude"``), its rows' numbers, the fed phase
    of each (0, 1, 2) and its numeric columns by name; each cell checked (width, phase, finite)."""
    rows_in = csv_rows(path, "bench file")  # (bounded, BOM skipped: docs/limits.md)
    header = next(rows_in)[1]
    if any(";" in h for h in header) and not any(c in header for c in ("phase", "I_re", "I")):
        raise InputError(src, "row 1", "semicolon separators are not read: separate the columns with "
                                       "commas (and decimal commas are not read: use a point)")
    form, cols = _header_form(header, src)
    idx = {c: header.index(c) for c in cols}
    body = []
    for r, row in rows_in:
        check_width(src, r, row, header)
        body.append((r, row))
    if not body:
        raise InputError(src, "", "no data rows after the header")
    numeric = [c for c in cols if c != "phase"]
    data = np.empty((len(body), len(numeric)))
    phase = np.empty(len(body), dtype=int)
    rows = np.array([r for r, _ in body])
    for i, (r, row) in enumerate(body):
        cell = row[idx["phase"]].strip() if idx["phase"] < len(row) else ""
        if cell.upper() not in PHASES:
            raise InputError(src, f"row {r}, column phase", f"expected A, B or C, got {cell!r}")
        phase[i] = PHASES.index(cell.upper())
        for j, c in enumerate(numeric):
            data[i, j] = finite_cell(src, r, c, row[idx[c]].strip() if idx[c] < len(row) else "")
    col = {c: data[:, j] for j, c in enumerate(numeric)}
    return form, rows, phase, col


def _bench_phasors(src: str, form: str, col: dict[str, np.ndarray],
                   rows: np.ndarray) -> tuple[np.ndarray, np.ndarray, str, str]:
    """The fed current and the three phase voltages of each row, complex (real for an
    amplitude-only file, whose negative magnitudes are refused), and the columns they come from."""
    if form == "phasor":
        current = col["I_re"] + 1j * col["I_im"]
        voltage = np.stack([col[f"V{p}_re"] + 1j * col[f"V{p}_im"] for p in PHASES], axis=1)
        i_cols, v_cols = "I_re, I_im", "VA_re .. VC_im"
    else:
        for c in ("I", "VA", "VB", "VC"):
            bad = np.nonzero(col[c] < 0)[0]
            if bad.size:
                i = bad[0]
                raise InputError(src, f"row {rows[i]}, column {c}",
                                 f"a magnitude cannot be negative, got {col[c][i]:.12g}")
        current = col["I"].astype(complex)
        voltage = np.stack([col[f"V{p}"] for p in PHASES], axis=1).astype(complex)
        i_cols, v_cols = "I", "VA, VB, VC"
    return current, voltage, i_cols, v_cols


def _check_magnitudes(src: str, rows: np.ndarray, current: np.ndarray, voltage: np.ndarray, i_cols: str,
                      v_cols: str) -> None:
    """Refuse an implausible current or voltage (one in mA or mV) and a row without current."""
    mag = np.abs(current)
    # (the table of plausible values: a current in mA, a voltage in mV)
    for kind, values, what in (("current", mag, i_cols), ("voltage", np.abs(voltage), v_cols)):
        bad = np.nonzero((values.max(axis=1) if values.ndim > 1 else values) > KINDS[kind].high)[0]
        if bad.size:
            i = int(bad[0])
            raise InputError(src, f"row {rows[i]}, column {what}",
                             f"{implausible(kind, float(np.max(values[i])))} (a bench file is in A and V "
                             "peak)")
    bad = np.nonzero(~(mag > ZERO_CURRENT_RATIO * mag.max()))[0]
    if bad.size:
        i = bad[0]
        raise InputError(src, f"row {rows[i]}, column {i_cols}",
                         f"zero current ({mag[i]:.12g} A): the fed phase carries no current")


def _check_bench_rows(src: str, rows: np.ndarray, freq: np.ndarray, pos_mm: np.ndarray,
                      phase: np.ndarray) -> None:
    """Refuse rows at another frequency than the first's, duplicate rows (same position and fed
    phase) and a phase that is never fed."""
    ref = freq[0]
    bad = np.nonzero(np.abs(freq - ref) > FREQ_TOLERANCE * ref)[0]
    if bad.size:
        i = bad[0]
        raise InputError(
            src, f"row {rows[i]}, column freq_hz",
            f"inconsistent frequency {freq[i]:.12g} Hz: row {rows[0]} has {ref:.12g} Hz "
            f"(all rows must use one frequency within {100 * FREQ_TOLERANCE:g} %)",
        )
    key = np.round(pos_mm / POSITION_TOLERANCE_MM).astype(np.int64) * 3 + phase
    _, first, inverse = np.unique(key, return_index=True, return_inverse=True)
    dup = np.nonzero(first[inverse] != np.arange(key.size))[0]
    if dup.size:
        i = dup[0]
        j = first[inverse[i]]
        raise InputError(
            src, f"row {rows[i]}, columns position_mm, phase",
            f"duplicate of row {rows[j]} (position {pos_mm[i]:.12g} mm, phase {PHASES[phase[i]]} fed)",
        )
    for k, name in enumerate(PHASES):
        if not np.any(phase == k):
            raise InputError(src, "column phase",
                             f"phase {name} is never fed: every phase must be fed in turn")


# ---------------------------------------------------------------------- writing
def bench_to_csv(data: BenchData) -> str:
    """CSV text of ``data`` in its form (12 significant digits; positions in mm).

    Parameters
    ----------
    data : BenchData
        The rows.

    Returns
    -------
    str
        The bench file's text.
    """
    pos = np.asarray(data.position) * 1e3
    if data.amplitude_only:
        lines = [",".join(AMPLITUDE_COLUMNS)]
        vals = np.column_stack([np.abs(data.current), np.abs(data.voltage)])
    else:
        lines = [",".join(PHASOR_COLUMNS)]
        V = np.asarray(data.voltage)
        I = np.asarray(data.current)
        vals = np.column_stack([I.real, I.imag] + [x for k in range(3) for x in (V[:, k].real, V[:, k].imag)])
    for i in range(data.rows):
        nums = ",".join(f"{v:.12g}" for v in vals[i])
        lines.append(f"{pos[i]:.12g},{PHASES[data.phase[i]]},{data.freq[i]:.12g},{nums}")
    return "\n".join(lines) + "\n"


# ---------------------------------------------------------------------- emulation
def emulate_bench(
    motor,
    positions: int = 56,
    noise: float = 0.0,
    seed: int = 0,
    freq: float = 1000.0,
    current: float = 1.0,
    amplitude_only: bool = False,
) -> BenchData:
    """The bench test of paper eq. (2) on ``motor``'s model, with measurement noise.

    At ``positions`` equally spaced positions over one pole pitch (``x_i = i tau / N``), each
    phase ``k`` in turn is fed a current phasor ``I`` of random phase (uniform) and amplitude
    (uniform in 0.8..1.2 times ``current``); the voltages of the three phases are::

        V_k = (R_s + j omega L_kk) I,    V_j = j omega L_jk I  (j != k)

    Then complex Gaussian noise of standard deviation ``noise * |p|`` (real and imaginary parts
    each ``noise * |p| / sqrt(2)``) is added independently to ``I`` and to each ``V``, from
    ``numpy.random.default_rng(seed)``. ``amplitude_only`` keeps only the magnitudes.

    Parameters
    ----------
    motor : Motor
        Gives ``R_s``, ``pole_pitch`` and ``L_abc(theta)``.
    positions : int
        Number of positions ``N`` over one electrical period.
    noise : float
        Relative noise, e.g. 0.01 for 1 %.
    seed : int
        Seed of the random generator (phases, amplitudes, noise).
    freq : float
        Excitation frequency, Hz.
    current : float
        Nominal current amplitude, A peak.
    amplitude_only : bool
        Keep only the magnitudes (the amplitude-only form).

    Returns
    -------
    BenchData
        Three rows per position (one per fed phase), source ``"emulated <motor name>"``.

    Raises
    ------
    linsense.errors.InputError
        An argument out of range, naming it.
    """
    positions, noise, seed, freq, current = _emulate_args(positions, noise, seed, freq, current)
    rng = np.random.default_rng(seed)
    x = np.arange(positions) * motor.pole_pitch / positions
    pos = np.repeat(x, 3)
    phase = np.tile(np.arange(3), positions)
    R = pos.size
    L = motor.inductance.L_abc(motor.theta_of_x(pos))  # (R, 3, 3)
    w = 2.0 * np.pi * freq
    amp = current * rng.uniform(0.8, 1.2, R)
    I = amp * np.exp(1j * rng.uniform(0.0, 2.0 * np.pi, R))
    Z = 1j * w * L[np.arange(R), :, phase]  # column k of j omega L
    Z[np.arange(R), phase] += motor.R_s
    V = Z * I[:, None]
    I_m = _noisy(rng, noise, I)
    V_m = _noisy(rng, noise, V)
    if amplitude_only:
        I_m = np.abs(I_m).astype(complex)
        V_m = np.abs(V_m).astype(complex)
    return BenchData(
        position=pos, phase=phase, freq=np.full(R, float(freq)), current=I_m, voltage=V_m,
        amplitude_only=amplitude_only, source=f"emulated {motor.name}",
    )


def _emulate_args(positions: int, noise: float, seed: int, freq: float,
                  current: float) -> tuple[int, float, int, float, float]:
    """:func:`emulate_bench`'s arguments checked (one InputError naming the one out of range)."""
    import numbers

    from linsense._check import real as real_arg
    from linsense.limits import MAX_POSITIONS

    # (the API refuses what `linsense bench-emulate` refuses, in one InputError naming the argument:
    # None, NaN, a string or a complex number were numpy tracebacks, a NaN seed a TypeError)
    src = "linsense.identify.emulate_bench"
    if isinstance(positions, bool) or not isinstance(positions, numbers.Integral) \
            or not 8 <= positions <= MAX_POSITIONS:
        raise InputError(src, "positions", f"must be an integer in 8 .. {MAX_POSITIONS:,} (docs/limits.md), "
                         f"got {positions!r}")
    if isinstance(seed, bool) or not isinstance(seed, numbers.Integral) or seed < 0:
        raise InputError(src, "seed", f"must be an integer >= 0, got {seed!r}")
    positions, seed = int(positions), int(seed)
    noise = real_arg(noise, src, "noise", 0.0, KINDS["relative_noise"].high, what="a fraction (0.01 = 1 %)",
                     kind="relative_noise")
    freq = real_arg(freq, src, "freq", 0.0, low_open=True, what="a positive finite frequency in Hz")
    current = real_arg(current, src, "current", 0.0, low_open=True, what="a positive finite current in A")
    return positions, noise, seed, freq, current


def _noisy(rng: np.random.Generator, noise: float, p: np.ndarray) -> np.ndarray:
    """``p`` with complex Gaussian noise of standard deviation ``noise * |p|`` added."""
    s = noise * np.abs(p) / np.sqrt(2.0)
    return p + s * (rng.standard_normal(p.shape) + 1j * rng.standard_normal(p.shape))
