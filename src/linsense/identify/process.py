"""From bench rows to the measured inductance table ``L_abc(theta)`` (paper eq. 2, with phasors).

Each row (phase ``k`` fed with current ``I``, voltages ``V_j``) gives column ``k`` of the
impedance matrix, ``Z_jk = V_j / I``. With phasors::

    L_kk = Im(V_k / I) / omega,   R_k = Re(V_k / I),   L_jk = Im(V_j / I) / omega  (j != k, signed)

With magnitudes only (the paper's eq. 2) the phase of ``V/I`` is unknown, so::

    L_kk = sqrt((|V_k| / |I|)^2 - R^2) / omega   (R known; R = 0 neglects the resistive drop)
    L_jk = -|V_j| / (omega |I|)                  (mutuals assumed negative)

Rows at the same electrical position (positions one pole pitch apart included) are averaged per fed
phase; the three excitations give the full 3x3 matrix, whose two reciprocal estimates of each
mutual (``L_jk`` from ``k`` fed, ``L_kj`` from ``j`` fed) are averaged for the table and compared
for the reciprocity error.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from linsense.errors import InputError
from linsense.identify.bench import PHASES, BenchData

#: Fewest distinct electrical positions accepted, and the largest gap between them (rad).
MIN_POSITIONS = 8
MAX_GAP = np.radians(45.0)
#: (row, column) of the six table entries L_A, L_B, L_C, M_AB, M_BC, M_CA in the 3x3 matrix.
_INDEX = ((0, 0), (1, 1), (2, 2), (0, 1), (1, 2), (2, 0))
_PAIRS = ("AB", "BC", "CA")


@dataclass(frozen=True)
class MeasuredTable:
    """Measured inductances at the distinct electrical positions, sorted by ``theta``.

    Parameters
    ----------
    theta : ndarray, shape (N,)
        Electrical positions in [0, 2 pi), rad.
    position : ndarray, shape (N,)
        Position of each (first row at that electrical position), m.
    entries : ndarray, shape (N, 6)
        ``L_A, L_B, L_C, M_AB, M_BC, M_CA`` (mutuals averaged over both excitations), H.
    matrix : ndarray, shape (N, 3, 3)
        The unsymmetrised matrices: column ``k`` from phase ``k`` fed, H.
    first_row : ndarray of int, shape (N,)
        File line of the first row at each position, for messages.
    resistance : float or None
        Mean of ``Re(V_fed / I)`` over all rows, ohm (None for amplitude-only data).
    resistance_std : float or None
        Standard deviation of ``Re(V_fed / I)`` over the rows, ohm.
    frequency : float
        Mean excitation frequency, Hz.
    reciprocity : ndarray, shape (N, 3)
        Relative difference of the reciprocal mutuals ``(L_jk - L_kj) / mean`` for AB, BC, CA.
    warnings : list of str
        One line each: what was assumed (amplitude-only data).
    rows : int
        Rows of the bench file.
    amplitude_only : bool
        The data were amplitude-only.
    """

    theta: np.ndarray
    position: np.ndarray
    entries: np.ndarray
    matrix: np.ndarray
    first_row: np.ndarray
    resistance: float | None
    resistance_std: float | None
    frequency: float
    reciprocity: np.ndarray
    rows: int
    amplitude_only: bool = False
    warnings: list[str] = field(default_factory=list)

    @property
    def reciprocity_max(self) -> float:
        """Largest relative difference between reciprocal mutuals."""
        return float(np.max(np.abs(self.reciprocity)))

    @property
    def reciprocity_rms(self) -> float:
        """RMS relative difference between reciprocal mutuals."""
        return float(np.sqrt(np.mean(self.reciprocity**2)))

    def reciprocity_worst(self) -> tuple[int, str]:
        """The position index and pair name of the largest reciprocity error.

        Returns
        -------
        index : int
            Position index.
        pair : str
            ``"AB"``, ``"BC"`` or ``"CA"``.
        """
        i, j = np.unravel_index(int(np.argmax(np.abs(self.reciprocity))), self.reciprocity.shape)
        return int(i), _PAIRS[j]


def electrical_groups(data: BenchData, pole_pitch: float) -> tuple[np.ndarray, np.ndarray]:
    """Electrical position of each row in [0, 2 pi) and the index of its distinct position.

    Positions one or more pole pitches apart fall into the same group.

    Parameters
    ----------
    data : BenchData
        The rows.
    pole_pitch : float
        m.

    Returns
    -------
    theta : ndarray
        Electrical position of each row, rad.
    group : ndarray of int
        Index of each row's distinct position.
    """
    theta = np.mod(2.0 * np.pi * np.asarray(data.position) / pole_pitch, 2.0 * np.pi)
    key = np.round(theta / (2.0 * np.pi) * 1e9).astype(np.int64) % 1_000_000_000
    _, inverse = np.unique(key, return_inverse=True)
    return theta, inverse.reshape(-1)


#: the span of a bench's positions, in pole pitches: one period (less the largest gap) to a few
SPAN_PITCHES = (1.0 - MAX_GAP / (2.0 * np.pi), 10.0)


def _position_units(data: BenchData, pole_pitch: float) -> str:
    """The slip of unit of column ``position_mm`` (metres or micrometres typed), for a message:
    ``"; the positions span 0.055 mm: did you type m? (0.055 m is 55 mm)"``, or ``""``."""
    from linsense.plausible import slip

    span = float(np.ptp(np.asarray(data.position))) * 1e3  # mm
    tau = pole_pitch * 1e3

    def covers(v: float) -> bool:
        return SPAN_PITCHES[0] * tau <= v <= SPAN_PITCHES[1] * tau

    hint = "" if covers(span) else slip("stroke", span, "mm", ok=covers)
    return f"; the positions span {span:.6g} mm of a {tau:.6g} mm pole pitch: {hint}" if hint else ""


def process_bench(data: BenchData, pole_pitch: float, resistance: float | None = None,
                  resistance_source: str = "", cover: bool = True) -> MeasuredTable:
    """The measured table of ``data`` with positions converted by ``pole_pitch`` (m).

    Parameters
    ----------
    data : BenchData
        Rows of a bench file (checked by :func:`~linsense.identify.bench.read_bench_csv`).
    pole_pitch : float
        One electrical period, m: ``theta = 2 pi x / pole_pitch``.
    resistance : float, optional
        Phase resistance (ohm) for amplitude-only data; required there (0 neglects the
        resistive drop, as the paper does). Not used with phasors.
    resistance_source : str
        Where ``resistance`` came from, for the warning.
    cover : bool, optional
        Refuse positions that do not cover one electrical period (False: a table of the physical
        positions as they are, for :func:`linsense.identify.fit.best_pitch`).

    Returns
    -------
    MeasuredTable
        The table.

    Raises
    ------
    InputError
        A position without all three phases fed, too few positions, a gap over 45 deg, an
        amplitude-only impedance below the resistance.
    """
    src = data.source
    theta_row, grp = electrical_groups(data, pole_pitch)
    n = int(grp.max()) + 1
    rows = np.asarray(data.row)
    k = np.asarray(data.phase)
    count = np.zeros((n, 3))  # rows per (position, fed phase)
    np.add.at(count, (grp, k), 1.0)
    first = _first_rows(rows, grp, n)
    _check_phases(data, theta_row, count, first)
    theta_g = theta_row[first]
    pos_order = np.argsort(theta_g)
    _check_cover(data, pole_pitch, theta_g, pos_order, first, cover)
    col, r_row, warnings = _columns(data, resistance, resistance_source)

    # average per (position, fed phase): matrix[g, :, p] = mean of column rows
    acc = np.zeros((n, 3, 3))
    np.add.at(acc, (grp, slice(None), k), col)
    mat = acc / count[:, None, :]
    mat = mat[pos_order]
    sym = 0.5 * (mat + np.swapaxes(mat, -1, -2))
    entries = np.stack([sym[:, r, c] for r, c in _INDEX], axis=1)
    pair = [(0, 1), (1, 2), (2, 0)]
    recip = np.stack(
        [(mat[:, r, c] - mat[:, c, r]) / np.abs(sym[:, r, c]) for r, c in pair], axis=1
    )
    res, res_std = _resistance(src, r_row)
    return MeasuredTable(
        theta=theta_g[pos_order], position=np.asarray(data.position)[first[pos_order]], entries=entries,
        matrix=mat, first_row=rows[first[pos_order]], resistance=res, resistance_std=res_std,
        frequency=float(np.mean(data.freq)), reciprocity=recip, rows=data.rows,
        amplitude_only=data.amplitude_only, warnings=warnings,
    )


def _first_rows(rows: np.ndarray, grp: np.ndarray, n: int) -> np.ndarray:
    """Each of the ``n`` position groups' first (lowest) file row, as an index into the rows."""
    first = np.full(n, -1)
    order = np.argsort(rows, kind="stable")
    for i in order[::-1]:  # the first (lowest) file row of each group wins
        first[grp[i]] = i
    return first


