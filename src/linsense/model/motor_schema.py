"""Validation schema of motor files (TOML, SI units).

Parsed with :mod:`tomllib` and validated with pydantic in strict mode: unknown keys, missing
keys, wrong types (a string or a boolean where a number belongs) and non-finite numbers are all
refused. Errors are turned into :class:`~linsense.errors.InputError` naming file, key and value.
"""

from __future__ import annotations

import math
import re
from typing import Annotated

import numpy as np
from pydantic import AfterValidator, BaseModel, ConfigDict, Field, ValidationError, model_validator
from pydantic_core import PydanticCustomError

from linsense._check import brief, closest_key
from linsense.errors import InputError, KeyProblem
from linsense.limits import max_harmonic_order
from linsense.validation import to_input_error

_STRICT = ConfigDict(extra="forbid", strict=True, allow_inf_nan=False)

Positive = Annotated[float, Field(gt=0)]
NonNegative = Annotated[float, Field(ge=0)]


def _at_most_max_order(value: int) -> int:
    # pydantic's own ``le`` refusal, with the limit read from the C library when a value is checked
    # (a Field(le=...) would read it, and load the C extension, when linsense.model is imported)
    limit = max_harmonic_order()
    if value > limit:
        raise PydanticCustomError("less_than_equal", "Input should be less than or equal to {le}",
                                  {"le": limit})
    return value


#: a Fourier order of L_abc(theta) or of the PM flux: at most MAX_HARMONIC_ORDER (docs/limits.md)
Order = Annotated[int, AfterValidator(_at_most_max_order)]
#: a harmonic key as documented (docs/motor-files.md): L4, M4, L6 ... (ASCII digits, no leading
#: zero: L04 was accepted and its value dropped, the model got L4 = 0)
_HARMONIC_KEY = re.compile(r"([LM])([1-9][0-9]*)")
#: a harmonic key with leading zeros (L04, M006): refused, naming the key it stands for
_ZERO_PADDED_KEY = re.compile(r"([LM])0+([0-9]+)")


class MotorSection(BaseModel):
    """The ``[motor]`` section of a motor file (docs/motor-files.md).

    Attributes
    ----------
    name : str
        Motor name.
    R_s : float
        Phase resistance, ohm.
    pole_pitch : float
        One electrical period, m.
    force_constant : float
        Thrust per peak phase current, N/A.
    mass : float
        Moving mass, kg.
    """
    model_config = _STRICT
    name: str = Field(min_length=1)
    R_s: NonNegative  # ohm
    pole_pitch: Positive  # m, one electrical period
    force_constant: Positive  # N/A per peak phase current
    mass: Positive  # kg

    @model_validator(mode="after")
    def _check(self) -> MotorSection:
        if any(ord(c) < 32 or ord(c) == 127 for c in self.name):
            raise KeyProblem("name", f"control characters are not allowed in a name, got {self.name!r}")
        return self


class InductanceSection(BaseModel):
    """The ``[inductance]`` section: the eq. (3) parameters or a table.

    The parameters may come with optional ``L<n>``/``M<n>`` even harmonics (extra keys).

    Attributes
    ----------
    L0 : float or None
        Eq. (3) mean self-inductance, H.
    L2 : float or None
        Eq. (3) second-harmonic amplitude of the self-inductances, H.
    M0 : float or None
        Eq. (3) mean mutual inductance, H.
    M2 : float or None
        Eq. (3) second-harmonic amplitude of the mutual inductances, H.
    dM0 : float or None
        Eq. (3) end-effect: the excess of M_BC and M_CA over M_AB, H.
    table : str or None
        CSV path of ``L_abc(theta)``, relative to the motor file.
    table_max_order : int or None
        Fourier order of the table's fit.
    """

    model_config = ConfigDict(extra="allow", strict=True, allow_inf_nan=False)
    L0: float | None = None  # H
    L2: float | None = None  # H
    M0: float | None = None  # H
    M2: float | None = None  # H
    dM0: float | None = None  # H
    table: str | None = Field(default=None, min_length=1)  # CSV path, relative to the motor file
    table_max_order: Order | None = Field(default=None, ge=1)  # Fourier order of the fit

    @model_validator(mode="after")
    def _check(self) -> InductanceSection:
        extra = self.model_extra or {}
        for key, value in extra.items():
            padded = _ZERO_PADDED_KEY.fullmatch(key)
            if padded:
                meant = f"{padded.group(1)}{int(padded.group(2))}"
                raise KeyProblem(key, f"a harmonic key is written without leading zeros (L4, M4, L6 ...) "
                                 f"(did you mean '{meant}'?)")
            m = _HARMONIC_KEY.fullmatch(key)
            if not m or int(m.group(2)) < 4 or int(m.group(2)) % 2:
                known = [k for k in type(self).model_fields] + ["L4", "M4", "L6", "M6"]
                hint = closest_key(key, known)
                raise KeyProblem(key, f"unknown key (harmonics are L4, M4, L6, M6 ...){hint}")
            if int(m.group(2)) > max_harmonic_order():
                raise KeyProblem(key, f"harmonic order {int(m.group(2))} beyond the limit of "
                                 f"{max_harmonic_order()} (docs/limits.md)")
            if isinstance(value, bool) or not isinstance(value, int | float):
                raise KeyProblem(key, f"expected a number, got {value!r}")
            if not math.isfinite(value):
                raise KeyProblem(key, f"expected a finite number, got {value!r}")
        params = {k: getattr(self, k) for k in ("L0", "L2", "M0", "M2", "dM0")}
        if self.table is not None:
            given = [k for k, v in params.items() if v is not None] + list(extra)
            if given:
                raise KeyProblem(given[0], "give either the eq. (3) parameters or 'table', not both")
        else:
            if self.table_max_order is not None:
                raise KeyProblem("table_max_order", "only valid together with 'table'")
            for k, v in params.items():
                if v is None:
                    raise KeyProblem(k, "missing required key (or give 'table = \"file.csv\"')")
            if self.L0 <= 0:
                raise KeyProblem("L0", f"must be positive, got {self.L0!r}")
        return self

    def harmonics(self) -> dict[int, tuple[float, float]]:
        """``{n: (L_n, M_n)}`` of the optional higher even harmonics (a missing partner is 0).

        Returns
        -------
        dict
            ``{n: (L_n, M_n)}``, H.
        """
        extra = self.model_extra or {}
        orders = sorted({int(k[1:]) for k in extra})
        return {n: (float(extra.get(f"L{n}", 0.0)), float(extra.get(f"M{n}", 0.0))) for n in orders}


