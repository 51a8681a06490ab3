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
    energy_error: float = 0.0  # max |W_field - 1/2 i^T L i| / (1/2 i^T L i)
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
        return Solution(x, L, psi_pm, energy, 0.5 * np.diag(L), fields)


def energy_of(solver: Solver, sol: Solution, currents) -> tuple[float, float]:
    """(field energy, 1/2 i^T L i) for phase currents ``currents`` (A), magnets off; needs keep=True."""
    i = np.asarray(currents, float)
    psi = sol.fields["psi"][:, :3] @ i
    w = asm(_energy, solver.basis, nu=sol.fields["nu"], psi=solver.basis.interpolate(psi))
    return float(w), float(0.5 * i @ sol.L @ i)


def run(g: Geometry, positions: int = 56, level: str = "default", progress=None,
        keep_first: bool = True) -> Result:
    """Solve ``positions`` rod positions over one electrical period; 3 excitations (+ magnets) each."""
    t0 = time.perf_counter()
    s = Solver(g, level, positions)
    t_setup = time.perf_counter() - t0
    xs = g.pole_pitch * np.arange(positions) / positions
    sols = []
    t1 = time.perf_counter()
    for k, x in enumerate(xs):
        sols.append(s.solve(float(x), keep=keep_first and k == 0))
        if progress is not None:
            progress(k + 1, positions)
    t_solve = time.perf_counter() - t1
    L = np.array([q.L for q in sols])
    pm = np.array([q.psi_pm for q in sols])
    raw = 2 * np.pi * xs / g.pole_pitch
    amp, offset, direction = 0.0, 0.0, 1
    if g.remanence > 0 and positions >= 3:
        c = (pm * np.exp(-1j * raw)[:, None]).mean(axis=0) * 2  # fundamental phasors
        amp = float(abs(c[0]))
        if amp > 0:
            # psi_B lags psi_A by 120 deg for the positive direction
            direction = 1 if np.angle(c[1] / c[0]) < 0 else -1
            offset = float(-direction * np.angle(c[0]))
    theta = np.mod(direction * raw - offset, 2 * np.pi)
    err = max(abs(q.energy - q.energy_li).max() / q.energy_li.max() for q in sols)
    return Result(g, s.m, xs, theta, L, pm, amp, offset, direction,
                  {"setup_s": t_setup, "solve_s": t_solve, "per_position_s": t_solve / positions},
                  float(err), {"solver": s, "first": sols[0]})
