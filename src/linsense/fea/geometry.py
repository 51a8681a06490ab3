"""Geometry files of axisymmetric tubular motors (TOML, SI units) and their r-z layout.

A geometry file describes a tubular motor like the paper's Fig. 1: an inner rod of axially
magnetised magnets of alternating polarity separated by iron spacers, a non-magnetic tube, an air
gap, and a slotless armature (coils in front of a back iron) of finite length, so that the open
ends are modelled. Validated with pydantic in strict mode; errors are one line naming the file,
the key and the value (:func:`linsense.validation.to_input_error`). See docs/fea.md.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from importlib import resources
from pathlib import Path
from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from linsense.errors import InputError, KeyProblem
from linsense.io import parse_toml, read_text_file
from linsense.plausible import implausible, slip
from linsense.validation import to_input_error

_STRICT = ConfigDict(extra="forbid", strict=True, allow_inf_nan=False)
Positive = Annotated[float, Field(gt=0)]
NonNegative = Annotated[float, Field(ge=0)]
#: the largest number of coils a geometry may hold (bounds the mesh)
MAX_COILS = 120
_TOKEN_SIGN = {"+": 1, "-": -1}


class MotorPart(BaseModel):
    """The ``[motor]`` section of a geometry file (docs/fea.md).

    Attributes
    ----------
    name : str
        Motor name.
    pole_pitch : float
        One electrical period (as in motor files), m.
    mass : float
        Moving mass written into motor.toml, kg.
    R_s : float
        Phase resistance written into motor.toml, ohm.
    force_constant : float or None
        N/A; default: from the computed PM flux linkage.
    """
    model_config = _STRICT
    name: str = Field(min_length=1, max_length=200)
    pole_pitch: Positive  # m, one electrical period (as in motor files)
    mass: Positive = 1.0  # kg, written into motor.toml
    R_s: NonNegative = 0.0  # ohm, written into motor.toml
    force_constant: Positive | None = None  # N/A; default: from the computed PM flux linkage

    @model_validator(mode="after")
    def _check(self) -> MotorPart:
        if any(ord(c) < 32 or ord(c) == 127 for c in self.name):
            raise KeyProblem("name", f"control characters are not allowed in a name, got {self.name!r}")
        return self


#: the default B-H curve of the iron (a typical non-oriented electrical steel, M270-35A class): T, A/m
DEFAULT_BH = ((0.0, 0.5, 1.0, 1.2, 1.4, 1.5, 1.6, 1.7, 1.8, 1.9, 2.0, 2.1),
              (0.0, 60.0, 120.0, 180.0, 320.0, 560.0, 1200.0, 3000.0, 7000.0, 15000.0, 30000.0, 60000.0))


class BHTable(BaseModel):
    """A B-H curve given as a table.

    Attributes
    ----------
    B : list of float
        Flux density, T.
    H : list of float
        Field strength, A/m.
    """
    model_config = _STRICT
    B: list[Annotated[float, Field(ge=0, le=5)]] = Field(min_length=3, max_length=1000)  # T
    H: list[Annotated[float, Field(ge=0, le=1e8)]] = Field(min_length=3, max_length=1000)  # A/m

    @model_validator(mode="after")
    def _check(self) -> BHTable:
        if len(self.B) != len(self.H):
            raise KeyProblem("H", f"{len(self.H)} values for {len(self.B)} values of B")
        if self.B[0] != 0 or self.H[0] != 0:
            raise KeyProblem("B", "the curve must start at B = 0, H = 0")
        for k in range(1, len(self.B)):
            if not (self.B[k] > self.B[k - 1] and self.H[k] > self.H[k - 1]):
                raise KeyProblem("B", f"B and H must increase strictly (point {k}: B {self.B[k]!r}, "
                                 f"H {self.H[k]!r})")
            if (self.B[k] - self.B[k - 1]) / (self.H[k] - self.H[k - 1]) < 4e-7 * 3.141592653589793 * 0.999:
                raise KeyProblem("B", f"slope below mu0 at point {k}: not a ferromagnetic curve")
        return self


BH = str | dict | None


def _bh_of(bh) -> tuple | None:
    if bh is None:
        return None
    if bh == "default":
        return DEFAULT_BH
    return (tuple(float(b) for b in bh["B"]), tuple(float(h) for h in bh["H"]))


def _check_bh(part) -> None:
    bh = part.bh
    if bh is not None and "mu_r_iron" in part.model_fields_set:
        raise KeyProblem("bh", "give either 'mu_r_iron' (linear) or 'bh' (a B-H curve), not both")
    if isinstance(bh, str) and bh != "default":
        raise KeyProblem("bh", f"unknown curve {bh!r} (give 'default' or a table {{ B = [...], H = [...] }})")
    if isinstance(bh, dict):
        try:
            BHTable.model_validate(bh)
        except ValidationError as exc:
            err = to_input_error(exc, "", BHTable)
            raise KeyProblem(f"bh.{err.key}", err.message) from None


class RodPart(BaseModel):
    """The ``[rod]`` section: the magnet rod.

    Attributes
    ----------
    radius : float
        Outer radius of magnets and spacers (solid to the axis), m.
    magnet_length : float
        Axial length of one magnet, m; spacer = pole_pitch / 2 - magnet_length.
    tube_thickness : float
        Non-magnetic tube around the rod, m.
    remanence : float
        Axial magnetisation, alternating sign, T.
    mu_r_magnet : float
        Recoil permeability.
    mu_r_iron : float
        Relative permeability of the spacers (linear).
    bh : str or dict or None
        Or a B-H curve: ``"default"`` or ``{B = [...], H = [...]}`` (saturating spacers).
    """
    model_config = _STRICT
    radius: Positive  # m, outer radius of magnets and spacers (solid to the axis)
    magnet_length: Positive  # m, axial length of one magnet; spacer = pole_pitch / 2 - magnet_length
    tube_thickness: NonNegative = 0.0  # m, non-magnetic tube around the rod
    remanence: NonNegative = 1.2  # T, axial magnetisation, alternating sign
    mu_r_magnet: Annotated[float, Field(ge=1.0, le=10.0)] = 1.05  # recoil permeability
    mu_r_iron: Annotated[float, Field(ge=1.0, le=1e6)] = 1000.0  # spacers (linear)
    bh: BH = None  # or a B-H curve: "default" or { B = [...], H = [...] } (saturating spacers)

    @model_validator(mode="after")
    def _check(self) -> RodPart:
        _check_bh(self)
        return self


class CoilEntry(BaseModel):
    """One coil of ``[armature] coils``.

    Attributes
    ----------
    phase : str
        ``"A"``, ``"B"`` or ``"C"``.
    sign : int
        Winding sense, 1 or -1.
    turns : int
        Turns.
    """
    model_config = _STRICT
    phase: Literal["A", "B", "C"]
    sign: Literal[1, -1]
    turns: Annotated[int, Field(ge=1, le=100_000)]


class ArmaturePart(BaseModel):
    """The ``[armature]`` section: an explicit coil list, or a sequence of tokens repeated.

    Attributes
    ----------
    air_gap : float
        Radial, tube to armature bore, m.
    coil_depth : float
        Radial depth of the coils, m.
    back_iron : float
        Radial thickness of the back iron, m.
    coil_pitch : float or None
        Axial length per coil, m (default pole_pitch / 6).
    end_length : float
        Back iron beyond the outer coils at each end, m.
    mu_r_iron : float
        Relative permeability of the back iron (linear).
    bh : str or dict or None
        Or a B-H curve: ``"default"`` or ``{B = [...], H = [...]}`` (saturating back iron).
    coils : list of CoilEntry or None
        The explicit coil list.
    sequence : str or None
        Tokens such as ``"A+ C- B+ A- C+ B-"``.
    repeat : int
        Repetitions of ``sequence``.
    turns : int or None
        Turns of each coil of ``sequence``.
    """
    model_config = _STRICT
    air_gap: Positive  # m, radial, tube to armature bore
    coil_depth: Positive  # m, radial depth of the coils
    back_iron: Positive  # m, radial thickness of the back iron
    coil_pitch: Positive | None = None  # m, axial length per coil (default pole_pitch / 6)
    end_length: NonNegative = 0.0  # m, back iron beyond the outer coils at each end
    mu_r_iron: Annotated[float, Field(ge=1.0, le=1e6)] = 1000.0
    bh: BH = None  # or a B-H curve: "default" or { B = [...], H = [...] } (saturating back iron)
    # either an explicit coil list ...
    coils: list[CoilEntry] | None = Field(default=None, min_length=1, max_length=MAX_COILS)
    # ... or a sequence of tokens repeated
    sequence: str | None = None  # e.g. "A+ C- B+ A- C+ B-"
    repeat: Annotated[int, Field(ge=1, le=MAX_COILS)] = 1
    turns: Annotated[int, Field(ge=1, le=100_000)] | None = None

    @model_validator(mode="after")
    def _check(self) -> ArmaturePart:
        _check_bh(self)
        if self.coils is not None:
            for k in ("sequence", "turns"):
                if getattr(self, k) is not None:
                    raise KeyProblem(k, "give either 'coils' or 'sequence' with 'turns', not both")
            return self
        if self.sequence is None:
            raise KeyProblem("coils", "missing: give 'coils' or 'sequence' (e.g. \"A+ C- B+ A- C+ B-\")")
        if self.turns is None:
            raise KeyProblem("turns", "missing required key (with 'sequence')")
        tokens = self.sequence.split()
        if not tokens:
            raise KeyProblem("sequence", f"empty, got {self.sequence!r}")
        for t in tokens:
            if len(t) != 2 or t[0] not in "ABC" or t[1] not in "+-":
                raise KeyProblem("sequence", f"token {t!r} is not a phase A/B/C and a sign +/- (e.g. 'A+')")
        if len(tokens) * self.repeat > MAX_COILS:
            raise KeyProblem("repeat", f"{len(tokens) * self.repeat} coils, beyond the limit of {MAX_COILS}")
        return self

    def coil_list(self) -> list[CoilEntry]:
        """The coils: the explicit list, or ``sequence`` repeated ``repeat`` times.

        Returns
        -------
        list of CoilEntry
            In axial order.
        """
        if self.coils is not None:
            return list(self.coils)
        tokens = self.sequence.split() * self.repeat
        return [CoilEntry(phase=t[0], sign=_TOKEN_SIGN[t[1]], turns=self.turns) for t in tokens]


class DomainPart(BaseModel):
    """The ``[domain]`` section: the meshed domain.

    Attributes
    ----------
    far : float
        Far boundary, in armature outer radii.
    margin_periods : float
        Fine zone beyond the armature, in pole pitches.
    """
    model_config = _STRICT
    far: Annotated[float, Field(ge=1.5, le=100.0)] = 4.0  # far boundary, in armature outer radii
    margin_periods: Annotated[float, Field(ge=0.0, le=10.0)] = 1.0  # fine zone beyond the armature


class GeometryFile(BaseModel):
    """A whole geometry file, validated (docs/fea.md).

    Attributes
    ----------
    motor : MotorPart
        ``[motor]``.
    rod : RodPart
        ``[rod]``.
    armature : ArmaturePart
        ``[armature]``.
    domain : DomainPart
        ``[domain]`` (defaults).
    """
    model_config = _STRICT
    motor: MotorPart
    rod: RodPart
    armature: ArmaturePart
    domain: DomainPart = Field(default_factory=DomainPart)

    @model_validator(mode="after")
    def _check(self) -> GeometryFile:
        # (the table of plausible values: a pole pitch of 56 was "outer radius or pole pitch beyond
        # 10 m" naming [armature])
        pitch = implausible("pole_pitch", self.motor.pole_pitch)
        if pitch is not None:
            raise KeyProblem("motor.pole_pitch", f"{pitch}; a geometry file is in m")
        half = self.motor.pole_pitch / 2
        if self.rod.magnet_length > half:
            raise KeyProblem("rod.magnet_length", f"{self.rod.magnet_length!r} m exceeds half the pole pitch "
                             f"({half:g} m): magnets and spacers alternate within pole_pitch / 2")
        outer = self.rod.radius + self.rod.tube_thickness + self.armature.air_gap
        outer += self.armature.coil_depth + self.armature.back_iron
        if outer > 10.0:
            hint = slip("pole_pitch", outer, ok=lambda v: v <= 10.0)
            raise KeyProblem("armature", f"the outer radius (rod.radius + rod.tube_thickness + air_gap + "
                             f"coil_depth + back_iron) {outer:g} m is beyond 10 m: check the units (m)"
                             + (f"; {hint}" if hint else ""))
        if outer / self.armature.air_gap > 1e4:
            raise KeyProblem("armature.air_gap", f"{self.armature.air_gap!r} m is below 1e-4 of the outer "
                             "radius: not meshable")
        return self


# ---------------------------------------------------------------------- layout
@dataclass
class Coil:
    """One coil as meshed.

    Attributes
    ----------
    index : int
        Position in the armature, from the lower z end.
    phase : str
        ``"A"``, ``"B"`` or ``"C"``.
    sign : int
        Winding sense, 1 or -1.
    turns : int
        Turns.
    r0 : float
        Inner radius, m.
    r1 : float
        Outer radius, m.
    z0 : float
        Lower axial end, m.
    z1 : float
        Upper axial end, m.
    """

    index: int
    phase: str
    sign: int
    turns: int
    r0: float
    r1: float
    z0: float
    z1: float

    @property
    def area(self) -> float:
        """Cross-section in the r-z plane, m^2."""
        return (self.r1 - self.r0) * (self.z1 - self.z0)


@dataclass
class Geometry:
    """The r-z layout of a geometry file (SI units); z = 0 is the armature's centre.

    Attributes
    ----------
    name : str
        Motor name.
    source : str
        The file or preset, for messages.
    pole_pitch : float
        m.
    mass : float
        kg.
    R_s : float
        ohm.
    force_constant : float or None
        N/A (None: from the computed PM flux linkage).
    r_rod : float
        Rod radius, m.
    r_tube : float
        Outer radius of the tube, m.
    r_bore : float
        Armature bore radius, m.
    r_coil : float
        Outer radius of the coils, m.
    r_out : float
        Outer radius of the back iron, m.
    magnet_length : float
        m.
    remanence : float
        T.
    mu_magnet : float
        Recoil permeability.
    mu_rod_iron : float
        Relative permeability of the spacers.
    mu_arm_iron : float
        Relative permeability of the back iron.
    z_arm0 : float
        Lower end of the armature, m.
    z_arm1 : float
        Upper end of the armature, m.
    coils : list of Coil
        The coils as meshed.
    far : float
        Far boundary, in armature outer radii.
    margin : float
        Fine zone beyond the armature, m.
    bh_rod : tuple or None
        ``(B, H)`` of the spacers (T, A/m), None: linear ``mu_rod_iron``.
    bh_arm : tuple or None
        ``(B, H)`` of the back iron, None: linear ``mu_arm_iron``.
    notes : list of str
        Remarks on the layout (empty unless a caller adds some).
    """

    name: str
    source: str
    pole_pitch: float
    mass: float
    R_s: float
    force_constant: float | None
    r_rod: float
    r_tube: float
    r_bore: float
    r_coil: float
    r_out: float
    magnet_length: float
    remanence: float
    mu_magnet: float
    mu_rod_iron: float
    mu_arm_iron: float
    z_arm0: float
    z_arm1: float
    coils: list[Coil]
    far: float
    margin: float
    bh_rod: tuple | None = None  # (B, H) of the spacers, None: linear mu_rod_iron
    bh_arm: tuple | None = None  # (B, H) of the back iron, None: linear mu_arm_iron
    notes: list[str] = field(default_factory=list)

    @property
    def r_far(self) -> float:
        """Radius of the far boundary, m."""
        return self.far * self.r_out

    @property
    def z_far(self) -> tuple[float, float]:
        """Axial ends of the domain, m."""
        ext = self.margin + self.far * self.r_out
        return self.z_arm0 - ext, self.z_arm1 + ext

    def regions(self) -> dict:
        """Every region as meshed (for geometry.json).

        Returns
        -------
        dict
            Region name to its extents and materials, m and T.
        """
        return {
            "units": "m, T",
            "name": self.name,
            "pole_pitch": self.pole_pitch,
            "rod": {"r": [0.0, self.r_rod], "z": "whole domain (infinite rod)",
                    "magnet_length": self.magnet_length,
                    "spacer_length": self.pole_pitch / 2 - self.magnet_length,
                    "remanence": self.remanence, "mu_r_magnet": self.mu_magnet,
                    "iron": {"B_T": self.bh_rod[0], "H_A_per_m": self.bh_rod[1]} if self.bh_rod
                    else {"mu_r": self.mu_rod_iron},
                    "pattern": "magnet +z centred at z = x, spacer, magnet -z centred at x + pole_pitch/2, "
                               "spacer (x: the rod's position)"},
            "tube": {"r": [self.r_rod, self.r_tube], "mu_r": 1.0},
            "air_gap": {"r": [self.r_tube, self.r_bore]},
            "back_iron": {"r": [self.r_coil, self.r_out], "z": [self.z_arm0, self.z_arm1],
                          "iron": {"B_T": self.bh_arm[0], "H_A_per_m": self.bh_arm[1]} if self.bh_arm
                          else {"mu_r": self.mu_arm_iron}},
            "coils": [asdict(c) for c in self.coils],
            "domain": {"r": [0.0, self.r_far], "z": list(self.z_far),
                       "boundary": "flux function r*A_phi = 0 on the axis and on the far boundary"},
        }


def geometry_from_doc(doc: GeometryFile, source: str) -> Geometry:
    """The r-z layout of a validated geometry file.

    Parameters
    ----------
    doc : GeometryFile
        The validated file.
    source : str
        Its name, for messages.

    Returns
    -------
    Geometry
        The layout, the armature centred on z = 0.
    """
    m, rod, arm = doc.motor, doc.rod, doc.armature
    coils = arm.coil_list()
    pitch = arm.coil_pitch if arm.coil_pitch is not None else m.pole_pitch / 6
    r_tube = rod.radius + rod.tube_thickness
    r_bore = r_tube + arm.air_gap
    r_coil = r_bore + arm.coil_depth
    r_out = r_coil + arm.back_iron
    length = len(coils) * pitch + 2 * arm.end_length
    z0 = -length / 2
    out = []
    for k, c in enumerate(coils):
        za = z0 + arm.end_length + k * pitch
        out.append(Coil(k, c.phase, int(c.sign), int(c.turns), r_bore, r_coil, za, za + pitch))
    return Geometry(
        name=m.name, source=source, pole_pitch=m.pole_pitch, mass=m.mass, R_s=m.R_s,
        force_constant=m.force_constant, r_rod=rod.radius, r_tube=r_tube, r_bore=r_bore, r_coil=r_coil,
        r_out=r_out, magnet_length=rod.magnet_length, remanence=rod.remanence, mu_magnet=rod.mu_r_magnet,
        mu_rod_iron=rod.mu_r_iron, mu_arm_iron=arm.mu_r_iron, z_arm0=z0, z_arm1=-z0, coils=out,
        far=doc.domain.far, margin=doc.domain.margin_periods * m.pole_pitch,
        bh_rod=_bh_of(rod.bh), bh_arm=_bh_of(arm.bh),
    )


def preset_names() -> list[str]:
    """Names of the built-in geometry presets (``linsense/fea/presets/<name>.toml``).

    Returns
    -------
    list of str
        Sorted.
    """
    return sorted(p.name[:-5] for p in (resources.files("linsense.fea") / "presets").iterdir()
                  if p.name.endswith(".toml"))


def geometry_from_toml(text: str, source: str) -> Geometry:
    """Parse and validate the text of a geometry file.

    Parameters
    ----------
    text : str
        The TOML text.
    source : str
        Its name, for messages.

    Returns
    -------
    Geometry
        The layout.

    Raises
    ------
    linsense.errors.InputError
        Bad TOML or an invalid key, naming ``source`` and the key.
    """
    data = parse_toml(text, source)
    try:
        doc = GeometryFile.model_validate(data)
    except ValidationError as exc:
        raise to_input_error(exc, source, GeometryFile) from None
    return geometry_from_doc(doc, source)


def load_geometry(spec: str | Path) -> Geometry:
    """A geometry from a file path or a preset name (``linsense/fea/presets/<name>.toml``).

    Parameters
    ----------
    spec : str or Path
        A ``.toml`` path, an existing path, or a preset name.

    Returns
    -------
    Geometry
        The layout.

    Raises
    ------
    linsense.errors.InputError
        No such file or preset, or an invalid file.
    """
    s = str(spec)
    p = Path(s)
    if p.suffix.lower() == ".toml" or p.exists() or "/" in s:
        return geometry_from_toml(read_text_file(s, "geometry file"), s)
    if s not in preset_names():
        raise InputError(s, "", f"no such geometry file or preset (presets: {', '.join(preset_names())})")
    text = (resources.files("linsense.fea") / "presets" / f"{s}.toml").read_text(encoding="utf-8")
    return geometry_from_toml(text, f"preset {s}")

