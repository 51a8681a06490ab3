"""Motors: parameters, loading from presets or TOML files, and the physical checks.

A motor file (TOML, SI units) has the sections ``[motor]`` and ``[inductance]`` (required) and
``[friction]``, ``[pm_flux]`` (optional); see :mod:`linsense.model.motor_schema` and docs/motor-files.md.
"""

from __future__ import annotations

import functools
import math
import os
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path

import numpy as np

from linsense import examples
from linsense._check import brief, closest_key, instance, real, reals
from linsense.errors import InputError, ModelError
from linsense.io import csv_rows, folder_of, parse_toml, read_csv_table, read_text_file
from linsense.model.frames import PHASE_ANGLE
from linsense.model.inductance import DERIVED_COLUMNS, ENTRIES, InductanceModel, derived_columns
from linsense.model.motor_schema import (
    PHASES,
    FrictionSection,
    MotorSection,
    PmFluxSection,
    PmHarmonicEntry,
    validate_motor_file,
    validate_section,
)
from linsense.model.saturation import Saturation
from linsense.plausible import KINDS, implausible, slip

#: Saliency |L_q - L_d| below this fraction of (L_d + L_q)/2 counts as vanished.
MIN_SALIENCY_RATIO = 0.01
#: the source a motor built in Python (without one) is named by in messages
_API = "linsense.Motor"
#: Columns a tabulated inductance file must have (others, e.g. those of ``linsense model``, are allowed).
TABLE_COLUMNS = ("theta_deg",) + ENTRIES


@dataclass(frozen=True)
class Friction:
    """Friction of the moving part.

    Parameters
    ----------
    viscous : float
        Viscous coefficient, N s/m.
    coulomb : float
        Coulomb force, N.
    """

    viscous: float = 0.0  # N s/m
    coulomb: float = 0.0  # N

    def __post_init__(self) -> None:
        # the motor file's [friction] rules (finite, >= 0): one validated path
        validate_section(FrictionSection, {"viscous": self.viscous, "coulomb": self.coulomb},
                         "linsense.model.motor.Friction", "friction")


@dataclass(frozen=True)
class PmHarmonic:
    """One harmonic of the PM flux linkage, relative to the fundamental.

    Parameters
    ----------
    order : int
        Harmonic order in theta.
    amplitude : float
        Amplitude relative to ``psi_pm``, dimensionless.
    phase : float
        Phase, electrical rad.
    """

    order: int  # harmonic order in theta
    amplitude: float  # relative to psi_pm
    phase: float  # rad (electrical)

    def __post_init__(self) -> None:
        # the motor file's [pm_flux] harmonics' rules (an order 2 .. MAX_HARMONIC_ORDER, finite numbers)
        src = "linsense.model.motor.PmHarmonic"
        phase = real(self.phase, src, "pm_flux.harmonics.phase", what="a finite phase in rad")
        validate_section(PmHarmonicEntry, {"order": self.order, "amplitude": self.amplitude,
                                           "phase_deg": math.degrees(phase)}, src, "pm_flux.harmonics")


@dataclass(frozen=True)
class PmPhases:
    """The end effect on the magnets' flux: each phase's PM flux-linkage amplitude and phase.

    The end phases of a linear motor link less magnet flux than the middle one (an unbalanced
    back-EMF). Phase ``k`` (A, B, C) links ``scale[k] psi_pm f(theta - 2 pi k/3 + shift[k])``,
    ``f(u) = cos u + sum_n a_n cos(n u + phi_n)`` (the harmonics of :class:`PmHarmonic`): its whole
    waveform scaled and advanced, so that ``scale[k]`` and ``shift[k]`` are the amplitude and phase
    of its fundamental (docs/theory.md, "The end effect on the magnets' flux"; docs/motor-files.md).

    Parameters
    ----------
    scale : tuple of float
        Amplitude relative to ``psi_pm``, phases A, B, C, dimensionless (balanced: 1, 1, 1).
    shift : tuple of float
        Phase advance, phases A, B, C, electrical rad (balanced: 0, 0, 0).
    """

    scale: tuple[float, float, float] = (1.0, 1.0, 1.0)  # -, relative to psi_pm
    shift: tuple[float, float, float] = (0.0, 0.0, 0.0)  # rad (electrical)

    def __post_init__(self) -> None:
        # the motor file's [pm_flux] scale_abc / shift_deg_abc rules (three finite numbers each):
        # one validated path; the plausible ranges are check_plausible's (the motor's source named)
        src = "linsense.model.motor.PmPhases"
        for name, v in (("scale", self.scale), ("shift", self.shift)):
            instance(v, src, name, tuple, "a tuple of three numbers (phases A, B, C)")
        scale = reals(self.scale, src, "scale", "amplitudes relative to psi_pm", ndim=1)
        shift = reals(self.shift, src, "shift", "phase advances in rad", ndim=1)
        validate_section(PmFluxSection, {"scale_abc": scale.tolist(),
                                         "shift_deg_abc": np.degrees(shift).tolist()}, src, "pm_flux")

    @property
    def balanced(self) -> bool:
        """Whether every phase links the nominal flux at the nominal phase (exactly)."""
        return all(float(g) == 1.0 for g in self.scale) and all(float(d) == 0.0 for d in self.shift)


