"""Magnetic saturation of a motor, for the simulator's saturated plant (``ls_sim_sat``).

The plant's co-energy in the true dq frame (docs/theory.md, "The saturated plant") is
``W = a(theta, i_q) S(i_d) + i_d B(theta, i_q) + C(theta, i_q)``: at ``i_d = 0`` its incremental
inductances are exactly ``L_d = a``, ``L_dq = dB/di_q`` and ``L_q = d2C/di_q2``, each a Fourier
series in theta times a polynomial in ``i_q`` (powers 0..3), and ``S`` is the d-axis saturation of
the magnets' flux: ``S'' = k(i_d) = f(i_d + i_m) / f(i_m)``, ``f(u) = 1 / (1 + (u / i_sat_d)^2)``.

Two sources fill it:

* **parametric** (``[saturation]`` keys ``polarity``, ``magnet_current``, ``q_drop``,
  ``q_current``; any motor): the linear model's ``L_d(theta), L_dq(theta), L_q(theta)`` with
  ``L_q`` falling as ``1 - q_drop (i_q / q_current)^2`` and the d-axis saturation set by the
  polarity signal ``(L_d(-I) - L_d(+I)) / L_d / I`` at small pulses ``I`` (1/A);
* **tables** (``currents`` and ``tables``: incremental ``L_abc(theta)`` CSVs at those q currents,
  e.g. ``linsense fea ... --load-current 0,0.5,1``): the dq inductances of each table, fitted by
  a polynomial in ``i_q`` of degree ``min(n - 1, 3)`` (least squares); ``polarity`` adds the
  d-axis saturation (e.g. from the FEA's ``polarity.csv``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from linsense._check import instance
from linsense.errors import SaturationRangeError
from linsense.model.inductance import InductanceModel
from linsense.model.motor_schema import SaturationSection, validate_section

#: Powers 0..SAT_POW-1 of i_q the C plant takes (LS_SIM_SAT_POW).
SAT_POW = 4
#: Positions of the grid the dq series are computed on (orders up to half of it).
_GRID = 512


@dataclass(frozen=True)
class Saturation:
    """Saturation data of a motor (SI units).

    Parameters
    ----------
    polarity : float
        1/A, d-axis polarity signal ``(L_d(-I) - L_d(+I)) / L_d`` per ampere of pulse, small
        ``I`` (0: no d-axis saturation).
    magnet_current : float or None
        A, ``i_m``: the d current equivalent to the magnets' flux; None: ``psi_pm / mean L_d``.
    q_drop : float
        -, parametric q-axis saturation: relative fall of ``L_q`` at ``q_current``.
    q_current : float
        A, see ``q_drop``.
    currents : tuple of float
        A, q currents of ``tables`` (empty: the parametric model on the motor's inductance).
    tables : tuple of InductanceModel
        Incremental ``L_abc(theta)`` at ``currents`` (``i_d = 0``).
    source : str
        Where the data came from (the motor file's ``[saturation]``), for messages.

    Raises
    ------
    linsense.errors.InputError
        A value the motor file's ``[saturation]`` section refuses (its schema), or tables that are
        not :class:`~linsense.model.inductance.InductanceModel`.
    """

    polarity: float = 0.0
    magnet_current: float | None = None
    q_drop: float = 0.0
    q_current: float = 1.0
    currents: tuple[float, ...] = ()
    tables: tuple[InductanceModel, ...] = ()
    source: str = ""

    def __post_init__(self) -> None:
        # one validated path: the motor file's [saturation] rules (SaturationSection)
        src = "linsense.model.saturation.Saturation"
        instance(self.source, src, "source", str, "a str")
        source = self.source or src
        instance(self.currents, source, "saturation.currents", tuple, "a tuple of currents in A")
        instance(self.tables, source, "saturation.tables", tuple, "a tuple of InductanceModel")
        for k, t in enumerate(self.tables):
            instance(t, source, f"saturation.tables[{k}]", InductanceModel, "an InductanceModel")
        given = bool(self.currents or self.tables)
        validate_section(SaturationSection, {
            "polarity": self.polarity, "magnet_current": self.magnet_current, "q_drop": self.q_drop,
            "q_current": self.q_current, "currents": list(self.currents) if given else None,
            "tables": [t.description or f"table {k}" for k, t in enumerate(self.tables)] if given else None},
            source, "saturation")

    def describe(self) -> str:
        """One line describing the saturation data, for reports.

        Returns
        -------
        str
            The tables' currents and the polarity, or the parametric model's numbers.
        """
        if self.tables:
            cur = ", ".join(f"{c:g}" for c in self.currents)
            return f"tables at i_q = {cur} A, polarity {self.polarity:g} /A"
        return (f"parametric: polarity {self.polarity:g} /A, "
                f"L_q -{100 * self.q_drop:g} % at {self.q_current:g} A")

    def key(self) -> tuple:
        """Everything that defines it, hashable (for caches).

        Returns
        -------
        tuple
            ``(polarity, magnet_current, q_drop, q_current, currents, tables' coefficient bytes)``.
        """
        tab = tuple((t.a.tobytes(), t.b.tobytes()) for t in self.tables)
        return (self.polarity, self.magnet_current, self.q_drop, self.q_current, self.currents, tab)


def i_sat_d_of(polarity: float, i_m: float) -> float:
    """The d saturation current ``a`` giving a small-pulse polarity signal at a magnet current.

    ``polarity = -2 k'(0) = 4 i_m / (a^2 + i_m^2)``.

    Parameters
    ----------
    polarity : float
        Polarity signal per ampere of pulse, 1/A (0: no d-axis saturation).
    i_m : float
        Magnet current, A.

    Returns
    -------
    float
        ``a``, A; 0 when ``polarity`` is 0.

    Raises
    ------
    linsense.errors.SaturationRangeError
        When ``polarity`` or ``i_m`` is not positive, or ``polarity`` is beyond ``4 / i_m`` (no ``a``
        gives it).
    """
    if polarity == 0.0:
        return 0.0
    if not (polarity > 0.0 and i_m > 0.0):
        raise SaturationRangeError("saturation.polarity", f"polarity {polarity:g} /A needs a positive value "
                                   f"and magnet current (i_m = {i_m:g} A)")
    a2 = 4.0 * i_m / polarity - i_m * i_m
    if not a2 > 0.0:
        raise SaturationRangeError("saturation.polarity", f"polarity {polarity:g} /A is beyond what a magnet "
                                   f"current of {i_m:g} A can give (at most {4.0 / i_m:.3g} /A)")
    return math.sqrt(a2)


def d_factor(i_d: np.ndarray | float, i_m: float, i_sat_d: float) -> np.ndarray:
    """``k(i_d) = L_d,inc(i_d) / L_d,inc(0)`` of the d-axis saturation, dimensionless.

    Parameters
    ----------
    i_d : float or ndarray
        d current, A.
    i_m : float
        Magnet current, A.
    i_sat_d : float
        d saturation current (:func:`i_sat_d_of`), A; 0 or less: no saturation.

    Returns
    -------
    ndarray
        ``(1 + (i_m / a)^2) / (1 + ((i_m + i_d) / a)^2)``, ones without saturation.
    """
    i_d = np.asarray(i_d, dtype=float)
    if i_sat_d <= 0.0:
        return np.ones_like(i_d)
    return (1.0 + (i_m / i_sat_d) ** 2) / (1.0 + ((i_m + i_d) / i_sat_d) ** 2)


def _dq_series(ind: InductanceModel, n_order: int) -> tuple[np.ndarray, np.ndarray]:
    """cos and sin coefficients (3, n_order) of ``L_d, L_dq, L_q`` (true dq frame) in theta."""
    theta = 2.0 * np.pi * np.arange(_GRID) / _GRID
    L = ind.L_dq(theta)
    vals = np.stack([L[:, 0, 0], L[:, 0, 1], L[:, 1, 1]])  # (3, N)
    F = np.fft.rfft(vals, axis=1) / _GRID
    cos = 2.0 * F.real[:, :n_order]
    sin = -2.0 * F.imag[:, :n_order]
    cos[:, 0] *= 0.5
    return cos, sin


def plant_series(sat: Saturation, inductance: InductanceModel, psi_pm: float,
                 max_order: int) -> dict:
    """What the C plant's saturated model (``ls_sim_sat``) takes.

    Parameters
    ----------
    sat : Saturation
        The saturation data.
    inductance : InductanceModel
        The motor's (unsaturated) model, used when ``sat`` has no tables.
    psi_pm : float
        Magnet flux linkage, Wb (gives ``i_m`` when ``sat.magnet_current`` is None).
    max_order : int
        The C plant's limit of harmonic orders.

    Returns
    -------
    dict
        ``dq_cos``, ``dq_sin`` (n_pow, 3, n_order; H/A^p), ``n_pow``, ``n_order``, ``i_m`` (A),
        ``i_sat_d`` (A).

    Raises
    ------
    linsense.errors.SaturationRangeError
        When the dq series needs more harmonic orders than ``max_order``, or the polarity is out of
        range (:func:`i_sat_d_of`).
    """
    models = sat.tables if sat.tables else (inductance,)
    # the dq series has the L_abc orders +-2 (the rotation); all shared by one length
    n_order = max(m.max_order for m in models) + 3
    if n_order > max_order:
        key = "saturation.tables" if sat.tables else "inductance"
        raise SaturationRangeError(key, f"the dq inductances have {n_order} harmonic orders; the simulator's "
                                   f"saturated plant takes at most {max_order} (smooth the tables with "
                                   "table_max_order)")
    series = [_dq_series(m, n_order) for m in models]
    if sat.tables:
        cur = np.asarray(sat.currents, dtype=float)
        deg = min(len(cur) - 1, SAT_POW - 1)
        V = np.vander(cur, deg + 1, increasing=True)  # (n_tab, deg + 1)
        out = []
        for part in (0, 1):
            y = np.stack([s[part] for s in series])  # (n_tab, 3, n_order)
            coef, *_ = np.linalg.lstsq(V, y.reshape(len(cur), -1), rcond=None)
            out.append(coef.reshape(deg + 1, 3, n_order))
        cos, sin = out
    else:
        c0, s0 = series[0]
        deg = 2 if sat.q_drop else 0
        cos = np.zeros((deg + 1, 3, n_order))
        sin = np.zeros_like(cos)
        cos[0], sin[0] = c0, s0
        if deg:  # L_q (1 - q_drop (i_q / q_current)^2)
            f = -sat.q_drop / sat.q_current**2
            cos[2, 2], sin[2, 2] = f * c0[2], f * s0[2]
    # the d-axis: i_m from the mean unsaturated L_d at zero current
    L_d0 = float(cos[0, 0, 0])
    i_m = sat.magnet_current if sat.magnet_current is not None else psi_pm / L_d0
    return {"dq_cos": cos, "dq_sin": sin, "n_pow": cos.shape[0], "n_order": n_order, "i_m": float(i_m),
            "i_sat_d": i_sat_d_of(sat.polarity, float(i_m))}


def incremental_dq(series: dict, theta: np.ndarray | float, i_q: float) -> np.ndarray:
    """``[[L_d, L_dq], [L_dq, L_q]]`` at ``i_d = 0`` from :func:`plant_series`'s output.

    The plant's incremental inductances there.

    Parameters
    ----------
    series : dict
        :func:`plant_series`'s output.
    theta : float or ndarray
        Electrical position(s), rad.
    i_q : float
        q current, A.

    Returns
    -------
    ndarray, shape theta.shape + (2, 2)
        H.
    """
    theta = np.asarray(theta, dtype=float)
    k = np.arange(series["n_order"])
    c, s = np.cos(theta[..., None] * k), np.sin(theta[..., None] * k)
    pw = i_q ** np.arange(series["n_pow"])
    v = (np.einsum("p,pek,...k->...e", pw, series["dq_cos"], c)
         + np.einsum("p,pek,...k->...e", pw, series["dq_sin"], s))
    out = np.empty(theta.shape + (2, 2))
    out[..., 0, 0], out[..., 1, 1] = v[..., 0], v[..., 2]
    out[..., 0, 1] = out[..., 1, 0] = v[..., 1]
    return out