def _check_phases(data: BenchData, theta_row: np.ndarray, count: np.ndarray, first: np.ndarray) -> None:
    """Every distinct position needs every phase fed (``count``: rows per position and phase)."""
    missing = np.argwhere(count == 0)
    if missing.size:
        g, p = missing[0]
        i = first[g]
        raise InputError(
            data.source, f"row {np.asarray(data.row)[i]}, column phase",
            f"position {data.position[i] * 1e3:.6g} mm ({np.degrees(theta_row[i]):.1f} deg) has no row "
            f"with phase {PHASES[p]} fed: every position needs all three excitations",
        )


def _check_cover(data: BenchData, pole_pitch: float, theta_g: np.ndarray, pos_order: np.ndarray,
                 first: np.ndarray, cover: bool) -> None:
    """Enough distinct positions, and (with ``cover``) no gap over :data:`MAX_GAP` in the period."""
    n = theta_g.size
    if n < MIN_POSITIONS:
        raise InputError(data.source, "column position_mm",
                         f"need at least {MIN_POSITIONS} distinct electrical positions, got {n}"
                         + _position_units(data, pole_pitch))
    ts = theta_g[pos_order]
    gaps = np.diff(np.concatenate([ts, [ts[0] + 2.0 * np.pi]]))
    if cover and gaps.max() > MAX_GAP + 1e-9:
        g = int(np.argmax(gaps))
        i = first[pos_order[g]]
        raise InputError(
            data.source, f"row {np.asarray(data.row)[i]}, column position_mm",
            f"positions do not cover one electrical period: gap of {np.degrees(gaps[g]):.1f} deg after "
            f"{data.position[i] * 1e3:.6g} mm ({np.degrees(ts[g]):.1f} deg) with pole pitch "
            f"{pole_pitch * 1e3:.6g} mm (at most {np.degrees(MAX_GAP):.0f} deg allowed)"
            + _position_units(data, pole_pitch),
        )