@dataclass(frozen=True)
class Motor:
    """A linear PM motor as linsense sees it (SI units, electrical radians).

    Parameters
    ----------
    name : str
        Motor name (used in provenance comments and file names).
    R_s : float
        Phase resistance, ohm.
    pole_pitch : float
        One electrical period ``tau``, m: ``theta = 2 pi x / tau``.
    force_constant : float
        Thrust per peak phase current, N/A.
    mass : float
        Moving mass, kg.
    inductance : InductanceModel
        HF inductance model ``L_abc(theta)``.
    friction : Friction
        Friction of the moving part (none by default).
    pm_harmonics : tuple of PmHarmonic
        Harmonics of the PM flux linkage (none by default).
    source : str
        Where the motor came from (file path or ``preset <name>``), named in messages.
    saturation : Saturation or None
        Saturation data for the simulator's saturated plant (None: none given).
    pm_phases : PmPhases
        The end effect on the magnets' flux, per phase (balanced by default).
    """

    name: str
    R_s: float
    pole_pitch: float
    force_constant: float
    mass: float
    inductance: InductanceModel
    friction: Friction = field(default_factory=Friction)
    pm_harmonics: tuple[PmHarmonic, ...] = ()
    source: str = ""
    saturation: Saturation | None = None  # for the simulator's saturated plant (None: none given)
    pm_phases: PmPhases = field(default_factory=PmPhases)  # the end effect on the magnets' flux

    def __post_init__(self) -> None:
        # one validated path: a Motor built in Python is held to the motor file's checks
        # and limits (its [motor] section's schema, then check_plausible), as load_motor's are; one
        # built with R_s = 1e6 and pole_pitch = -1 gave an all-zero table
        instance(self.source, _API, "source", str, "a str (where the motor came from)")
        source = self.source or _API
        fields = ("name", "R_s", "pole_pitch", "force_constant", "mass")
        validate_section(MotorSection, {k: getattr(self, k) for k in fields}, source, "motor")
        instance(self.inductance, source, "inductance", InductanceModel,
                 "an InductanceModel (linsense.model.inductance: from_params or from_table)")
        instance(self.friction, source, "friction", Friction, "a Friction")
        instance(self.pm_harmonics, source, "pm_harmonics", tuple, "a tuple of PmHarmonic")
        for k, h in enumerate(self.pm_harmonics):
            instance(h, source, f"pm_harmonics[{k}]", PmHarmonic, "a PmHarmonic")
        if len({h.order for h in self.pm_harmonics}) != len(self.pm_harmonics):
            raise InputError(source, "pm_flux.harmonics", "an order is listed twice: give each order once")
        if self.saturation is not None:
            instance(self.saturation, source, "saturation", Saturation, "a Saturation or None")
        instance(self.pm_phases, source, "pm_phases", PmPhases, "a PmPhases")
        check_plausible(self)

    @property
    def psi_pm(self) -> float:
        """PM flux-linkage amplitude, Wb: ``F = (3/2) (2 pi / tau) psi_pm i_q`` (amplitude-invariant)."""
        return self.force_constant * self.pole_pitch / (3.0 * math.pi)

    def psi_pm_abc(self, theta: np.ndarray | float, derivative: int = 0) -> np.ndarray:
        """PM flux linkage of the phases A, B, C (Wb) or its theta derivative (Wb/rad).

        Phase ``k``: ``scale_k psi_pm [cos u_k + sum_n a_n cos(n u_k + phi_n)]``,
        ``u_k = theta - 2 pi k/3 + shift_k`` (:class:`PmPhases`; B lags A, docs/theory.md,
        "The end effect on the magnets' flux"). The derivative times the electrical speed is the
        open-circuit back-EMF of each phase.

        Parameters
        ----------
        theta : float or ndarray
            Electrical angle(s), rad.
        derivative : int, optional
            0: the flux linkage; 1: its derivative in theta.

        Returns
        -------
        ndarray, shape (..., 3)
            Wb (or Wb/rad), phases A, B, C on the last axis.

        Raises
        ------
        InputError
            ``theta`` not finite real numbers, or ``derivative`` not 0 or 1.
        """
        src = "linsense.Motor.psi_pm_abc"
        th = reals(theta, src, "theta", "angles in rad")
        if isinstance(derivative, bool) or derivative not in (0, 1):
            raise InputError(src, "derivative", f"expected 0 or 1, got {brief(derivative)}")
        p = self.pm_phases
        u = th[..., None] + PHASE_ANGLE + np.asarray(p.shift, dtype=float)
        if derivative == 0:
            out = np.cos(u)
            for h in self.pm_harmonics:
                out = out + h.amplitude * np.cos(h.order * u + h.phase)
        else:
            out = -np.sin(u)
            for h in self.pm_harmonics:
                out = out - h.order * h.amplitude * np.sin(h.order * u + h.phase)
        return self.psi_pm * np.asarray(p.scale, dtype=float) * out

    def force_abc(self, theta: np.ndarray | float, i_abc: np.ndarray) -> np.ndarray:
        """The motor force of phase currents: the co-energy's derivative in the position.

        ``F = (2 pi / tau) [i' d psi_pm_abc/d theta + 1/2 i' dL_abc/d theta i]`` (docs/theory.md,
        "The end effect on the magnets' flux"): with the per-phase PM flux of :meth:`psi_pm_abc`
        and the linear inductance model (no saturation).

        Parameters
        ----------
        theta : float or ndarray
            Electrical angle(s), rad, shape ``(...)``.
        i_abc : ndarray
            Phase currents, A, shape ``(..., 3)``.

        Returns
        -------
        ndarray
            N, shape ``(...)``.

        Raises
        ------
        InputError
            ``theta`` or ``i_abc`` not finite real numbers, or ``i_abc`` without 3 phases last.
        """
        src = "linsense.Motor.force_abc"
        th = reals(theta, src, "theta", "angles in rad")
        i = reals(i_abc, src, "i_abc", "phase currents in A")
        if i.ndim < 1 or i.shape[-1] != 3:
            raise InputError(src, "i_abc", f"expected the 3 phase currents on the last axis, shape {i.shape}")
        dL = self.inductance.L_abc(th, 1)
        pm = np.sum(i * self.psi_pm_abc(th, 1), axis=-1)
        rel = 0.5 * np.einsum("...j,...jk,...k->...", i, dL, i)
        return 2.0 * np.pi / self.pole_pitch * (pm + rel)

    def theta_of_x(self, x: np.ndarray | float) -> np.ndarray:
        """Electrical angle (rad) of a position (m).

        Parameters
        ----------
        x : float or ndarray
            Position(s), m.

        Returns
        -------
        ndarray
            ``2 pi x / pole_pitch``, rad.

        Raises
        ------
        InputError
            ``x`` not finite real numbers.
        """
        return 2.0 * np.pi * reals(x, "linsense.Motor.theta_of_x", "x", "positions in m") / self.pole_pitch

    def x_of_theta(self, theta: np.ndarray | float) -> np.ndarray:
        """Position (m) of an electrical angle (rad).

        Parameters
        ----------
        theta : float or ndarray
            Electrical angle(s), rad.

        Returns
        -------
        ndarray
            ``theta pole_pitch / (2 pi)``, m.

        Raises
        ------
        InputError
            ``theta`` not finite real numbers.
        """
        theta = reals(theta, "linsense.Motor.x_of_theta", "theta", "angles in rad")
        return theta * self.pole_pitch / (2.0 * np.pi)

    def provenance(self) -> dict:
        """Parameters that identify this motor, for provenance comments and JSON exports.

        Returns
        -------
        dict
            ``name``, ``R_s``, ``pole_pitch``, ``force_constant``, ``mass`` and the eq. (3) parameters
            (or ``inductance``: the table's description).
        """
        p = {
            "name": self.name,
            "R_s": self.R_s,
            "pole_pitch": self.pole_pitch,
            "force_constant": self.force_constant,
            "mass": self.mass,
        }
        if self.inductance.params:
            p.update(self.inductance.params)
        else:
            p["inductance"] = self.inductance.description
        return p


