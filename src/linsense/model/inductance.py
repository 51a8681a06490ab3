"""HF inductance models of a three-phase linear PM motor with the end-effect.

Every model is held in one form: a Fourier series in the electrical position ``theta`` of the six
independent entries of the symmetric 3x3 matrix, in the order ``L_A, L_B, L_C, M_AB, M_BC, M_CA``::

    entry_j(theta) = sum_k  a[j, k] cos(k theta) + b[j, k] sin(k theta),   k = 0 .. K

The five-parameter model of paper eq. (3), its higher even harmonics and tabulated measurements
(bench or FEA) all map onto it, so the dq transform, the derivatives needed by the stability
analysis and the coefficients handed to the C plant come from a single source of truth.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from linsense._check import instance, integer, real, reals
from linsense.errors import InputError
from linsense.limits import max_angle, max_harmonic_order
from linsense.model.frames import ab_to_dq_matrix, abc_to_ab_matrix

#: Names of the six independent entries, in storage order.
ENTRIES = ("L_A", "L_B", "L_C", "M_AB", "M_BC", "M_CA")
#: (row, column) of each entry in the 3x3 matrix.
_INDEX = ((0, 0), (1, 1), (2, 2), (0, 1), (1, 2), (2, 0))
#: the columns ``linsense model`` writes after ``theta_deg`` and the six entries, each derived from
#: the entries (docs/cli.md; :func:`derived_columns`)
DERIVED_COLUMNS = ("L_d", "L_q", "L_dq", "saliency", "psi_lut_deg", "err_nolut_deg", "gain_nolut",
                   "L_alpha", "L_beta", "L_alphabeta")

#: named in the messages of the model's checks
_SRC = "linsense.model.inductance.InductanceModel"
#: positions above which a table is fitted through its normal equations in blocks of as many rows
#: (a (N, 2K+1) design matrix of 100,000 positions took 5 s in ``lstsq``)
_BLOCK = 4096


def _design(theta: np.ndarray, K: int, nyquist: bool = False) -> np.ndarray:
    """Columns ``cos(k theta)``, k = 0 .. K, then ``sin(k theta)``, k = 1 .. K (without
    ``sin(K theta)`` when ``nyquist``: on ``2K`` equally spaced positions it is zero)."""
    k = np.arange(K + 1)
    ks = k[1:K] if nyquist else k[1:]
    return np.concatenate([np.cos(np.outer(theta, k)), np.sin(np.outer(theta, ks))], axis=1)


def _pair(src: str, n: int, pair) -> tuple[float, float]:
    """``(L_n, M_n)`` of a harmonic as two finite floats, else InputError naming ``harmonics[n]``."""
    v = reals(pair, src, f"harmonics[{n}]", "inductances (L_n, M_n) in H", ndim=1)
    if v.size != 2:
        raise InputError(src, f"harmonics[{n}]", f"expected two inductances (L_n, M_n) in H, got {v.size}")
    return float(v[0]), float(v[1])


def _fit(theta: np.ndarray, y: np.ndarray, K: int, nyquist: bool = False) -> np.ndarray:
    """Least-squares coefficients of the series of order ``K`` through ``(theta, y)``, shape
    ``(2K+1, 6)`` (``(2K, 6)`` when ``nyquist``: no ``sin(K theta)`` column, see :func:`_design`).

    Up to :data:`_BLOCK` positions: ``lstsq`` on the design matrix. Above: its normal equations,
    summed over blocks of rows (bounded memory, a few hundred ms for 100,000 positions), solved
    when well conditioned (equally spaced positions: condition 2); else ``lstsq``.
    """
    if theta.size <= _BLOCK:
        return np.linalg.lstsq(_design(theta, K, nyquist), y, rcond=None)[0]
    n = 2 * K + (0 if nyquist else 1)
    G, b = np.zeros((n, n)), np.zeros((n, y.shape[1]))
    for i in range(0, theta.size, _BLOCK):
        A = _design(theta[i:i + _BLOCK], K, nyquist)
        G += A.T @ A
        b += A.T @ y[i:i + _BLOCK]
    w = np.linalg.eigvalsh(G)
    if w[0] > 1e-6 * w[-1]:  # (error of the solution about 1e6 eps: 1e-10 relative)
        return np.linalg.solve(G, b)
    return np.linalg.lstsq(_design(theta, K, nyquist), y, rcond=None)[0]


@dataclass(frozen=True)
class InductanceModel:
    """Fourier-series model of ``L_abc(theta)``.

    Parameters
    ----------
    a, b : ndarray, shape (6, K + 1)
        Cosine and sine coefficients (H) of harmonic order ``k = 0..K`` of the entries
        ``L_A, L_B, L_C, M_AB, M_BC, M_CA``. ``b[:, 0]`` is ignored (kept zero).
    description : str
        Human-readable provenance, e.g. ``"eq. 3 parameters"`` or the table file.
    params : dict
        The eq. (3) parameters (``L0, L2, M0, M2, dM0`` and ``L<n>, M<n>`` of higher harmonics), H,
        of a parametric model (:meth:`from_params`); empty for a table.

    Raises
    ------
    linsense.errors.InputError
        When ``a`` and ``b`` are not both finite real numbers of shape ``(6, K + 1)``, ``K`` up to
        :data:`~linsense.limits.MAX_HARMONIC_ORDER`.
    """

    a: np.ndarray
    b: np.ndarray
    description: str = ""
    params: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        # one validated path: NaN, complex or string coefficients gave a model of NaN or
        # numpy's own traceback
        a = np.array(reals(self.a, _SRC, "a", "coefficients in H", ndim=2, min_size=6))
        b = np.array(reals(self.b, _SRC, "b", "coefficients in H", ndim=2, min_size=6))
        if a.shape[0] != 6 or a.shape != b.shape or a.shape[1] > max_harmonic_order() + 1:
            raise InputError(_SRC, "a, b", f"coefficient arrays must both be (6, K + 1) with K <= "
                             f"{max_harmonic_order()}, got {a.shape} and {b.shape}")
        instance(self.description, _SRC, "description", str, "a str")
        instance(self.params, _SRC, "params", dict, "a dict")
        b[:, 0] = 0.0
        a.setflags(write=False)
        b.setflags(write=False)
        object.__setattr__(self, "a", a)
        object.__setattr__(self, "b", b)

    # ------------------------------------------------------------------ construction
    @classmethod
    def from_params(
        cls,
        L0: float,
        L2: float,
        M0: float,
        M2: float,
        dM0: float,
        harmonics: dict[int, tuple[float, float]] | None = None,
    ) -> InductanceModel:
        """The sinusoidal model of paper eq. (3), optionally with higher even harmonics.

        ``L_A = L0 + sum_n L_n cos(n theta)``, with ``n = 2, 4, 6 ...`` and ``L_2 = L2``;
        ``L_B(theta) = L_A(theta - 2 pi/3)``, ``L_C(theta) = L_A(theta + 2 pi/3)``.
        Each mutual is even about the axis midway between its two phases:
        ``M_AB = M0 + sum_n M_n cos(n (theta - pi/3))``,
        ``M_BC = M0 + dM0 + sum_n M_n cos(n theta)``,
        ``M_CA = M0 + dM0 + sum_n M_n cos(n (theta + pi/3))``.
        For ``n = 2`` these are exactly eq. (3); ``dM0`` is the end-effect.

        Parameters
        ----------
        L0, L2, M0, M2, dM0 : float
            Eq. (3) parameters, H.
        harmonics : dict, optional
            ``{n: (L_n, M_n)}`` for even orders ``n >= 4``, H.

        Returns
        -------
        InductanceModel
            The model, with ``params`` holding the parameters.

        Raises
        ------
        linsense.errors.InputError
            A parameter that is not a finite real number, a harmonic order that is odd, below 4 or
            beyond :data:`~linsense.limits.MAX_HARMONIC_ORDER`.
        """
        src = f"{_SRC}.from_params"
        L0, L2, M0, M2, dM0 = (real(v, src, k, what="a finite inductance in H")
                               for k, v in zip(("L0", "L2", "M0", "M2", "dM0"), (L0, L2, M0, M2, dM0),
                                               strict=True))
        orders = {2: (L2, M2)}
        instance(harmonics if harmonics is not None else {}, src, "harmonics", dict, "a dict {n: (L_n, M_n)}")
        for n, pair in (harmonics or {}).items():
            n = integer(n, src, "harmonics", 4, max_harmonic_order(), "an even harmonic order")
            if n % 2:
                raise InputError(src, "harmonics", f"harmonic order must be even and >= 4, got {n}")
            Ln, Mn = _pair(src, n, pair)
            orders[n] = (Ln, Mn)
        K = max(orders)
        a = np.zeros((6, K + 1))
        b = np.zeros((6, K + 1))
        a[0:3, 0] = L0
        a[3, 0] = M0
        a[4:6, 0] = M0 + dM0
        # cos(n (theta - phi)) = cos(n phi) cos(n theta) + sin(n phi) sin(n theta)
        self_shift = (0.0, 2 * np.pi / 3, -2 * np.pi / 3)
        mutual_shift = (np.pi / 3, 0.0, -np.pi / 3)
        for n, (Ln, Mn) in orders.items():
            for j, phi in enumerate(self_shift):
                a[j, n] += Ln * np.cos(n * phi)
                b[j, n] += Ln * np.sin(n * phi)
            for j, phi in enumerate(mutual_shift):
                a[3 + j, n] += Mn * np.cos(n * phi)
                b[3 + j, n] += Mn * np.sin(n * phi)
        params = {"L0": L0, "L2": L2, "M0": M0, "M2": M2, "dM0": dM0}
        for n in sorted(orders):
            if n >= 4:
                params[f"L{n}"], params[f"M{n}"] = orders[n]
        return cls(a, b, description="paper eq. (3) parameters", params=params)

    @classmethod
    def from_table(
        cls,
        theta: np.ndarray,
        entries: np.ndarray,
        max_order: int | None = None,
        description: str = "table",
    ) -> InductanceModel:
        """Periodic (trigonometric) least-squares fit of tabulated ``L_abc(theta)``.

        With ``N`` equally spaced samples and the default order ``N // 2`` the series
        interpolates the table exactly, as a real DFT: for an odd ``N`` the orders up to
        ``(N - 1) / 2``; for an even ``N`` also the cosine of order ``N / 2`` (the Nyquist term,
        with its half weight ``sum_i y_i (-1)^i / N``; its sine is zero on the grid and is not
        fitted). It was left out: 8 positions of a motor with ``L4`` missed ``L4`` at every point.
        A smaller ``max_order`` smooths the table (least squares). The order is at
        most :data:`~linsense.limits.MAX_TABLE_ORDER` (63, the simulator's limit): a table of
        more than 127 positions is fitted by least squares up to it (interpolated exactly, 8,000
        positions took minutes and 100,000 asked for 37 GiB; every use of the model costs in
        proportion to its order).

        Parameters
        ----------
        theta : ndarray, shape (N,)
            Electrical positions, rad.
        entries : ndarray, shape (N, 6)
            ``L_A, L_B, L_C, M_AB, M_BC, M_CA`` at each position, H.
        max_order : int, optional
            Highest harmonic order of the fit (default: ``N // 2``, capped at ``MAX_TABLE_ORDER``).
        description : str
            Provenance, e.g. ``"table t8.csv"``.

        Returns
        -------
        InductanceModel
            The fitted series; ``b[:, N / 2]`` is zero when the Nyquist cosine is fitted.

        Raises
        ------
        linsense.errors.InputError
            ``theta`` not one dimension of finite real numbers, ``entries`` not of shape ``(N, 6)``,
            ``max_order`` not an order up to :data:`~linsense.limits.MAX_TABLE_ORDER`.
        """
        src = f"{_SRC}.from_table"
        theta = reals(theta, src, "theta", "positions in rad", ndim=1, min_size=1)
        entries = reals(entries, src, "entries", "inductances in H", ndim=2)
        N = theta.size
        if entries.shape != (N, 6):
            raise InputError(src, "entries", f"expected shape ({N}, 6) (L_A .. M_CA at each of the {N} "
                             f"positions), got {entries.shape}")
        k_max = max_harmonic_order()  # MAX_TABLE_ORDER, the simulator's limit (read from the C library)
        if max_order is not None:
            max_order = integer(max_order, src, "max_order", 0, k_max, "a harmonic order")
        K = min(N // 2, k_max if max_order is None else max_order, k_max)
        # (with 2K positions the order K has one degree of freedom: its cosine; N columns for N rows)
        nyquist = 2 * K == N
        coef = _fit(theta, entries, K, nyquist)
        a = coef[: K + 1].T
        sines = [np.zeros((6, 1)), coef[K + 1 :].T] + ([np.zeros((6, 1))] if nyquist else [])
        b = np.concatenate(sines, axis=1)
        return cls(a, b, description=description)

    # ------------------------------------------------------------------ evaluation
    @property
    def max_order(self) -> int:
        """Highest harmonic order ``K`` of the series."""
        return self.a.shape[1] - 1

    def entries(self, theta: np.ndarray | float, derivative: int = 0) -> np.ndarray:
        """The six entries, or their ``derivative``-th derivative in theta.

        Parameters
        ----------
        theta : float or ndarray
            Electrical position(s), rad.
        derivative : int, optional
            Order of the derivative in theta (0: the entries themselves).

        Returns
        -------
        ndarray, shape theta.shape + (6,)
            ``L_A, L_B, L_C, M_AB, M_BC, M_CA``, H (H/rad^derivative).

        Raises
        ------
        linsense.errors.InputError
            ``theta`` not finite real numbers, ``derivative`` not an integer in 0 .. 8.
        """
        theta = reals(theta, f"{_SRC}.entries", "theta", "positions in rad", bound=max_angle())
        derivative = integer(derivative, f"{_SRC}.entries", "derivative", 0, 8, "a derivative's order")
        k = np.arange(self.max_order + 1)
        kt = theta[..., None] * k
        c, s = np.cos(kt), np.sin(kt)
        # d^m/dtheta^m of (a cos + b sin) = k^m (a cos(kt + m pi/2) + b sin(kt + m pi/2))
        for _ in range(derivative):
            c, s = -k * s, k * c
        return c @ self.a.T + s @ self.b.T

    def L_abc(self, theta: np.ndarray | float, derivative: int = 0) -> np.ndarray:
        """Phase inductance matrix ``(..., 3, 3)``, H (or its theta-derivative, H/rad).

        Parameters
        ----------
        theta : float or ndarray
            Electrical position(s), rad.
        derivative : int, optional
            Order of the derivative in theta.

        Returns
        -------
        ndarray, shape theta.shape + (3, 3)
            The symmetric phase matrix, H (H/rad^derivative).
        """
        return entry_matrices(self.entries(theta, derivative))

    def L_ab(self, theta: np.ndarray | float, derivative: int = 0) -> np.ndarray:
        """Alpha-beta block ``(..., 2, 2)`` seen by currents with a floating star point.

        Parameters
        ----------
        theta : float or ndarray
            Electrical position(s), rad.
        derivative : int, optional
            Order of the derivative in theta.

        Returns
        -------
        ndarray, shape theta.shape + (2, 2)
            H (H/rad^derivative).
        """
        return abc_to_ab_matrix(self.L_abc(theta, derivative))

    def L_dq(self, theta: np.ndarray | float) -> np.ndarray:
        """dq inductance matrix ``[[L_d, L_dq], [L_dq, L_q]]`` ``(..., 2, 2)``, by transforming L_abc.

        Parameters
        ----------
        theta : float or ndarray
            Electrical position(s), rad (also the angle of the dq frame).

        Returns
        -------
        ndarray, shape theta.shape + (2, 2)
            H.
        """
        return ab_to_dq_matrix(self.L_ab(theta), theta)

    def dL_dq(self, theta: np.ndarray | float) -> np.ndarray:
        """Derivative of :meth:`L_dq` with respect to theta, H/rad.

        With ``L_dq = R' L_ab R`` and ``dR/dtheta = R J``, ``J = [[0, -1], [1, 0]]``:
        ``dL_dq = R' L_ab' R + J' L_dq + L_dq J``.

        Parameters
        ----------
        theta : float or ndarray
            Electrical position(s), rad.

        Returns
        -------
        ndarray, shape theta.shape + (2, 2)
            H/rad.
        """
        J = np.array([[0.0, -1.0], [1.0, 0.0]])
        Ldq = self.L_dq(theta)
        return ab_to_dq_matrix(self.L_ab(theta, 1), theta) + J.T @ Ldq + Ldq @ J

    @property
    def end_effect(self) -> float:
        """The end effect ``dM0`` as the coefficients hold it (eq. 3: the constant part of ``M_BC`` and
        ``M_CA`` beyond ``M_AB``), H; any model, a table's Fourier form too."""
        return _dm0(self.a)

    def scaled(self, k_inductance: float = 1.0, k_end_effect: float = 1.0,
               description: str | None = None) -> InductanceModel:
        """The model with every coefficient scaled by ``k_inductance`` and then its end effect
        (:attr:`end_effect`) by ``k_end_effect``: the constants of ``M_BC`` and ``M_CA`` moved by
        ``(k_end_effect - 1) dM0``. Any model (its Fourier form: the eq. 3 parameters are not kept).

        Parameters
        ----------
        k_inductance, k_end_effect : float, optional
            Factors, dimensionless.
        description : str or None, optional
            The new model's (None: this one's).

        Returns
        -------
        InductanceModel
            The scaled model.
        """
        a, b = np.array(self.a) * k_inductance, np.array(self.b) * k_inductance
        d_m0 = _dm0(a)
        a[4, 0] += (k_end_effect - 1.0) * d_m0
        a[5, 0] += (k_end_effect - 1.0) * d_m0
        return InductanceModel(a, b, description=self.description if description is None else description)

    def without_end_effect(self) -> InductanceModel:
        """The same model with the end-effect removed (``dM0 = 0``), for paper Fig. 5.

        Only defined for parametric models: a table has no separable end-effect term.

        Returns
        -------
        InductanceModel
            The eq. (3) model of the same parameters with ``dM0 = 0``.

        Raises
        ------
        ValueError
            For a tabulated model (no ``params``).
        """
        if not self.params:
            raise ValueError("the end-effect is only separable for a parametric (eq. 3) model")
        p = dict(self.params)
        harm = {
            int(k[1:]): (p[k], p[f"M{k[1:]}"]) for k in p if k.startswith("L") and k[1:] not in ("0", "2")
        }
        return InductanceModel.from_params(p["L0"], p["L2"], p["M0"], p["M2"], 0.0, harm)


def _dm0(a: np.ndarray) -> float:
    """``dM0`` of the cosine coefficients ``a`` (:attr:`InductanceModel.end_effect`), H."""
    return 0.5 * (a[4, 0] + a[5, 0]) - a[3, 0]


def entry_matrices(entries: np.ndarray) -> np.ndarray:
    """Symmetric 3x3 matrices ``(..., 3, 3)`` from the six entries ``(..., 6)``.

    Parameters
    ----------
    entries : ndarray, shape (..., 6)
        ``L_A .. M_CA`` (:data:`ENTRIES`), H.

    Returns
    -------
    ndarray, shape (..., 3, 3)
        H.
    """
    e = np.asarray(entries, dtype=float)
    L = np.empty(e.shape[:-1] + (3, 3))
    for j, (r, c) in enumerate(_INDEX):
        L[..., r, c] = e[..., j]
        L[..., c, r] = e[..., j]
    return L


def derived_columns(theta: np.ndarray, entries: np.ndarray) -> dict[str, np.ndarray]:
    """The :data:`DERIVED_COLUMNS` of a table of the six entries, as ``linsense model`` writes them.

    Pointwise from each position's matrix: the alpha-beta and dq inductances, the saliency
    ``L_q - L_d``, ``psi_lut_deg`` (eq. 12, ``atan(-L_dq/L_q)``) and ``err_nolut_deg`` (``tan 2e* =
    2 L_dq / (L_d - L_q)``, the stable root; docs/theory.md section 6); ``gain_nolut`` (``1 +
    de*/dtheta``) needs ``dL/dtheta``, which a table does not have: it is the derivative of the
    trigonometric series through the table (:meth:`InductanceModel.from_table`, default order).

    Parameters
    ----------
    theta : ndarray, shape (N,)
        Electrical positions, rad.
    entries : ndarray, shape (N, 6)
        ``L_A .. M_CA`` at those positions, H.

    Returns
    -------
    dict of str to ndarray
        The columns by name (H, electrical degrees, dimensionless).
    """
    theta = np.asarray(theta, dtype=float)
    L_ab = abc_to_ab_matrix(entry_matrices(entries))
    L_dq = ab_to_dq_matrix(L_ab, theta)
    L_d, L_q, L_x = L_dq[:, 0, 0], L_dq[:, 1, 1], L_dq[:, 0, 1]
    s = 1.0 if np.mean(L_q - L_d) >= 0 else -1.0
    series = InductanceModel.from_table(theta, entries)
    L, dL = series.L_dq(theta), series.dL_dq(theta)
    u, w = L[:, 1, 1] - L[:, 0, 0], -2.0 * L[:, 0, 1]
    du, dw = dL[:, 1, 1] - dL[:, 0, 0], -2.0 * dL[:, 0, 1]
    with np.errstate(divide="ignore", invalid="ignore"):  # (no saliency: refused by the motor's checks)
        gain = 1.0 + 0.5 * (u * dw - w * du) / (u * u + w * w)
    return {"L_d": L_d, "L_q": L_q, "L_dq": L_x, "saliency": L_q - L_d,
            "psi_lut_deg": np.degrees(np.arctan2(-L_x, L_q)),
            "err_nolut_deg": np.degrees(0.5 * np.arctan2(-2.0 * L_x * s, (L_q - L_d) * s)),
            "gain_nolut": gain, "L_alpha": L_ab[:, 0, 0], "L_beta": L_ab[:, 1, 1],
            "L_alphabeta": L_ab[:, 0, 1]}
