"""Axisymmetric magnetostatics in r-z with the flux function psi = r * A_phi (scikit-fem, P2 triangles).

With ``B = curl(A_phi e_phi) = (1/r) (-d psi/dz, d psi/dr)`` and ``H = nu (B - B_r)``, the weak form
of ``curl H = J_phi`` over the meridian half-plane is (the factor 2 pi of the volume cancels)::

    integral (nu / r) grad psi . grad v  dr dz  =  integral J_phi v dr dz + integral nu B_rz dv/dr dr dz

for every test function v vanishing on the Dirichlet boundary (psi = 0 on the axis and on the far
boundary). The flux through the circle of radius r is 2 pi psi, so a coil of N turns, sign s and
cross-section S links ``lambda = s N / S * 2 pi * integral_coil psi dr dz``, and the current i in it
is the density ``J = s N i / S``: the inductance matrix is ``L = 2 pi F^T K^-1 F`` with F the
coil-density load vectors of the three phases (symmetric by construction). The field energy is
``W = integral nu |B|^2 / 2 dV = pi * integral (nu / r) |grad psi|^2 dr dz``.

The rod moves along z: the mesh is fixed (a tensor grid whose z nodes hold every coil and
armature boundary), and the rod's materials (magnet, iron spacer) are evaluated at every
quadrature point for the rod's position. The z step of the zone around the armature divides the
position step and, when possible, the magnet and spacer lengths (:func:`rod_step`), so the
rod's interfaces are element edges at every position and the materials are exact; when no such
step exists the interfaces are resolved to the quadrature points only (``rod_aligned`` false in
fea.json; a position ripple of the order of the mesh-convergence figure, docs/fea.md).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np
from scipy.sparse.linalg import splu

from linsense._extras import require
from linsense.fea.geometry import Geometry

# the finite elements are scikit-fem's (the fea extra): without it this module stops in one line
require("skfem", extra="fea", feature="the FEA (linsense fea)")
from skfem import Basis, BilinearForm, ElementTriP2, Functional, LinearForm, MeshTri, asm  # noqa: E402
from skfem.helpers import dot, grad  # noqa: E402

MU0 = 4e-7 * math.pi
PHASES = ("A", "B", "C")
#: mesh levels: elements per coil pitch in z (the element size target everywhere near the motor)
LEVELS = {"coarse": 2, "default": 4, "fine": 8}


@BilinearForm
def _stiffness(u, v, w):
    return w.nu / w.x[0] * dot(grad(u), grad(v))


@LinearForm
def _density(v, w):
    return w.j * v


@LinearForm
def _magnet(v, w):
    return w.nubr * grad(v)[0]


@BilinearForm
def _tangent(u, v, w):  # the Jacobian of the nonlinear residual: nu_t = nu + 2 dnu/ds B B^T
    g = grad(w.psi)
    r = w.x[0]
    return (w.nu / r * dot(grad(u), grad(v))
            + 2.0 * w.dnu / r ** 3 * dot(g, grad(u)) * dot(g, grad(v)))


@LinearForm
def _internal(v, w):  # integral nu / r grad psi . grad v
    return w.nu / w.x[0] * dot(grad(w.psi), grad(v))


class Curve:
    """A B-H curve: H(B) monotone cubic (PCHIP) through the table, slope 1/mu0 beyond its end;
    ``nu(B) = H / B`` and ``dnu/ds`` with ``s = B^2`` at the quadrature points.

    Parameters
    ----------
    bh : tuple
        ``(B, H)`` of the table, T and A/m.
    """

    def __init__(self, bh: tuple) -> None:
        from scipy.interpolate import CubicHermiteSpline, PchipInterpolator

        self.B = np.asarray(bh[0], float)
        self.H = np.asarray(bh[1], float)
        d = PchipInterpolator(self.B, self.H).derivative()(self.B)
        d[0] = self.H[1] / self.B[1]  # the initial permeability: the first secant (pchip may give 0)
        self.f = CubicHermiteSpline(self.B, self.H, d, extrapolate=False)
        self.df = self.f.derivative()
        self.nu0 = float(self.df(0.0))

    def __call__(self, B: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        b = np.maximum(B, 1e-9)
        inside = b <= self.B[-1]
        H = np.where(inside, self.f(np.minimum(b, self.B[-1])), self.H[-1] + (b - self.B[-1]) / MU0)
        dH = np.where(inside, self.df(np.minimum(b, self.B[-1])), 1.0 / MU0)
        nu = H / b
        dnu = (dH * b - H) / (2 * b ** 3)
        small = B < 1e-6
        return np.where(small, self.nu0, nu), np.where(small, 0.0, dnu)


class _Assembly:
    """The tangent matrix and the residual of the nonlinear solve, assembled by array products.

    scikit-fem's ``asm`` re-evaluates the form for each of the 36 pairs of P2 basis functions and
    builds a COO matrix every call; here the basis gradients times the quadrature weights are
    kept once per mesh, the element matrices are batched products, and their sum into the interior
    block (the Dirichlet dofs dropped) is one ``bincount`` onto a CSC pattern computed once. Same
    quadrature, same sums: equal to ``asm`` to rounding.
    """

    def __init__(self, basis: Basis, interior: np.ndarray) -> None:
        self.G = np.stack([b[0].grad for b in basis.basis], axis=-1).transpose(1, 2, 3, 0)  # (e, q, i, a)
        self.dx = basis.dx  # (e, q)
        self.r = basis.mapping.F(basis.X)[0]
        self.dofs = basis.element_dofs.T  # (e, i)
        nloc = self.dofs.shape[1]
        self.n = basis.N
        pos = np.full(basis.N, -1)
        pos[interior] = np.arange(interior.size)
        rows = pos[np.repeat(self.dofs, nloc, axis=1)].ravel()  # (e, i, j) -> i's interior index
        cols = pos[np.tile(self.dofs, (1, nloc))].ravel()
        self.valid = (rows >= 0) & (cols >= 0)
        ni = interior.size
        key = cols[self.valid].astype(np.int64) * ni + rows[self.valid]
        uniq, self.slot = np.unique(key, return_inverse=True)  # CSC order: by column, then row
        self.indices = (uniq % ni).astype(np.int32)
        self.indptr = np.concatenate([[0], np.cumsum(np.bincount(uniq // ni, minlength=ni))]).astype(np.int32)
        self.shape = (ni, ni)

    def grad(self, psi: np.ndarray) -> np.ndarray:
        """grad psi at the quadrature points, (e, q, 2)."""
        return np.einsum("ei,eqia->eqa", psi[self.dofs], self.G)

    def residual(self, nu: np.ndarray, g: np.ndarray) -> np.ndarray:
        """integral nu / r grad psi . grad v for every basis function v, (N,)."""
        w = self.dx * nu / self.r
        loc = np.einsum("eq,eqa,eqia->ei", w, g, self.G)
        return np.bincount(self.dofs.ravel(), loc.ravel(), minlength=self.n)

    def tangent(self, nu: np.ndarray, dnu: np.ndarray | None = None, g: np.ndarray | None = None):
        """The interior block of the Jacobian ``(nu / r) I + (2 dnu / r^3) g g^T`` as CSC (without
        ``dnu``: the stiffness matrix of linear materials)."""
        from scipy.sparse import csc_matrix

        w1 = self.dx * nu / self.r
        e, q, nb, _ = self.G.shape
        Gw = (self.G * w1[..., None, None]).transpose(0, 2, 1, 3).reshape(e, nb, 2 * q)
        K = Gw @ self.G.transpose(0, 1, 3, 2).reshape(e, 2 * q, nb)
        sat = np.flatnonzero(np.any(dnu != 0, axis=1)) if dnu is not None else []  # saturable iron
        if len(sat):
            Gg = np.einsum("eqia,eqa->eqi", self.G[sat], g[sat])
            w2 = 2.0 * (self.dx * dnu / self.r ** 3)[sat]
            K[sat] += np.einsum("eqi,eqj->eij", Gg * w2[..., None], Gg)
        data = np.bincount(self.slot, K.ravel()[self.valid], minlength=self.indices.size)
        return csc_matrix((data, self.indices, self.indptr), shape=self.shape)


def _lu(A):
    """Sparse LU of a symmetric positive definite interior block: minimum degree on A^T + A and
    diagonal pivots (SuperLU); 1.6x faster than the default COLAMD on these meshes, half the fill."""
    return splu(A.tocsc(), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.001,
                options={"SymmetricMode": True})


@Functional
def _energy(w):  # W = integral nu |B|^2 / 2 * 2 pi r dr dz, B = grad psi / r
    return math.pi * w.nu / w.x[0] * dot(grad(w.psi), grad(w.psi))


def _segment(a: float, b: float, size: float, minimum: int = 1) -> np.ndarray:
    n = max(minimum, math.ceil((b - a) / size - 1e-9))
    return np.linspace(a, b, n + 1)


def _graded(a: float, b: float, size: float, ratio: float = 1.35) -> np.ndarray:
    """Nodes from a to b (either order) starting with step ``size`` at a, growing by ``ratio``."""
    sgn = 1.0 if b > a else -1.0
    length = abs(b - a)
    pts, step, pos = [0.0], size, 0.0
    while pos + step < length * (1 - 1e-9):
        pos += step
        pts.append(pos)
        step *= ratio
    if length - pts[-1] < 0.3 * step and len(pts) > 1:
        pts.pop()
    pts.append(length)
    return a + sgn * np.array(pts)


@dataclass
class Mesh:
    """The fixed structured r-z triangle mesh (:func:`build_mesh`).

    Attributes
    ----------
    mesh : skfem.MeshTri
        The mesh.
    level : str
        ``coarse``, ``default`` or ``fine``.
    size : float
        Element size near the motor, m.
    r_nodes : ndarray
        Radial node coordinates, m.
    z_nodes : ndarray
        Axial node coordinates, m.
    rod_aligned : bool
        The rod's interfaces are element edges at every position.
    """
    mesh: MeshTri
    level: str
    size: float  # m, element size near the motor
    r_nodes: np.ndarray
    z_nodes: np.ndarray
    rod_aligned: bool = True  # the rod's interfaces are element edges at every position


def rod_step(g: Geometry, positions: int, target: float) -> tuple[float, bool]:
    """The z step of the fine zone.

    ``h = (pole_pitch / positions) / k``, the largest such step not above ``target`` that also
    divides the magnet and spacer ends (then every rod interface is an element edge at every
    position: the rod's materials are exact).

    Parameters
    ----------
    g : Geometry
        The geometry.
    positions : int
        Rod positions over one period.
    target : float
        Largest step wanted, m.

    Returns
    -------
    h : float
        m.
    aligned : bool
        Whether ``h`` divides the rod's interfaces.
    """
    step = g.pole_pitch / positions
    k0 = max(1, math.ceil(step / target - 1e-9))
    for k in range(k0, k0 + 64):
        h = step / k
        if all(abs(v / h - round(v / h)) < 1e-6 for v in (g.magnet_length / 2, g.pole_pitch / 2)):
            return h, True
    return step / k0, False


def build_mesh(g: Geometry, level: str = "default", positions: int = 56) -> Mesh:
    """The fixed structured r-z triangle mesh (scikit-fem ``MeshTri.init_tensor``).

    z: a uniform zone over the armature and its margins with the step of :func:`rod_step` (origin
    at the rod's reference, so the rod's interfaces fall on element edges at every position when
    the step divides them), plus every coil and armature boundary, then graded rows to the far
    boundary; r: every radial interface, graded beyond the back iron.

    Parameters
    ----------
    g : Geometry
        The geometry.
    level : {"coarse", "default", "fine"}, optional
        Mesh level.
    positions : int, optional
        Rod positions over one period (the z step divides their spacing).

    Returns
    -------
    Mesh
        The mesh.

    Raises
    ------
    ValueError
        An unknown level.
    """
    if level not in LEVELS:
        raise ValueError(f"mesh level must be one of {', '.join(LEVELS)}, got {level!r}")
    n = LEVELS[level]
    pitch = min(c.z1 - c.z0 for c in g.coils)
    target = pitch / n
    h, aligned = rod_step(g, positions, target)
    if level == "fine":  # at least twice as fine as the default in z too
        h_default = rod_step(g, positions, pitch / LEVELS["default"])[0]
        h, aligned = rod_step(g, positions, 0.5 * h_default * (1 + 1e-9))
    rmin = {"coarse": 1, "default": 2, "fine": 3}[level]
    r = [_segment(0.0, g.r_rod, target)]
    if g.r_tube > g.r_rod:
        r.append(_segment(g.r_rod, g.r_tube, target))
    r += [_segment(g.r_tube, g.r_bore, target, rmin), _segment(g.r_bore, g.r_coil, target, 2 * rmin),
          _segment(g.r_coil, g.r_out, target, rmin), _graded(g.r_out, g.r_far, target)]
    r_nodes = np.unique(np.concatenate(r))
    zf0, zf1 = g.z_far
    a = math.floor((g.z_arm0 - g.margin) / h)
    b = math.ceil((g.z_arm1 + g.margin) / h)
    uni = h * np.arange(a, b + 1)
    edges = [g.z_arm0, g.z_arm1, *[c.z0 for c in g.coils], *[c.z1 for c in g.coils]]
    first = max(h, target)
    z = [_graded(uni[0], zf0, first)[::-1], uni, np.array(edges), _graded(uni[-1], zf1, first)]
    z_all = np.sort(np.concatenate(z))
    z_nodes = z_all[np.concatenate([[True], np.diff(z_all) > 1e-9 * g.pole_pitch])]
    return Mesh(MeshTri.init_tensor(r_nodes, z_nodes), level, h, r_nodes, z_nodes, aligned)


@dataclass
class Solution:
    """What one position's solves give.

    Attributes
    ----------
    x : float
        Rod position, m.
    L : ndarray, shape (3, 3)
        Inductances, H.
    psi_pm : ndarray, shape (3,)
        PM flux linkage per phase, Wb.
    energy : ndarray, shape (3,)
        Field energy of each phase at 1 A, J.
    energy_li : ndarray, shape (3,)
        ``L_pp / 2`` for the same, J.
    newton : int
        Newton iterations (0: linear materials).
    fields : dict or None
        psi per excitation (kept on request).
    """

    x: float  # m, rod position
    L: np.ndarray  # 3x3, H
    psi_pm: np.ndarray  # (3,), Wb, PM flux linkage per phase
    energy: np.ndarray  # (3,), J, field energy of each phase at 1 A
    energy_li: np.ndarray  # (3,), J, 1/2 L_pp for the same
    newton: int = 0  # Newton iterations (0: linear materials)
    fields: dict | None = None  # psi per excitation (kept on request)


@dataclass
class Result:
    """The FEA of a geometry at one load: inductances and PM flux linkages over the positions.

    Attributes
    ----------
    geometry : Geometry
        The geometry.
    mesh : Mesh
        The mesh.
    positions : ndarray
        Rod positions, m.
    theta : ndarray
        Electrical positions, rad, 0 where phase A's PM flux linkage peaks (raw if no PM).
    L : ndarray, shape (N, 3, 3)
        Inductances (incremental with a B-H curve), H.
    psi_pm : ndarray, shape (N, 3)
        PM flux linkages, Wb.
    psi_pm_amplitude : float
        Fundamental of phase A's, Wb.
    theta_offset : float
        ``theta = direction * 2 pi x / P - offset``, rad.
    direction : int
        1 or -1.
    times : dict
        Timings, s.
    energy_error : float or None
        ``max |W_field - i^T L i / 2| / (i^T L i / 2)``; None: nonlinear (not checked).
    newton : dict or None
        Newton iterations per position (max, mean); None: linear.
    load_current : float
        q-axis current, A.
    keep : dict
        The solver and the first position's solution (for fea.json and the checks).
    d_current : float
        d-axis current, A (along the magnets' flux: > 0 strengthens it).
    """
    geometry: Geometry
    mesh: Mesh
    positions: np.ndarray  # m
    theta: np.ndarray  # rad, electrical, 0 where phase A's PM flux linkage peaks (raw if no PM)
    L: np.ndarray  # (N, 3, 3), H
    psi_pm: np.ndarray  # (N, 3), Wb
    psi_pm_amplitude: float  # Wb, fundamental of phase A
    theta_offset: float  # rad, theta = direction * 2 pi x / P - offset
    direction: int
    times: dict = field(default_factory=dict)
    energy_error: float | None = 0.0  # max |W_field - 1/2 i^T L i| / (1/2 i^T L i); None: nonlinear
    newton: dict | None = None  # Newton iterations per position (max, mean); None: linear
    load_current: float = 0.0  # A, q-axis
    keep: dict = field(default_factory=dict)
    d_current: float = 0.0  # A, d-axis (along the magnets' flux: > 0 strengthens it)


class Solver:
    """The mesh, the fixed armature, the coil load vectors: solves one rod position at a time.

    Parameters
    ----------
    g : Geometry
        The geometry.
    level : {"coarse", "default", "fine"}, optional
        Mesh level.
    positions : int, optional
        Rod positions over one period.
    """

    def __init__(self, g: Geometry, level: str = "default", positions: int = 56) -> None:
        self.g = g
        self.m = build_mesh(g, level, positions)
        self.basis = Basis(self.m.mesh, ElementTriP2(), intorder=4)
        r, z = self.basis.mapping.F(self.basis.X)  # quadrature points (nelems, nqp)
        self.r, self.z = r, z
        in_arm = (z > g.z_arm0) & (z < g.z_arm1)
        self.nu_fixed = np.full(r.shape, 1.0 / MU0)
        self.nu_fixed[in_arm & (r > g.r_coil) & (r < g.r_out)] = 1.0 / (MU0 * g.mu_arm_iron)
        self.in_rod = r < g.r_rod
        self.arm_iron = in_arm & (r > g.r_coil) & (r < g.r_out)
        self.curve_rod = Curve(g.bh_rod) if g.bh_rod else None
        self.curve_arm = Curve(g.bh_arm) if g.bh_arm else None
        self.loads = []
        for p in PHASES:
            j = np.zeros(r.shape)
            for c in g.coils:
                if c.phase == p:
                    inside = (r > c.r0) & (r < c.r1) & (z > c.z0) & (z < c.z1)
                    j[inside] += c.sign * c.turns / c.area
            self.loads.append(asm(_density, self.basis, j=j))
        self.F = np.column_stack(self.loads)
        self.I = np.setdiff1d(np.arange(self.basis.N), self.basis.get_dofs().all())
        self.asm = _Assembly(self.basis, self.I)

    @property
    def ndofs(self) -> int:
        """Degrees of freedom of the P2 basis."""
        return self.basis.N

    def rod_pattern(self, x: float) -> np.ndarray:
        """The rod's magnetisation pattern at rod position ``x``, at the quadrature points.

        +1 / -1 in the magnets (axial magnetisation sign), 0 in the spacers (and outside the rod).

        Parameters
        ----------
        x : float
            Rod position, m.

        Returns
        -------
        ndarray
            Per element and quadrature point.
        """
        P, half = self.g.pole_pitch, self.g.magnet_length / 2
        u = np.mod(self.z - x + P / 2, P) - P / 2  # in [-P/2, P/2): 0 at a + magnet's centre
        s = np.zeros(self.z.shape)
        s[np.abs(u) < half] = 1.0
        s[np.abs(np.abs(u) - P / 2) < half] = -1.0
        return np.where(self.in_rod, s, 0.0)

    @property
    def nonlinear(self) -> bool:
        """Whether a B-H curve makes the solves nonlinear."""
        return self.curve_rod is not None or self.curve_arm is not None

    def solve_nonlinear(self, x: float, currents=(0.0, 0.0, 0.0), keep: bool = False, tol: float = 1e-7,
                        max_iter: int = 40, psi0: np.ndarray | None = None) -> Solution:
        """Newton iterations for the state set by the magnets and the phase currents.

        Then the incremental inductances ``2 pi F^T J^-1 F`` with J the Jacobian (the tangent
        reluctivity) there.

        Parameters
        ----------
        x : float
            Rod position, m.
        currents : sequence of float, optional
            Phase currents, A.
        keep : bool, optional
            Keep the fields in the solution.
        tol : float, optional
            Relative step tolerance of the iterations.
        max_iter : int, optional
            Most iterations.
        psi0 : ndarray or None, optional
            Start (None: the linear solution with mu_r 1000 in the saturable iron).

        Returns
        -------
        Solution
            Incremental inductances, PM flux linkages and the iterations.

        Raises
        ------
        RuntimeError
            No convergence in ``max_iter`` iterations.
        """
        nu_lin, masks, rhs = self._nonlinear_problem(x, currents)
        I = self.I

        A = self.asm

        def state(psi):
            gr = A.grad(psi)
            B = np.sqrt(gr[..., 0] ** 2 + gr[..., 1] ** 2) / self.r
            nu, dnu = nu_lin.copy(), np.zeros(nu_lin.shape)
            for mask, curve in masks:
                nu[mask], dnu[mask] = curve(B[mask])
            res = A.residual(nu, gr) - rhs
            return gr, nu, dnu, res[I], B

        psi = self._nonlinear_start(nu_lin, masks, rhs) if psi0 is None else np.array(psi0, float)
        field, nu, dnu, res, B = state(psi)
        it = 0
        while True:
            if it == max_iter:
                raise RuntimeError(f"Newton did not converge in {max_iter} iterations at x = {x!r} m")
            du = -_lu(A.tangent(nu, dnu, field)).solve(res)
            norm0 = np.linalg.norm(res)
            step = 1.0
            for _ in range(12):  # backtracking: the residual must decrease
                trial = psi.copy()
                trial[I] += step * du
                t_state = state(trial)
                if np.linalg.norm(t_state[3]) < norm0 or step < 1e-3:
                    break
                step *= 0.5
            psi = trial
            field, nu, dnu, res, B = t_state
            it += 1
            if step * np.abs(du).max() <= tol * max(np.abs(psi).max(), 1e-30):
                break
        # the Jacobian at the converged state (one more assembly) gives the incremental inductances
        lu = _lu(A.tangent(nu, dnu, field))
        inc = np.zeros((self.basis.N, 3))
        inc[I] = lu.solve(np.ascontiguousarray(self.F[I]))
        L = 2 * math.pi * self.F.T @ inc
        L = 0.5 * (L + L.T)
        link = 2 * math.pi * self.F.T @ psi
        fields = {"psi": np.column_stack([inc, psi]), "nu": nu, "B_max": float(B.max())} if keep else None
        self.last_state = psi
        half = 0.5 * np.diag(L)
        return Solution(x, L, link, half, half, fields=fields, newton=it)

    def _nonlinear_problem(self, x: float, currents) -> tuple[np.ndarray, list, np.ndarray]:
        """The reluctivity of the linear materials at rod position ``x``, the (mask, B-H curve)
        pairs of the saturable iron, and the right-hand side of the magnets and ``currents``."""
        g = self.g
        pat = self.rod_pattern(x)
        nu_mag = 1.0 / (MU0 * g.mu_magnet)
        nu_lin = self.nu_fixed.copy()
        nu_lin[self.in_rod] = np.where(pat[self.in_rod] != 0, nu_mag, 1.0 / (MU0 * g.mu_rod_iron))
        masks = []
        if self.curve_rod is not None:
            masks.append((self.in_rod & (pat == 0), self.curve_rod))
        if self.curve_arm is not None:
            masks.append((self.arm_iron, self.curve_arm))
        rhs = self.F @ np.asarray(currents, float)
        if g.remanence > 0:
            rhs = rhs + asm(_magnet, self.basis, nubr=nu_mag * g.remanence * pat)
        return nu_lin, masks, rhs

    def _nonlinear_start(self, nu_lin: np.ndarray, masks: list, rhs: np.ndarray) -> np.ndarray:
        """Newton's start: the linear solution with mu_r 1000 in the saturable iron."""
        A, I = self.asm, self.I
        nu0 = nu_lin.copy()
        for mask, _ in masks:
            nu0[mask] = 1.0 / (MU0 * 1000.0)
        psi = np.zeros(self.basis.N)
        psi[I] = _lu(A.tangent(nu0)).solve(rhs[I])
        return psi

    def solve(self, x: float, keep: bool = False, energy: bool = True) -> Solution:
        """Linear materials: the inductances (magnets off) and the PM flux linkages at rod position x.

        Parameters
        ----------
        x : float
            Rod position, m.
        keep : bool, optional
            Keep the fields in the solution (for :func:`energy_of`).
        energy : bool, optional
            Compute the field energy of each phase at 1 A (the check of fea.json).

        Returns
        -------
        Solution
            The position's solution.
        """
        g = self.g
        pat = self.rod_pattern(x)
        nu = self.nu_fixed.copy()
        nu_mag, nu_fe = 1.0 / (MU0 * g.mu_magnet), 1.0 / (MU0 * g.mu_rod_iron)
        nu[self.in_rod] = np.where(pat[self.in_rod] != 0, nu_mag, nu_fe)
        rhs = self.F
        if g.remanence > 0:
            rhs = np.column_stack([self.F, asm(_magnet, self.basis, nubr=nu_mag * g.remanence * pat)])
        I = self.I
        lu = _lu(self.asm.tangent(nu))
        sol = np.zeros(rhs.shape)
        sol[I] = lu.solve(np.ascontiguousarray(rhs[I]))
        L = 2 * math.pi * self.F.T @ sol[:, :3]
        L = 0.5 * (L + L.T)
        psi_pm = 2 * math.pi * self.F.T @ sol[:, 3] if rhs.shape[1] > 3 else np.zeros(3)
        half = 0.5 * np.diag(L)
        energy = (np.array([asm(_energy, self.basis, nu=nu, psi=self.basis.interpolate(sol[:, k]))
                            for k in range(3)]) if energy else half)
        fields = {"psi": sol, "nu": nu} if keep else None
        return Solution(x, L, psi_pm, energy, half, fields=fields)


def energy_of(solver: Solver, sol: Solution, currents) -> tuple[float, float]:
    """The field energy and ``i^T L i / 2`` for phase currents, magnets off.

    Parameters
    ----------
    solver : Solver
        The solver.
    sol : Solution
        A solution solved with ``keep=True``.
    currents : sequence of float
        Phase currents, A.

    Returns
    -------
    field : float
        J.
    circuit : float
        J.
    """
    i = np.asarray(currents, float)
    psi = sol.fields["psi"][:, :3] @ i
    w = asm(_energy, solver.basis, nu=sol.fields["nu"], psi=solver.basis.interpolate(psi))
    return float(w), float(0.5 * i @ sol.L @ i)


def _theta_origin(raw: np.ndarray, pm: np.ndarray) -> tuple[float, float, int]:
    """(amplitude of phase A's PM flux fundamental, offset, direction) from samples at ``raw`` (rad)."""
    A = np.column_stack([np.ones_like(raw), np.cos(raw), np.sin(raw)])
    coef = np.linalg.lstsq(A, pm, rcond=None)[0]  # (3, 3 phases)
    c = coef[1] - 1j * coef[2]  # psi = Re(c e^{j raw})
    amp = float(abs(c[0]))
    if amp == 0:
        return 0.0, 0.0, 1
    direction = 1 if np.angle(c[1] / c[0]) < 0 else -1  # psi_B lags psi_A by 120 deg
    return amp, float(-direction * np.angle(c[0])), direction


def q_currents(theta: float, i_q: float) -> np.ndarray:
    """Phase currents of q-axis current ``i_q`` (amplitude-invariant, i_d = 0) at electrical ``theta``.

    Parameters
    ----------
    theta : float
        Electrical position, rad.
    i_q : float
        A.

    Returns
    -------
    ndarray, shape (3,)
        A.
    """
    return -i_q * np.sin(theta - np.array([0.0, 2 * np.pi / 3, -2 * np.pi / 3]))


def dq_currents(theta: float, i_d: float, i_q: float) -> np.ndarray:
    """Phase currents of ``(i_d, i_q)`` (amplitude-invariant) at electrical ``theta``.

    theta = 0 where phase A's PM flux linkage peaks, so the d-axis is along the magnets' flux and
    ``i_d > 0`` strengthens it. With ``i_d = 0`` exactly :func:`q_currents`.

    Parameters
    ----------
    theta : float
        Electrical position, rad.
    i_d : float
        A.
    i_q : float
        A.

    Returns
    -------
    ndarray, shape (3,)
        A.
    """
    if i_d == 0:
        return q_currents(theta, i_q) if i_q else np.zeros(3)
    phase = theta - np.array([0.0, 2 * np.pi / 3, -2 * np.pi / 3])
    return i_d * np.cos(phase) - i_q * np.sin(phase)


#: (token, Solver) of the running :func:`run_loads`: forked workers inherit it, spawned ones build
#: their own once and keep it for the following positions
_SHARED: tuple | None = None


def _solve_position(args) -> tuple[Solution, np.ndarray]:
    """Worker of :func:`run_loads`: one Newton solve, and its converged state (the next load's start)."""
    global _SHARED
    token, g, level, positions, x, currents, psi0, keep = args
    if _SHARED is None or _SHARED[0] != token:
        _SHARED = (token, Solver(g, level, positions))
    s = _SHARED[1]
    sol = s.solve_nonlinear(x, currents, keep=keep, psi0=psi0)
    return sol, s.last_state


def run(g: Geometry, positions: int = 56, level: str = "default", progress=None,
        keep_first: bool = True, load_current: float = 0.0, workers: int = 1,
        d_current: float = 0.0) -> Result:
    """Solve ``positions`` rod positions over one electrical period; 3 excitations (+ magnets) each.

    With a B-H curve (``rod.bh`` / ``armature.bh``) each position is a Newton solve at the state set
    by the magnets, the q-axis ``load_current`` and the d-axis ``d_current`` (:func:`dq_currents`).
    :func:`run_loads` for several loads.

    Parameters
    ----------
    g : Geometry
        The geometry.
    positions : int, optional
        Rod positions.
    level : {"coarse", "default", "fine"}, optional
        Mesh level.
    progress : callable or None, optional
        ``progress(k, n)`` after each position.
    keep_first : bool, optional
        Keep the first position's fields.
    load_current : float, optional
        q-axis current, A.
    workers : int, optional
        Processes.
    d_current : float, optional
        d-axis current, A.

    Returns
    -------
    Result
        The FEA.

    Raises
    ------
    ValueError
        A load current with linear iron.
    """
    prog = None if progress is None else (lambda stage, k, n: progress(k, n) if stage != "origin" else None)
    return run_loads(g, [(d_current, load_current)], positions, level, progress=prog, keep_first=keep_first,
                     workers=workers)[0]


def _operating_point(c) -> tuple[float, float]:
    """(i_d, i_q) in A of a load: a q-axis current, or an ``(i_d, i_q)`` pair."""
    if isinstance(c, (tuple, list, np.ndarray)):
        return float(c[0]), float(c[1])
    return 0.0, float(c)


def run_loads(g: Geometry, currents, positions: int = 56, level: str = "default", progress=None,
              keep_first: bool = True, workers: int = 1, force_newton: bool = False) -> list[Result]:
    """:func:`run` for each load of ``currents`` (A: a q-axis current, or an ``(i_d, i_q)`` pair), on one
    mesh and one theta grid.

    With a B-H curve each position is a Newton solve at the state set by the magnets and the load
    (its angle needs theta's origin first: one linear pass over the positions serves every load),
    and the inductances are the incremental ones there. A load's Newton solve at a position starts
    from the previous load's converged state at that position (3 iterations instead of about 11 from
    the linear start; the same solution to the Newton tolerance). The solves are spread over
    ``workers`` processes (forked where possible). ``progress(stage, k, n)``: stage ``"origin"``
    for the linear pass, else the index of the load. ``force_newton``: Newton solves at the loads' states
    with linear iron too (the incremental inductances then equal the linear ones: a check).

    Parameters
    ----------
    g : Geometry
        The geometry.
    currents : iterable of float or (float, float)
        Loads: a q-axis current or an ``(i_d, i_q)`` pair, A.
    positions : int, optional
        Rod positions.
    level : {"coarse", "default", "fine"}, optional
        Mesh level.
    progress : callable or None, optional
        ``progress(stage, k, n)``.
    keep_first : bool, optional
        Keep the first position's fields.
    workers : int, optional
        Processes.
    force_newton : bool, optional
        Newton solves with linear iron too.

    Returns
    -------
    list of Result
        One per load, in order.

    Raises
    ------
    ValueError
        A load current with linear iron (without ``force_newton``).
    """
    global _SHARED
    points = [_operating_point(c) for c in currents]
    t0 = time.perf_counter()
    s = Solver(g, level, positions)
    t_setup = time.perf_counter() - t0
    xs = g.pole_pitch * np.arange(positions) / positions
    raw = 2 * np.pi * xs / g.pole_pitch
    if any(d or q for d, q in points) and not (s.nonlinear or force_newton):
        raise ValueError("a load current needs a B-H curve: with linear iron the incremental inductances "
                         "do not depend on it")
    if not (s.nonlinear or force_newton):
        return [_run_linear(g, s, xs, raw, keep_first, progress, t_setup)]
    t1 = time.perf_counter()
    origin = _origin_pass(g, s, xs, raw, progress) if g.remanence > 0 else (0.0, 0.0, 1)
    t_origin = time.perf_counter() - t1
    amp, offset, direction = origin
    theta = np.mod(direction * raw - offset, 2 * np.pi)
    token = (id(s), time.time_ns())
    _SHARED = (token, s)
    pool = _process_pool(workers) if workers > 1 and positions > 2 else None
    results, starts = [], [None] * positions
    try:
        for n_load, (i_d, cur) in enumerate(points):
            t2 = time.perf_counter()
            items = [(token, g, level, positions, float(x),
                      dq_currents(direction * raw[k] - offset, i_d, cur), starts[k], keep_first and k == 0)
                     for k, x in enumerate(xs)]
            sols, starts = _solve_positions(items, pool, progress, n_load)
            times = {"setup_s": t_setup, "origin_s": t_origin, "solve_s": time.perf_counter() - t2}
            results.append(_newton_result(g, s, xs, theta, origin, sols, times, i_d, cur))
    finally:
        if pool is not None:
            pool.shutdown(cancel_futures=True)
        _SHARED = None
    return results


def _newton_result(g: Geometry, s: Solver, xs: np.ndarray, theta: np.ndarray, origin: tuple, sols: list,
                   times: dict, i_d: float, i_q: float) -> Result:
    """One load's :class:`Result` from its Newton solutions (``times``: setup, origin and solve, s;
    the time per position added)."""
    amp, offset, direction = origin
    its = [q.newton for q in sols]
    times = {**times, "per_position_s": times["solve_s"] / xs.size}
    newton = {"max": int(max(its)), "mean": float(np.mean(its))}
    return Result(g, s.m, xs, theta, np.array([q.L for q in sols]), np.array([q.psi_pm for q in sols]),
                  amp, offset, direction, times, energy_error=None, newton=newton, load_current=i_q,
                  keep={"solver": s, "first": sols[0]}, d_current=i_d)


def _run_linear(g: Geometry, s: Solver, xs: np.ndarray, raw: np.ndarray, keep_first: bool, progress,
                t_setup: float) -> Result:
    """Linear iron: one solve per position (``xs``, m; ``raw``, their angles), theta's origin from
    the PM flux; the energy check of the inductances."""
    positions = xs.size
    t1 = time.perf_counter()
    sols = []
    for k, x in enumerate(xs):
        sols.append(s.solve(float(x), keep=keep_first and k == 0))
        if progress is not None:
            progress(0, k + 1, positions)
    amp, offset, direction = 0.0, 0.0, 1
    pm = np.array([q.psi_pm for q in sols])
    if g.remanence > 0 and positions >= 3:
        amp, offset, direction = _theta_origin(raw, pm)
    err = max(float(abs(q.energy - q.energy_li).max() / q.energy_li.max()) for q in sols)
    t_solve = time.perf_counter() - t1
    times = {"setup_s": t_setup, "solve_s": t_solve, "per_position_s": t_solve / positions}
    theta = np.mod(direction * raw - offset, 2 * np.pi)
    return Result(g, s.m, xs, theta, np.array([q.L for q in sols]), pm, amp, offset, direction, times,
                  energy_error=err, newton=None, load_current=0.0, keep={"solver": s, "first": sols[0]})


def _origin_pass(g: Geometry, s: Solver, xs: np.ndarray, raw: np.ndarray, progress) -> tuple:
    """theta's origin from a linear pass (mu_r 1000) at every position: by the rod's mirror symmetry
    the phase of the PM flux fundamental does not depend on the iron, and every load of a geometry
    then shares one theta grid (:func:`_theta_origin`'s ``(amp, offset, direction)``)."""
    pm0 = []
    for k, x in enumerate(xs):
        pm0.append(s.solve(float(x), energy=False).psi_pm)
        if progress is not None:
            progress("origin", k + 1, xs.size)
    return _theta_origin(raw, np.array(pm0))


def _process_pool(workers: int):
    """A pool of ``workers`` processes, forked where possible."""
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    methods = multiprocessing.get_all_start_methods()
    ctx = multiprocessing.get_context("fork" if "fork" in methods else "spawn")
    return ProcessPoolExecutor(max_workers=workers, mp_context=ctx)


def _solve_positions(items: list, pool, progress, n_load: int) -> tuple[list, list]:
    """One load's Newton solves (:func:`_solve_position` of each item, in ``pool`` if any):
    ``(solutions, converged states)`` in the order of the positions."""
    positions = len(items)
    out: dict[int, tuple] = {}
    if pool is not None:
        from concurrent.futures import as_completed

        futs = {pool.submit(_solve_position, it): k for k, it in enumerate(items)}
        for f in as_completed(futs):
            out[futs[f]] = f.result()
            if progress is not None:
                progress(n_load, len(out), positions)
    else:
        for k, it in enumerate(items):
            out[k] = _solve_position(it)
            if progress is not None:
                progress(n_load, k + 1, positions)
    return [out[k][0] for k in range(positions)], [out[k][1] for k in range(positions)]