# ---------------------------------------------------------------------- loading
def preset_names() -> list[str]:
    """Names of the built-in presets.

    Returns
    -------
    list of str
        The preset names (``ecce2010``...).
    """
    return list(_preset_names())


@functools.cache
def _preset_names() -> tuple[str, ...]:  # (the package's files do not change while it runs)
    folder = resources.files("linsense.model") / "presets"
    return tuple(sorted(p.name[:-5] for p in folder.iterdir() if p.name.endswith(".toml")))


def preset_text(name: str) -> str:
    """The TOML text of a built-in preset.

    Parameters
    ----------
    name : str
        One of :func:`preset_names`.

    Returns
    -------
    str
        The preset's motor file.
    """
    return (resources.files("linsense.model") / "presets" / f"{name}.toml").read_text(encoding="utf-8")


def example_motor(spec: str, source: str = "--motor") -> Path:
    """The packaged example motor named ``spec`` (:mod:`linsense.examples`).

    Parameters
    ----------
    spec : str
        The example's name.
    source : str, optional
        The option or key it was given at, named in the message.

    Returns
    -------
    Path
        Its motor file.

    Raises
    ------
    linsense.errors.InputError
        No such example, naming ``source`` and listing the presets and the example motors.
    """
    p = examples.path("motors", spec)
    if p is None:
        raise InputError(source, "", examples.unknown("motors", spec, tuple(preset_names())))
    return p