class FrictionSection(BaseModel):
    """The ``[friction]`` section.

    Attributes
    ----------
    viscous : float
        Viscous coefficient, N s/m.
    coulomb : float
        Coulomb force, N.
    """
    model_config = _STRICT
    viscous: NonNegative = 0.0  # N s/m
    coulomb: NonNegative = 0.0  # N


class PmHarmonicEntry(BaseModel):
    """One entry of ``[pm_flux] harmonics``.

    Attributes
    ----------
    order : int
        Harmonic order of the PM flux linkage in theta (at least 2).
    amplitude : float
        Relative to the fundamental PM flux linkage.
    phase_deg : float
        Phase, electrical degrees.
    """
    model_config = _STRICT
    order: Order = Field(ge=2)  # harmonic order of the PM flux linkage in theta
    amplitude: float  # relative to the fundamental PM flux linkage
    phase_deg: float = 0.0  # electrical degrees


#: the phases A, B, C, in the order of the per-phase keys of ``[pm_flux]``
PHASES = ("A", "B", "C")


class PmFluxSection(BaseModel):
    """The ``[pm_flux]`` section.

    Attributes
    ----------
    harmonics : list of PmHarmonicEntry
        The PM flux harmonics (none by default).
    scale_abc : list of float
        The end effect on the magnets' flux: each phase's PM flux-linkage amplitude relative to
        ``psi_pm``, phases A, B, C (default balanced, ``[1, 1, 1]``), dimensionless
        (docs/motor-files.md, "End effect on the magnets' flux"; docs/theory.md).
    shift_deg_abc : list of float
        Each phase's PM flux phase advance, electrical degrees (default ``[0, 0, 0]``).
    """
    model_config = _STRICT
    harmonics: list[PmHarmonicEntry] = Field(default_factory=list)
    scale_abc: list[float] = Field(default_factory=lambda: [1.0, 1.0, 1.0], min_length=3,
                                   max_length=3)  # -, relative to psi_pm, phases A, B, C
    shift_deg_abc: list[float] = Field(default_factory=lambda: [0.0, 0.0, 0.0], min_length=3,
                                       max_length=3)  # electrical degrees, phases A, B, C

    @model_validator(mode="after")
    def _one_entry_per_order(self) -> PmFluxSection:
        # (an order listed twice was accepted, one entry silently over the other)
        seen = set()
        for k, h in enumerate(self.harmonics):
            if h.order in seen:
                raise KeyProblem(f"harmonics[{k}].order", f"order {h.order} is listed twice: give each "
                                 "order once (amplitude and phase_deg together)")
            seen.add(h.order)
        return self