def _columns(data: BenchData, resistance: float | None,
             resistance_source: str) -> tuple[np.ndarray, np.ndarray | None, list[str]]:
    """Each row's inductance column (H; the fed phase's self inductance and the mutuals), the
    row's resistance ``Re(V/I)`` (None for amplitude-only data) and the warnings."""
    src = data.source
    rows = np.asarray(data.row)
    k = np.asarray(data.phase)
    w = 2.0 * np.pi * np.asarray(data.freq)
    I = np.asarray(data.current)
    V = np.asarray(data.voltage)
    R = np.arange(data.rows)
    if not data.amplitude_only:
        z = V / I[:, None]
        return z.imag / w[:, None], z[R, k].real, []
    if resistance is None:
        raise InputError(src, "", "amplitude-only data carry no resistance: give --resistance "
                         "(0 neglects the resistive drop, as the paper does) or --motor")
    z = np.abs(V) / np.abs(I)[:, None]
    z_fed = z[R, k]
    bad = np.nonzero(z_fed < resistance)[0]
    if bad.size:
        i = bad[0]
        raise InputError(
            src, f"row {rows[i]}, column V{PHASES[k[i]]}",
            f"|V|/|I| = {z_fed[i]:.6g} ohm is below the resistance {resistance:.6g} ohm "
            f"({resistance_source or 'given'}): no inductance left",
        )
    col = -z / w[:, None]  # mutuals assumed negative
    col[R, k] = np.sqrt(z_fed**2 - resistance**2) / w
    warnings = ["amplitude-only data: the signs of the mutual inductances are not measured; "
                "all mutuals taken as negative"]
    if resistance > 0:
        warnings.append(
            f"amplitude-only data: self inductances from sqrt((|V|/|I|)^2 - R^2)/omega with "
            f"R = {resistance:.6g} ohm ({resistance_source or 'given'}), not measured in this file"
        )
    else:
        warnings.append("amplitude-only data: resistive drop neglected (R = 0, as the paper's eq. 2): "
                        "self inductances are overestimated")
    return col, None, warnings


def _resistance(src: str, r_row: np.ndarray | None) -> tuple[float | None, float | None]:
    """The phase resistance identified from the rows' ``Re(V/I)`` and its spread, ohm (None, None
    for amplitude-only data)."""
    if r_row is None:
        return None, None
    res, res_std = float(np.mean(r_row)), float(np.std(r_row))
    if res < 0:
        raise InputError(src, "columns I_re, I_im, V*_re, V*_im",
                         f"identified resistance Re(V/I) = {res:.6g} ohm is negative: "
                         "are current and voltages on one time reference?")
    return res, res_std