def motor_path(spec: str) -> str:
    """A motor ``spec`` as a scenario or sweep names it, with an example motor's name made a path.

    A packaged example motor's name is replaced by its file's absolute path; a preset or a path is
    unchanged.

    Parameters
    ----------
    spec : str
        The ``motor`` value.

    Returns
    -------
    str
        The motor as the simulator reads it.
    """
    if names_a_path(spec) or spec in preset_names():
        return spec
    p = examples.path("motors", spec)
    return spec if p is None else str(p)


def names_a_path(spec: str) -> bool:
    """Whether a scenario's (or a sweep's) motor spec names a file rather than a preset.

    A ``.toml`` name or a path with a separator, relative to the scenario (the file need not exist:
    the scenario's reader says so).

    Parameters
    ----------
    spec : str
        The ``motor`` value as written.

    Returns
    -------
    bool
        True for a file.
    """
    return spec.lower().endswith(".toml") or any(c in spec for c in "/\\")


def table_files(data: dict) -> list[tuple[str, str]]:
    """The tables a motor file's TOML data names.

    Its ``[inductance] table`` and its ``[saturation] tables``; data that is not a motor file's
    names none.

    Parameters
    ----------
    data : dict
        The parsed TOML of a motor file.

    Returns
    -------
    list of (str, str)
        ``(kind, path as written)``, kind ``"inductance table"`` or ``"saturation table"``.
    """
    ind = data.get("inductance")
    out = [("inductance table", ind.get("table"))] if isinstance(ind, dict) else []
    sat = data.get("saturation")
    if isinstance(sat, dict) and isinstance(sat.get("tables"), list):
        out += [("saturation table", t) for t in sat["tables"]]
    return [(kind, t) for kind, t in out if isinstance(t, str) and t]


def names_a_file(spec: str | Path) -> bool:
    """Whether :func:`load_motor` reads ``spec`` as a motor file rather than as a preset name.

    A ``.toml`` name, an existing path or a path with a separator.

    Parameters
    ----------
    spec : str or Path
        The motor as given.

    Returns
    -------
    bool
        True for a file.
    """
    s = str(spec)
    return Path(s).suffix.lower() == ".toml" or Path(s).exists() or any(c in s for c in "/\\")


def load_motor(spec: str | Path, check: bool = True) -> Motor:
    """Load a motor from a preset name or a TOML file path.

    Parameters
    ----------
    spec : str or Path
        A preset name (``"ecce2010"``) or a path to a motor file.
    check : bool
        Run :func:`check_motor` (positive definiteness, saliency) after loading.

    Returns
    -------
    Motor
        The motor, checked for plausible values (:func:`check_plausible`, by its constructor).

    Raises
    ------
    InputError
        Unknown preset, unreadable file, schema violations, implausible values.
    ModelError
        The model is not usable for HF sensorless control (see :func:`check_motor`).
    """
    instance(spec, "linsense.load_motor", "spec", str | os.PathLike,
             "a preset's or example's name or a motor file's path (a str or os.PathLike)")
    instance(check, "linsense.load_motor", "check", bool, "True or False")
    spec_s = str(spec)
    if not spec_s.strip():
        raise InputError("--motor", "", "empty: give a preset name (" + ", ".join(preset_names())
                         + ") or the path of a motor .toml file")
    path = Path(spec_s)
    if names_a_file(spec_s):
        if not path.exists():
            listing = examples.listing("motors", tuple(preset_names()))
            raise InputError(spec_s, "", f"no such motor file ({listing})")
        text = read_text_file(spec_s, "motor file")
        motor = motor_from_toml(text, source=spec_s, base_dir=folder_of(path))
    elif spec_s in preset_names():
        text = preset_text(spec_s)
        motor = motor_from_toml(text, source=f"preset {spec_s}", base_dir=None)
    else:  # a packaged example's name (linsense.examples), else unknown: the names listed
        p = example_motor(spec_s)  # (a name: tables relative to the packaged file)
        text = read_text_file(p, "motor file")
        motor = motor_from_toml(text, source=f"example {spec_s}", base_dir=p.parent)
    if check:
        check_motor(motor)
    return motor


def as_motor(value, source: str, name: str = "motor", inductance: bool = False) -> Motor | InductanceModel:
    """A motor argument of the public API, checked and resolved the same way everywhere.

    A :class:`Motor` as it is; a preset's or packaged example's name or a motor file's path loaded
    as :func:`load_motor` loads it; an :class:`InductanceModel` where ``inductance`` allows it.
    Anything else, or a name that is none of them, is refused naming the argument (``psi_lut(42,
    x)`` was an AttributeError, ``psi_lut("ecce2010", x)`` too).

    Parameters
    ----------
    value : object
        The argument.
    source : str
        The function it was given to, named in messages.
    name : str, optional
        The argument's name.
    inductance : bool, optional
        Whether an :class:`InductanceModel` is accepted too.

    Returns
    -------
    Motor or InductanceModel
        The motor (or the model).

    Raises
    ------
    InputError
        Naming ``source`` and ``name``: not a motor, or an unknown name (the closest named); a
        motor file's own errors name the file.
    ModelError
        A loaded motor unusable for HF sensorless control (:func:`check_motor`).
    """
    if isinstance(value, Motor) or (inductance and isinstance(value, InductanceModel)):
        return value
    what = "a Motor" + (" or an InductanceModel" if inductance else "")
    if isinstance(value, os.PathLike):
        value = os.fspath(value)
    if not isinstance(value, str) or not value.strip():
        raise InputError(source, name, f"expected {what}, a preset or example name "
                         f"({', '.join(preset_names())} ...) or a motor file's path, got {brief(value)} "
                         f"({type(value).__name__})")
    if names_a_file(value) or value in preset_names() or examples.path("motors", value) is not None:
        return load_motor(value)
    known = tuple(preset_names()) + tuple(examples.names("motors"))
    raise InputError(source, name, f"unknown motor {value!r}{closest_key(value, known)}: no preset, "
                     f"packaged example or motor file of that name ({', '.join(known)})")