class SaturationSection(BaseModel):
    """The ``[saturation]`` section, for the simulator's saturated plant (:mod:`linsense.model.saturation`).

    The parametric keys, or incremental inductance tables at several q currents (plus ``polarity``).

    Attributes
    ----------
    polarity : float
        ``(L_d(-I) - L_d(+I)) / L_d`` per ampere of d pulse, 1/A.
    magnet_current : float or None
        ``i_m``, A (default ``psi_pm / mean L_d``).
    q_drop : float
        Relative fall of ``L_q`` at ``q_current``, dimensionless.
    q_current : float
        A.
    currents : list of float or None
        q currents of the tables, A.
    tables : list of str or None
        ``L_abc(theta)`` CSVs, relative to the motor file.
    table_max_order : int or None
        Fourier order of the tables' fit.
    """

    model_config = _STRICT
    polarity: NonNegative = 0.0  # 1/A, (L_d(-I) - L_d(+I)) / L_d per A of d pulse
    magnet_current: Positive | None = None  # A, i_m (default psi_pm / mean L_d)
    q_drop: float = Field(default=0.0, ge=0.0, lt=1.0)  # -, fall of L_q at q_current
    q_current: Positive = 1.0  # A
    currents: list[float] | None = None  # A, q currents of the tables
    tables: list[Annotated[str, Field(min_length=1)]] | None = None  # L_abc(theta) CSVs
    table_max_order: Order | None = Field(default=None, ge=1)

    @model_validator(mode="after")
    def _check(self) -> SaturationSection:
        if (self.currents is None) != (self.tables is None):
            raise KeyProblem("tables" if self.tables is None else "currents",
                             "give currents and tables together (or neither: the parametric model)")
        if self.currents is not None:
            if len(self.currents) != len(self.tables):
                raise KeyProblem("tables", f"{len(self.tables)} tables for {len(self.currents)} currents")
            if not 2 <= len(self.currents) <= 16:
                raise KeyProblem("currents", f"give 2 to 16 currents, got {len(self.currents)}")
            if len(set(self.currents)) != len(self.currents):
                raise KeyProblem("currents", f"currents must be distinct, got {self.currents!r}")
            if any(abs(c) > 1e3 for c in self.currents):
                raise KeyProblem("currents", f"beyond 1000 A, got {self.currents!r}")
            if self.q_drop:
                raise KeyProblem("q_drop", "the tables give the q-axis saturation: q_drop is for the "
                                 "parametric model only")
        elif self.table_max_order is not None:
            raise KeyProblem("table_max_order", "only valid together with 'tables'")
        return self


class MotorFile(BaseModel):
    """A whole motor file, validated (docs/motor-files.md).

    Attributes
    ----------
    motor : MotorSection
        ``[motor]``.
    inductance : InductanceSection
        ``[inductance]``.
    friction : FrictionSection
        ``[friction]`` (zero by default).
    pm_flux : PmFluxSection
        ``[pm_flux]`` (no harmonics by default).
    saturation : SaturationSection or None
        ``[saturation]`` (None: none).
    """
    model_config = _STRICT
    motor: MotorSection
    inductance: InductanceSection
    friction: FrictionSection = Field(default_factory=FrictionSection)
    pm_flux: PmFluxSection = Field(default_factory=PmFluxSection)
    saturation: SaturationSection | None = None


def validate_motor_file(data: dict, source: str) -> MotorFile:
    """Validate the parsed TOML of a motor file.

    Parameters
    ----------
    data : dict
        The parsed TOML.
    source : str
        Its name in messages.

    Returns
    -------
    MotorFile
        The validated file.

    Raises
    ------
    InputError
        Naming ``source``, the key and the value.
    """
    try:
        return MotorFile.model_validate(data)
    except ValidationError as exc:
        raise to_input_error(exc, source, MotorFile) from None


def validate_section(section: type[BaseModel], data: dict, source: str, key: str) -> BaseModel:
    """Validate one section of a motor file (``[motor]``, ``[friction]``, a ``[pm_flux]`` harmonic,
    ``[saturation]``) with the reader's rules: the constructors of :class:`~linsense.model.motor.Motor`
    and its parts check their values through it, so that a motor built in Python is held to the
    motor file's checks and limits (one validated path).

    Parameters
    ----------
    section : type
        The section's pydantic model (:class:`MotorSection` ...).
    data : dict
        Its values (numpy's integers and floats are taken as Python's).
    source : str
        Named in messages (the motor file, or the class built from Python).
    key : str
        The section's dotted key, prefixed to the key at fault.

    Returns
    -------
    pydantic.BaseModel
        The validated section.

    Raises
    ------
    InputError
        Naming ``source``, the dotted key and the value.
    """
    # (numpy's integers and floats, as a fit gives them, are numbers; strict pydantic takes Python's
    # only, and took numpy's booleans and complex numbers as floats, the imaginary part dropped)
    plain = {}
    for k, v in data.items():
        if isinstance(v, np.generic) and not isinstance(v, np.integer | np.floating):
            raise InputError(source, f"{key}.{k}", f"expected a number, got {brief(v)} ({type(v).__name__})")
        plain[k] = v.item() if isinstance(v, np.generic) else v
    try:
        return section.model_validate(plain)
    except ValidationError as exc:
        err = to_input_error(exc, source, section)
        raise InputError(source, f"{key}.{err.key}" if err.key else key, err.message) from None
