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
from skfem import Basis, BilinearForm, ElementTriP2, Functional, LinearForm, MeshTri, asm
from skfem.helpers import dot, grad

from linsense.fea.geometry import Geometry

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
    ``nu(B) = H / B`` and ``dnu/ds`` with ``s = B^2`` at the quadrature points."""

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
    mesh: MeshTri
    level: str
    size: float  # m, element size near the motor
    r_nodes: np.ndarray
    z_nodes: np.ndarray
    rod_aligned: bool = True  # the rod's interfaces are element edges at every position


def rod_step(g: Geometry, positions: int, target: float) -> tuple[float, bool]:
    """The z step of the fine zone: ``h = (pole_pitch / positions) / k``, the largest such step not
    above ``target`` that also divides the magnet and spacer ends (then every rod interface is an
    element edge at every position: the rod's materials are exact). ``(h, aligned)``."""
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
    """What one position's solves give."""

    x: float  # m, rod position
    L: np.ndarray  # 3x3, H
    psi_pm: np.ndarray  # (3,), Wb, PM flux linkage per phase
    energy: np.ndarray  # (3,), J, field energy of each phase at 1 A
    energy_li: np.ndarray  # (3,), J, 1/2 L_pp for the same
    newton: int = 0  # Newton iterations (0: linear materials)
    fields: dict | None = None  # psi per excitation (kept on request)


@dataclass
class Result:
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


class Solver:
    """The mesh, the fixed armature, the coil load vectors: solves one rod position at a time."""

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

    @property
    def ndofs(self) -> int:
        return self.basis.N

    def rod_pattern(self, x: float) -> np.ndarray:
        """+1 / -1 in the magnets (axial magnetisation sign), 0 in the spacers, at the quadrature points."""
        P, half = self.g.pole_pitch, self.g.magnet_length / 2
        u = np.mod(self.z - x + P / 2, P) - P / 2  # in [-P/2, P/2): 0 at a + magnet's centre
        s = np.zeros(self.z.shape)
        s[np.abs(u) < half] = 1.0
        s[np.abs(np.abs(u) - P / 2) < half] = -1.0
        return np.where(self.in_rod, s, 0.0)

    @property
    def nonlinear(self) -> bool:
        return self.curve_rod is not None or self.curve_arm is not None

    def solve_nonlinear(self, x: float, currents=(0.0, 0.0, 0.0), keep: bool = False, tol: float = 1e-7,
                        max_iter: int = 40, psi0: np.ndarray | None = None) -> Solution:
        """Newton iterations for the state set by the magnets and the phase ``currents`` (A), then the
        incremental inductances ``2 pi F^T J^-1 F`` with J the Jacobian (the tangent reluctivity) there."""
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
        I = self.I

        def state(psi):
            field = self.basis.interpolate(psi)
            gr = field.grad
            B = np.sqrt(gr[0] ** 2 + gr[1] ** 2) / self.r
            nu, dnu = nu_lin.copy(), np.zeros(nu_lin.shape)
            for mask, curve in masks:
                nu[mask], dnu[mask] = curve(B[mask])
            res = asm(_internal, self.basis, nu=nu, psi=field) - rhs
            return field, nu, dnu, res[I], B

        if psi0 is None:  # start from the linear solution with mu_r 1000 in the saturable iron
            nu0 = nu_lin.copy()
            for mask, _ in masks:
                nu0[mask] = 1.0 / (MU0 * 1000.0)
            K = asm(_stiffness, self.basis, nu=nu0)
            psi = np.zeros(self.basis.N)
            psi[I] = splu(K[I][:, I].tocsc()).solve(rhs[I])
        else:
            psi = np.array(psi0, float)
        field, nu, dnu, res, B = state(psi)
        it = 0
        while True:
            if it == max_iter:
                raise RuntimeError(f"Newton did not converge in {max_iter} iterations at x = {x!r} m")
            J = asm(_tangent, self.basis, nu=nu, dnu=dnu, psi=field)
            du = -splu(J[I][:, I].tocsc()).solve(res)
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
        J = asm(_tangent, self.basis, nu=nu, dnu=dnu, psi=field)
        lu = splu(J[I][:, I].tocsc())
        inc = np.zeros((self.basis.N, 3))
        inc[I] = lu.solve(np.ascontiguousarray(self.F[I]))
        L = 2 * math.pi * self.F.T @ inc
        L = 0.5 * (L + L.T)
        link = 2 * math.pi * self.F.T @ psi
        fields = {"psi": np.column_stack([inc, psi]), "nu": nu, "B_max": float(B.max())} if keep else None
        self.last_state = psi
        half = 0.5 * np.diag(L)
        return Solution(x, L, link, half, half, fields=fields, newton=it)

    def solve(self, x: float, keep: bool = False) -> Solution:
        g = self.g
        pat = self.rod_pattern(x)
        nu = self.nu_fixed.copy()
        nu_mag, nu_fe = 1.0 / (MU0 * g.mu_magnet), 1.0 / (MU0 * g.mu_rod_iron)
        nu[self.in_rod] = np.where(pat[self.in_rod] != 0, nu_mag, nu_fe)
        K = asm(_stiffness, self.basis, nu=nu)
        rhs = self.F
        if g.remanence > 0:
            rhs = np.column_stack([self.F, asm(_magnet, self.basis, nubr=nu_mag * g.remanence * pat)])
        I = self.I
        lu = splu(K[I][:, I].tocsc())
        sol = np.zeros(rhs.shape)
        sol[I] = lu.solve(np.ascontiguousarray(rhs[I]))
        L = 2 * math.pi * self.F.T @ sol[:, :3]
        L = 0.5 * (L + L.T)
        psi_pm = 2 * math.pi * self.F.T @ sol[:, 3] if rhs.shape[1] > 3 else np.zeros(3)
        energy = np.array([asm(_energy, self.basis, nu=nu, psi=self.basis.interpolate(sol[:, k]))
                           for k in range(3)])
        fields = {"psi": sol, "nu": nu} if keep else None
        return Solution(x, L, psi_pm, energy, 0.5 * np.diag(L), fields=fields)


def energy_of(solver: Solver, sol: Solution, currents) -> tuple[float, float]:
    """(field energy, 1/2 i^T L i) for phase currents ``currents`` (A), magnets off; needs keep=True."""
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
    """Phase currents of q-axis current ``i_q`` (amplitude-invariant, i_d = 0) at electrical ``theta``."""
    return -i_q * np.sin(theta - np.array([0.0, 2 * np.pi / 3, -2 * np.pi / 3]))


def _solve_nonlinear_chunk(args) -> list[Solution]:
    """Worker of :func:`run`: a solver of its own for some positions ``[(x, currents), ...]``."""
    g, level, positions, items = args
    s = Solver(g, level, positions)
    return [s.solve_nonlinear(x, cur) for x, cur in items]


def run(g: Geometry, positions: int = 56, level: str = "default", progress=None,
        keep_first: bool = True, load_current: float = 0.0, workers: int = 1) -> Result:
    """Solve ``positions`` rod positions over one electrical period; 3 excitations (+ magnets) each.

    With a B-H curve (``rod.bh`` / ``armature.bh``) each position is a Newton solve at the state set
    by the magnets and the q-axis ``load_current`` (A; its angle needs theta's origin first: a
    linear pass over the positions), and the inductances are the incremental ones there. Those
    Newton solves are spread over ``workers`` processes (forked where possible, each with its own
    mesh).
    """
    t0 = time.perf_counter()
    s = Solver(g, level, positions)
    t_setup = time.perf_counter() - t0
    xs = g.pole_pitch * np.arange(positions) / positions
    raw = 2 * np.pi * xs / g.pole_pitch
    origin = None
    if load_current and not s.nonlinear:
        raise ValueError("a load current needs a B-H curve: with linear iron the incremental inductances "
                         "do not depend on it")
    t1 = time.perf_counter()
    if s.nonlinear and g.remanence > 0:
        # theta's origin from a linear pass (mu_r 1000) at every position: by the rod's mirror symmetry
        # the phase of the PM flux fundamental does not depend on the iron, and every load of a
        # geometry then shares one theta grid
        pm0 = np.array([s.solve(float(x)).psi_pm for x in xs])
        origin = _theta_origin(raw, pm0)
    sols = []
    if s.nonlinear:
        _, off_, dir_ = origin if origin is not None else (0.0, 0.0, 1)
        items = [(float(x), q_currents(dir_ * raw[k] - off_, load_current) if load_current else np.zeros(3))
                 for k, x in enumerate(xs)]
        sols = [s.solve_nonlinear(*items[0], keep=keep_first)]
        if progress is not None:
            progress(1, positions)
        if workers > 1 and positions > 2:
            import multiprocessing
            from concurrent.futures import ProcessPoolExecutor

            chunks = [list(range(1, positions))[w::workers] for w in range(workers)]
            out: dict[int, Solution] = {}
            methods = multiprocessing.get_all_start_methods()
            ctx = multiprocessing.get_context("fork" if "fork" in methods else "spawn")
            with ProcessPoolExecutor(max_workers=workers, mp_context=ctx) as ex:
                futs = {ex.submit(_solve_nonlinear_chunk, (g, level, positions, [items[k] for k in c])): c
                        for c in chunks}
                for f, c in futs.items():
                    out.update(zip(c, f.result(), strict=True))
                    if progress is not None:
                        progress(1 + len(out), positions)
            sols += [out[k] for k in range(1, positions)]
        else:
            for k in range(1, positions):
                sols.append(s.solve_nonlinear(*items[k]))
                if progress is not None:
                    progress(k + 1, positions)
    else:
        for k, x in enumerate(xs):
            sols.append(s.solve(float(x), keep=keep_first and k == 0))
            if progress is not None:
                progress(k + 1, positions)
    t_solve = time.perf_counter() - t1
    L = np.array([q.L for q in sols])
    pm = np.array([q.psi_pm for q in sols])
    amp, offset, direction = 0.0, 0.0, 1
    if origin is not None:
        amp, offset, direction = origin
    elif g.remanence > 0 and positions >= 3:
        amp, offset, direction = _theta_origin(raw, pm)
    theta = np.mod(direction * raw - offset, 2 * np.pi)
    err = None
    if not s.nonlinear:
        err = max(float(abs(q.energy - q.energy_li).max() / q.energy_li.max()) for q in sols)
    its = [q.newton for q in sols]
    times = {"setup_s": t_setup, "solve_s": t_solve, "per_position_s": t_solve / positions}
    newton = {"max": int(max(its)), "mean": float(np.mean(its))} if s.nonlinear else None
    return Result(g, s.m, xs, theta, L, pm, amp, offset, direction, times, energy_error=err,
                  newton=newton, load_current=float(load_current), keep={"solver": s, "first": sols[0]})