def motor_from_toml(text: str, source: str, base_dir: Path | None = None) -> Motor:
    """Parse and validate the text of a motor file.

    Parameters
    ----------
    text : str
        The TOML text.
    source : str
        Its name in messages (the file path or ``preset <name>``).
    base_dir : Path or None, optional
        Folder that relative table paths are read from (None: as written).

    Returns
    -------
    Motor
        The motor, its values checked for plausibility by its constructor; not for HF sensorless
        control (:func:`load_motor` runs :func:`check_motor`).

    Raises
    ------
    InputError
        Bad TOML, schema violations, a missing or bad table file, implausible values.
    """
    doc = validate_motor_file(parse_toml(text, source), source)
    ind = doc.inductance
    if ind.table is not None:
        table_path = Path(ind.table)
        if not table_path.is_absolute() and base_dir is not None:
            table_path = base_dir / table_path
        if not table_path.is_file():
            raise InputError(source, "inductance.table", f"no such table file {str(table_path)!r}")
        theta, entries = read_inductance_table(table_path)
        inductance = InductanceModel.from_table(
            theta, entries, ind.table_max_order, description=f"table {ind.table}"
        )
    else:
        inductance = InductanceModel.from_params(
            ind.L0, ind.L2, ind.M0, ind.M2, ind.dM0, ind.harmonics()
        )
    m = doc.motor
    saturation = None if doc.saturation is None else _saturation(doc.saturation, source, base_dir)
    return Motor(
        name=m.name,
        R_s=m.R_s,
        pole_pitch=m.pole_pitch,
        force_constant=m.force_constant,
        mass=m.mass,
        inductance=inductance,
        friction=Friction(doc.friction.viscous, doc.friction.coulomb),
        pm_harmonics=tuple(
            PmHarmonic(h.order, h.amplitude, math.radians(h.phase_deg)) for h in doc.pm_flux.harmonics
        ),
        source=source,
        saturation=saturation,
        pm_phases=PmPhases(tuple(float(g) for g in doc.pm_flux.scale_abc),
                           tuple(math.radians(d) for d in doc.pm_flux.shift_deg_abc)),
    )


def _saturation(sec, source: str, base_dir: Path | None) -> Saturation:
    """The ``[saturation]`` section, its tables read (paths relative to the motor file)."""
    tables = []
    for j, name in enumerate(sec.tables or ()):
        path = Path(name)
        if not path.is_absolute() and base_dir is not None:
            path = base_dir / path
        if not path.is_file():
            raise InputError(source, f"saturation.tables[{j}]", f"no such table file {str(path)!r}")
        theta, entries = read_inductance_table(path)
        tables.append(InductanceModel.from_table(theta, entries, sec.table_max_order,
                                                 description=f"table {name}"))
    return Saturation(polarity=sec.polarity, magnet_current=sec.magnet_current, q_drop=sec.q_drop,
                      q_current=sec.q_current, currents=tuple(float(c) for c in sec.currents or ()),
                      tables=tuple(tables), source=source)


