"""Least-squares fit of the HF inductance model (paper eq. 3 and its even harmonics) to a table.

The model (docs/theory.md section 2) is linear in its parameters
``p = (L0, M0, dM0, L2, M2, L4, M4, ..., L_2K, M_2K)``::

    L_A  = L0 + sum_n L_n cos(n th),            L_B(th) = L_A(th - 2pi/3), L_C(th) = L_A(th + 2pi/3)
    M_AB = M0 + sum_n M_n cos(n (th - pi/3)),   M_BC = M0 + dM0 + sum_n M_n cos(n th),
    M_CA = M0 + dM0 + sum_n M_n cos(n (th + pi/3)),    n = 2, 4, ..., 2K

so all six entries at all ``N`` positions give ``6 N`` equations ``A p = y``, solved by ordinary
linear least squares. The columns of ``A`` are the model of
:meth:`~linsense.model.inductance.InductanceModel.from_params` with one parameter set to 1, so
the fit and the model share one convention.

Standard errors come from the covariance ``sigma^2 (A' A)^-1`` with ``sigma^2 = RSS / (n - p)``,
taken separately for the self and the mutual entries: the self inductances depend only on
``L0, L_n`` and the mutuals only on ``M0, dM0, M_n``, so the problem splits exactly into two
independent least-squares problems, and their noise differs (the fed phase's voltage carries the
resistive drop; each mutual is the mean of two reciprocal measurements). One pooled ``sigma``
would understate the errors of the ``L`` parameters and overstate those of the ``M`` ones.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from linsense.errors import InputError
from linsense.model.inductance import InductanceModel

#: |t| = |dM0| / stderr(dM0) above this: the end-effect term is significant.
T_SIGNIFICANT = 3.0


def parameter_names(harmonics: int = 1) -> list[str]:
    """Names of the fitted parameters for ``harmonics = K`` even orders ``2 .. 2K``.

    Parameters
    ----------
    harmonics : int, optional
        ``K``.

    Returns
    -------
    list of str
        ``L0, L2, M0, M2, dM0`` then ``L<n>, M<n>`` for n = 4 .. 2K.
    """
    names = ["L0", "L2", "M0", "M2", "dM0"]
    for n in range(4, 2 * harmonics + 1, 2):
        names += [f"L{n}", f"M{n}"]
    return names


def _model_of(values: dict[str, float], harmonics: int) -> InductanceModel:
    harm = {n: (values[f"L{n}"], values[f"M{n}"]) for n in range(4, 2 * harmonics + 1, 2)}
    return InductanceModel.from_params(values["L0"], values["L2"], values["M0"], values["M2"],
                                       values["dM0"], harm)


def design_matrix(theta: np.ndarray, harmonics: int = 1) -> np.ndarray:
    """Matrix ``A`` (6 N, P) of the linear fit: row ``6 i + j`` is entry ``j`` at ``theta[i]``.

    One column per parameter (:func:`parameter_names`).

    Parameters
    ----------
    theta : ndarray, shape (N,)
        Electrical positions, rad.
    harmonics : int, optional
        ``K``.

    Returns
    -------
    ndarray, shape (6 N, P)
        Dimensionless (entries per henry of each parameter).
    """
    names = parameter_names(harmonics)
    theta = np.asarray(theta, dtype=float)
    cols = []
    for name in names:
        unit = dict.fromkeys(names, 0.0)
        unit[name] = 1.0
        cols.append(_model_of(unit, harmonics).entries(theta).reshape(-1))
    return np.stack(cols, axis=1)


@dataclass(frozen=True)
class FitResult:
    """Fitted HF model parameters.

    Parameters
    ----------
    values, stderr : dict
        Parameter values and their standard errors, H.
    harmonics : int
        ``K``: even orders ``2 .. 2K`` fitted.
    residual_rms : float
        RMS of the ``6 N`` residuals, H.
    sigma : dict
        Residual standard deviation ``sqrt(RSS / (n - p))`` of the ``"self"`` and ``"mutual"``
        entries, H.
    dof : dict
        Degrees of freedom ``n - p`` of each group.
    residuals : ndarray, shape (N, 6)
        Table minus fit, H.
    """

    values: dict[str, float]
    stderr: dict[str, float]
    harmonics: int
    residual_rms: float
    sigma: dict[str, float]
    dof: dict[str, int]
    residuals: np.ndarray

    @property
    def end_effect_t(self) -> float:
        """t-statistic ``dM0 / stderr(dM0)`` (inf for an exact fit with dM0 != 0)."""
        se = self.stderr["dM0"]
        if se == 0.0:
            return 0.0 if self.values["dM0"] == 0.0 else float(np.copysign(np.inf, self.values["dM0"]))
        return self.values["dM0"] / se

    @property
    def end_effect_significant(self) -> bool:
        """True when ``|t| > T_SIGNIFICANT``."""
        return bool(abs(self.end_effect_t) > T_SIGNIFICANT)

    def model(self) -> InductanceModel:
        """The fitted :class:`InductanceModel` (eq. 3 with the fitted harmonics).

        Returns
        -------
        InductanceModel
            From :attr:`values`.
        """
        return _model_of(self.values, self.harmonics)


def fit_inductances(theta: np.ndarray, entries: np.ndarray, harmonics: int = 1,
                    source: str = "table") -> FitResult:
    """Fit eq. (3) with even orders ``2 .. 2 harmonics`` to a table by linear least squares.

    Parameters
    ----------
    theta : ndarray, shape (N,)
        Electrical positions, rad.
    entries : ndarray, shape (N, 6)
        ``L_A, L_B, L_C, M_AB, M_BC, M_CA``, H.
    harmonics : int
        ``K >= 1``: fit orders 2, 4, ..., 2K (``K = 1`` is the five parameters of eq. 3).
    source : str
        For messages.

    Returns
    -------
    FitResult
        Values, standard errors, residuals.

    Raises
    ------
    InputError
        The positions cannot separate the requested harmonics (rank-deficient design matrix).
    ValueError
        ``harmonics`` below 1.
    """
    if harmonics < 1:
        raise ValueError("harmonics must be >= 1")
    theta = np.asarray(theta, dtype=float)
    y = np.asarray(entries, dtype=float).reshape(-1)
    A = design_matrix(theta, harmonics)
    names = parameter_names(harmonics)
    P = len(names)
    if np.linalg.matrix_rank(A) < P or y.size <= P:
        raise InputError(
            source, "--harmonics",
            f"{harmonics} (orders up to {2 * harmonics}) cannot be separated with {theta.size} "
            "distinct positions: use fewer harmonics or measure more positions",
        )
    p, *_ = np.linalg.lstsq(A, y, rcond=None)
    res = y - A @ p
    is_self = np.tile(np.arange(6) < 3, theta.size)
    cov = np.zeros((P, P))
    sigma, dof = {}, {}
    for group, rows in (("self", is_self), ("mutual", ~is_self)):
        Ag = A[rows]
        used = np.any(Ag != 0.0, axis=0)  # the parameters this group depends on
        n_g, p_g = int(rows.sum()), int(used.sum())
        if n_g <= p_g:
            raise InputError(source, "--harmonics",
                             f"{harmonics}: too many parameters for {theta.size} positions")
        s2 = float(res[rows] @ res[rows]) / (n_g - p_g)
        cov[np.ix_(used, used)] = s2 * np.linalg.inv(Ag[:, used].T @ Ag[:, used])
        sigma[group], dof[group] = float(np.sqrt(s2)), n_g - p_g
    se = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    return FitResult(
        values={n: float(v) for n, v in zip(names, p, strict=True)},
        stderr={n: float(s) for n, s in zip(names, se, strict=True)},
        harmonics=harmonics,
        residual_rms=float(np.sqrt(np.mean(res**2))),
        sigma=sigma,
        dof=dof,
        residuals=res.reshape(-1, 6),
    )


#: the pole pitches :func:`best_pitch` tries, as factors of the one given: a geometric grid of
#: PITCH_STEPS steps over PITCH_RANGE (0.5 % apart), then refined around the best
PITCH_RANGE = (0.5, 2.0)
PITCH_STEPS = 280
#: the fit at another pole pitch leaves at most this share of the residual at the one given: the
#: bench's positions are of another motor (a 60 mm motor read with 56 mm leaves 6.5 times the
#: residual of its own pitch; a motor with harmonics fitted without them, at its own pitch, 1.002)
PITCH_RESIDUAL_SHARE = 0.5


def best_pitch(position: np.ndarray, entries: np.ndarray, pole_pitch: float, harmonics: int = 1) -> tuple:
    """The pole pitch whose model fits the measured inductances best, near the one given.

    Fits the model (:func:`fit_inductances`) with the positions converted by each pitch of a
    geometric grid over :data:`PITCH_RANGE` times ``pole_pitch``, then refines around the best (a
    bounded scalar search); a pitch whose positions the model cannot separate is skipped.

    Parameters
    ----------
    position : ndarray, shape (N,)
        The measured positions, m.
    entries : ndarray, shape (N, 6)
        ``L_A .. M_CA`` at those positions, H.
    pole_pitch : float
        The pole pitch the bench is read with, m.
    harmonics : int, optional
        ``K``, as :func:`fit_inductances`.

    Returns
    -------
    pitch : float
        The best pole pitch, m.
    residual_rms : float
        The fit's residual there, H.
    """
    from scipy.optimize import minimize_scalar

    position = np.asarray(position, dtype=float)
    y = np.asarray(entries, dtype=float).reshape(-1)
    n_par = len(parameter_names(harmonics))

    def rms(p: float) -> float:  # (fit_inductances' least squares, without its statistics)
        A = design_matrix(2.0 * np.pi * position / p, harmonics)
        coef, _, rank, _ = np.linalg.lstsq(A, y, rcond=None)
        if rank < n_par:  # (positions the model cannot separate at this pitch)
            return np.inf
        return float(np.sqrt(np.mean((y - A @ coef) ** 2)))

    grid = pole_pitch * np.geomspace(*PITCH_RANGE, PITCH_STEPS + 1)
    values = np.array([rms(p) for p in grid])
    i = int(np.argmin(values))
    lo, hi = grid[max(i - 1, 0)], grid[min(i + 1, grid.size - 1)]
    res = minimize_scalar(rms, bounds=(lo, hi), method="bounded", options={"xatol": 1e-6 * pole_pitch})
    return (float(res.x), float(res.fun)) if res.fun < values[i] else (float(grid[i]), float(values[i]))