def read_inductance_table(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """Read a tabulated ``L_abc(theta)`` CSV (columns ``theta_deg, L_A .. M_CA``; H).

    Every problem names the row and column; the sizes are bounded while reading
    (:func:`linsense.io.read_csv_table`, docs/limits.md).

    Parameters
    ----------
    path : Path
        The CSV file.

    Returns
    -------
    theta : ndarray, shape (N,)
        Positions, rad, in file order.
    entries : ndarray, shape (N, 6)
        ``L_A, L_B, L_C, M_AB, M_BC, M_CA``, H.

    Raises
    ------
    InputError
        Fewer than 8 positions, a duplicate position (modulo 360 deg), a gap over 45 deg, or a bad
        cell.
    """
    src = str(path)
    data, line = read_csv_table(path, TABLE_COLUMNS, "inductance table")
    if data.shape[0] < 8:
        raise InputError(src, "", f"need at least 8 positions, got {data.shape[0]}")
    wrapped = np.mod(data[:, 0], 360.0)
    order = np.argsort(wrapped)
    ws = wrapped[order]
    dup = np.nonzero(np.diff(ws) < 1e-9)[0]
    if dup.size:
        r, q = int(order[dup[0] + 1]), int(order[dup[0]])
        # (plain numbers: the message showed np.float64(360.0))
        raise InputError(src, f"row {line[r]}, column theta_deg",
                         f"duplicate position {float(data[r, 0])!r} deg (row {line[q]} has "
                         f"{float(data[q, 0])!r} deg: the same position modulo 360 deg)")
    gaps = np.diff(np.concatenate([ws, [ws[0] + 360.0]]))
    if gaps.max() > 45.0:
        g = int(np.argmax(gaps))
        span = float(ws[-1] - ws[0])  # (radians typed: 0 .. 6.2)
        hint = slip("angle", span, ok=lambda v: 360.0 - 45.0 <= v <= 360.0)
        raise InputError(
            src, "column theta_deg",
            f"positions do not cover one electrical period: gap of {gaps[g]:.1f} deg after "
            f"{ws[g]:.1f} deg (at most 45 deg allowed)"
            + (f"; the positions span {span:.4g} deg: {hint}" if hint else ""),
        )
    theta = np.radians(data[:, 0])
    _check_derived(src, path, theta, data[:, 1:], line)
    return theta, data[:, 1:]


#: tolerance of a derived column against what the entries give, relative to the column's largest
#: magnitude (``linsense model`` writes 12 significant digits; a derivative of the series through
#: them is good to about 1e-10 of it)
DERIVED_RTOL = 1e-6


def _check_derived(src: str, path: Path, theta: np.ndarray, entries: np.ndarray, line: np.ndarray) -> None:
    """Refuse a table whose ``linsense model`` columns beside the entries (:data:`DERIVED_COLUMNS`)
    do not agree with the entries: they are not read (the model is ``L_A .. M_CA``), so an edit of
    ``L_dq`` or ``psi_lut_deg`` in a model table used as a motor's table changed nothing, without a
    word. The first row and column that disagree are named. ``gain_nolut`` is a derivative, which a
    table does not determine (``linsense model --points 8`` of a motor with ``L4`` writes the motor's,
    not the 8 points' series'): it is not compared."""
    rows = csv_rows(path, "inductance table")
    header = next(rows)[1]
    rows.close()
    present = tuple(c for c in DERIVED_COLUMNS if c in header and c != "gain_nolut")
    if not present:
        return
    given = read_csv_table(path, present, "inductance table")[0]
    want = derived_columns(theta, entries)
    for j, name in enumerate(present):
        w = want[name]
        scale = float(np.max(np.abs(w[np.isfinite(w)]), initial=0.0))
        bad = np.nonzero(~(np.abs(given[:, j] - w) <= DERIVED_RTOL * scale + 1e-300))[0]
        if bad.size:
            i = int(bad[0])
            raise InputError(src, f"row {line[i]}, column {name}",
                             f"{float(given[i, j])!r}, but the row's L_A .. M_CA give {float(w[i]):.12g}: "
                             f"the columns linsense model writes beside the entries ({', '.join(present)}) "
                             "are derived from them, not read: edit L_A .. M_CA (or delete the derived "
                             "columns)")


# ---------------------------------------------------------------------- checks
def check_grid(inductance: InductanceModel, n_min: int = 720) -> np.ndarray:
    """Dense position grid (rad) fine enough to resolve every harmonic of ``inductance``.

    Parameters
    ----------
    inductance : InductanceModel
        The model to sample.
    n_min : int, optional
        Fewest positions.

    Returns
    -------
    ndarray
        ``max(n_min, 16 (K + 1))`` equally spaced positions over one period, rad.
    """
    n = max(n_min, 16 * (inductance.max_order + 1))
    return np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)


def _intervals_deg(theta: np.ndarray, bad: np.ndarray) -> str:
    """Describe the positions where ``bad`` is true as wrapped degree intervals."""
    deg = np.degrees(theta)
    n = bad.size
    parts = []
    i = 0
    if bad.all():
        return "all positions"
    start = int(np.argmin(bad))  # start scanning at a good point so intervals do not wrap
    idx = [(start + k) % n for k in range(n)]
    while i < n:
        if bad[idx[i]]:
            j = i
            while j + 1 < n and bad[idx[j + 1]]:
                j += 1
            a, b = deg[idx[i]], deg[idx[j]]
            parts.append(f"{a:.1f}" if i == j else f"{a:.1f}..{b:.1f}")
            i = j + 1
        else:
            i += 1
    return ", ".join(parts[:6]) + (" ..." if len(parts) > 6 else "") + " deg"


#: Ranges that hold every real linear PM motor with margin, SI units: (low, high, unit, the
#: likely mistake above, below). A value outside names the probable slip of unit. The class
#: (pole pitch 20-100 mm, 24-300 V, L 0.1-100 mH, R_s 0.1-20 ohm; docs/limits.md): above 0.5 H the
#: HF current of any injection the drive can make (V_dc/6 at 500 Hz or more) is below 30 mA, under
#: the resolution of its current sensors; below 1 uH the PWM ripple is hundreds of amperes; a phase
#: of 100 ohm passes at most 3 A at 300 V.
#: The ranges are the rows of the one table of plausible values, :data:`linsense.plausible.KINDS`.
PLAUSIBLE = {
    key: (KINDS[kind].low, KINDS[kind].high, KINDS[kind].unit, above, below)
    for key, kind, above, below in (("motor.pole_pitch", "pole_pitch", "mm", None),
                                    ("motor.R_s", "resistance", "milliohm", None),
                                    ("motor.force_constant", "force_constant", None, None),
                                    ("motor.mass", "mass", "g", None),
                                    ("inductance", "inductance", "mH", "uH or nH"))
}
#: s, the longest electrical time constant L0 / R_s of a real linear motor (large iron-core motors
#: reach 20-30 ms): an inductance typed in mH that the range above lets through (0.1 to 0.5) ends here
MAX_TIME_CONSTANT = 0.1


def _implausible(key: str, value: float, what: str = "") -> str | None:
    lo, hi, unit, above, below = PLAUSIBLE[key]
    name = what or key.split(".")[-1]
    if lo <= value <= hi:
        return None
    hint = above if value > hi else below
    typed = f" Did you type {hint}? Motor files are in SI units ({unit})." if hint else ""
    return (f"{name} = {value:g} {unit} is outside the range of real linear motors "
            f"[{lo:g}, {hi:g}] {unit}.{typed}")


def check_plausible(motor: Motor) -> None:
    """Refuse values off by a unit prefix from any real linear motor (mm for m, mH for H ...).

    Parameters
    ----------
    motor : Motor
        The motor to check.

    Raises
    ------
    InputError
        Naming the key, the value, the range (:data:`PLAUSIBLE`; the per-phase magnet flux of
        ``[pm_flux]``: :data:`linsense.plausible.KINDS` ``flux_scale`` and ``flux_shift``) and the
        likely mistake.
    """
    for key, value in (("motor.pole_pitch", motor.pole_pitch), ("motor.R_s", motor.R_s),
                       ("motor.force_constant", motor.force_constant), ("motor.mass", motor.mass)):
        msg = _implausible(key, value)
        if msg:
            raise InputError(motor.source or _API, key, msg)
    if motor.inductance.params:
        key, what, L_self = "inductance.L0", "L0", float(motor.inductance.params["L0"])
    else:
        theta = check_grid(motor.inductance)
        key, what = "inductance.table", "the mean phase self-inductance"
        L_self = float(np.mean(motor.inductance.entries(theta)[..., :3]))
    msg = _implausible("inductance", L_self, what)
    if msg:
        raise InputError(motor.source or _API, key, msg)
    if L_self > MAX_TIME_CONSTANT * motor.R_s > 0.0:
        raise InputError(motor.source or _API, key, (
            f"{what} = {L_self:g} H with R_s = {motor.R_s:g} ohm is an electrical time constant of "
            f"{L_self / motor.R_s:.3g} s, beyond the {MAX_TIME_CONSTANT:g} s of real linear motors. "
            "Did you type mH? Motor files are in SI units (H)."))
    p = motor.pm_phases
    for k in range(3):
        for name, kind, value in (("scale_abc", "flux_scale", float(p.scale[k])),
                                  ("shift_deg_abc", "flux_shift", math.degrees(p.shift[k]))):
            msg = implausible(kind, value)
            if msg:
                raise InputError(motor.source or _API, f"pm_flux.{name}[{k}]", f"phase {PHASES[k]}: {msg}")


def check_motor(motor: Motor) -> None:
    """Refuse models that are unphysical or unusable for HF sensorless control.

    * the 3x3 phase inductance matrix must be positive definite at every position (the magnetic
      energy of any phase currents is positive; then so is the alpha-beta block, the one seen by
      currents with a floating star point);
    * the saliency ``L_q - L_d`` must keep one sign and stay above ``MIN_SALIENCY_RATIO`` of the
      mean inductance everywhere, else the position error signal vanishes or reverses.

    Parameters
    ----------
    motor : Motor
        The motor to check.

    Raises
    ------
    ModelError
        Naming the positions (electrical degrees) where the condition fails.
    """
    theta = check_grid(motor.inductance)
    eig_min = np.linalg.eigvalsh(motor.inductance.L_abc(theta))[..., 0]
    bad = ~(eig_min > 0)
    if bad.any():
        raise ModelError(
            motor.source or _API, "inductance",
            f"3x3 phase inductance matrix not positive definite at theta = {_intervals_deg(theta, bad)} "
            f"(smallest eigenvalue {eig_min.min():.3g} H): no real winding has it",
        )
    bad, sal = _saliency_lost(motor.inductance, theta)
    if bad.any():
        raise ModelError(
            motor.source or _API, "inductance",
            f"saliency L_q - L_d vanishes or changes sign at theta = {_intervals_deg(theta, bad)} "
            f"(range {sal.min():.3g} .. {sal.max():.3g} H): HF sensorless control impossible there"
            + _end_effect_room(motor.inductance, theta),
        )


def _saliency_lost(ind: InductanceModel, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Where the saliency ``L_q - L_d`` of ``ind`` at ``theta`` leaves its mean's sign or falls within
    :data:`MIN_SALIENCY_RATIO` of the mean inductance (bool), and the saliency (H)."""
    L_dq = ind.L_dq(theta)
    sal = L_dq[..., 1, 1] - L_dq[..., 0, 0]
    L_mean = 0.5 * (L_dq[..., 1, 1] + L_dq[..., 0, 0])
    sign = 1.0 if np.mean(sal) >= 0 else -1.0
    return sign * sal <= MIN_SALIENCY_RATIO * L_mean, sal


def _end_effect_room(ind: InductanceModel, theta: np.ndarray) -> str:
    """Where the end effect (eq. 3's dM0: the mean of M_BC and M_CA beyond M_AB) is what takes the
    saliency's sign away and the motor without it keeps one: the largest dM0 of its sign that does,
    for the message ('' otherwise)."""
    d_m0 = ind.end_effect

    def keeps(k: float) -> bool:  # (the saliency of one sign, dM0 scaled by k)
        return not _saliency_lost(ind.scaled(k_end_effect=k), theta)[0].any()

    if d_m0 == 0.0 or not keeps(0.0):
        return ""
    lo, hi = 0.0, 1.0  # (the largest share of dM0 that keeps it, by bisection)
    for _ in range(40):
        lo, hi = ((lo + hi) / 2.0, hi) if keeps((lo + hi) / 2.0) else (lo, (lo + hi) / 2.0)
    return (f"; it is the end effect's: dM0 = {d_m0:.3g} H (the mean of M_BC and M_CA beyond M_AB) is too "
            f"large for this saliency: at most {lo * abs(d_m0):.3g} H in magnitude")


def _toml_str(text: str) -> str:
    """``text`` as a TOML basic string (a name with a quote or a backslash wrote a file that did not
    load back)."""
    import tomli_w

    return tomli_w.dumps({"s": str(text)})[len("s = "):].strip()


def motor_to_toml(motor: Motor, table: str | None = None) -> str:
    """Serialise a motor to the motor-file format (round-trips through :func:`load_motor`).

    A parametric model writes its eq. (3) parameters; otherwise ``table`` must name the CSV.
    Every number is written as a plain float (a numpy scalar wrote ``np.float64(9.0)``, not TOML).

    Parameters
    ----------
    motor : Motor
        The motor.
    table : str or None, optional
        The inductance table's file name to write (needed for a tabulated model).

    Returns
    -------
    str
        The motor file's TOML text.

    Raises
    ------
    ValueError
        A tabulated model without ``table``.
    """
    f = motor.friction
    lines = [
        "[motor]",
        f"name = {_toml_str(motor.name)}",
        f"R_s = {float(motor.R_s)!r}              # ohm",
        f"pole_pitch = {float(motor.pole_pitch)!r}     # m, one electrical period",
        f"force_constant = {float(motor.force_constant)!r}  # N/A, per peak phase current",
        f"mass = {float(motor.mass)!r}             # kg, moving part",
        "",
        "[inductance]           # H",
    ]
    if table is not None:
        lines.append(f"table = {_toml_str(table)}")
    elif motor.inductance.params:
        lines += [f"{k} = {float(v)!r}" for k, v in motor.inductance.params.items()]
    else:
        raise ValueError("a tabulated inductance model needs the name of its table file")
    if f.viscous or f.coulomb:
        lines += ["", "[friction]", f"viscous = {float(f.viscous)!r}  # N s/m",
                  f"coulomb = {float(f.coulomb)!r}  # N"]
    sat = motor.saturation
    if sat is not None and not sat.tables:  # (tables need their file names: not written)
        lines += ["", "[saturation]", f"polarity = {float(sat.polarity)!r}  # 1/A",
                  f"q_drop = {float(sat.q_drop)!r}", f"q_current = {float(sat.q_current)!r}  # A"]
        if sat.magnet_current is not None:
            lines.append(f"magnet_current = {float(sat.magnet_current)!r}  # A")
    p = motor.pm_phases
    if motor.pm_harmonics or not p.balanced:
        lines += ["", "[pm_flux]"]
    if not p.balanced:
        lines += [f"scale_abc = [{', '.join(repr(float(g)) for g in p.scale)}]  # of psi_pm, A, B, C",
                  f"shift_deg_abc = [{', '.join(repr(float(math.degrees(d))) for d in p.shift)}]  "
                  "# electrical degrees"]
    if motor.pm_harmonics:
        lines.append("harmonics = [")
        lines += [
            f"  {{ order = {int(h.order)}, amplitude = {float(h.amplitude)!r}, "
            f"phase_deg = {float(math.degrees(h.phase))!r} }},"
            for h in motor.pm_harmonics
        ]
        lines.append("]")
    return "\n".join(lines) + "\n"
