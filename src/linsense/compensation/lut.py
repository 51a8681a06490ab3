"""The compensation look-up table Psi_LUT(theta) (paper eq. 12, Fig. 9) and its exports.

Table rule (shared with the C core, ``csrc/ctrl/ls_lut.c``): ``N`` values at the equally spaced
electrical positions ``theta_k = 2 pi k / N``, ``k = 0 .. N-1``, read with periodic linear
interpolation::

    u = theta / (2 pi) * N   wrapped into [0, N);   k = floor(u);   f = u - k
    Psi(theta) = (1 - f) table[k] + f table[(k + 1) mod N]

Exports are byte-reproducible (no timestamps): CSV (``theta_deg,psi_lut_deg``), JSON (radians,
with provenance) and a C99 header with a ``static const float`` table in radians.
"""

from __future__ import annotations

import dataclasses
import json
import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from linsense._check import brief, choice, instance, integer, is_real, path_arg, reals
from linsense._check import real as real_arg
from linsense.analysis.hf import psi_lut, psi_lut_resistive
from linsense.compensation.stamp import data_digest, stamp_comment, stamp_macros
from linsense.errors import InputError, shown
from linsense.io import check_width, csv_rows, read_text_file
from linsense.model.motor import as_motor
from linsense.version import __version__

FORMATS = ("csv", "json", "c")
#: the injections a table is made for (:func:`build_lut`)
INJECTIONS = ("pulsating", "rotating", "square")
#: the module, named in the messages of its functions' argument checks
_SRC = "linsense.compensation.lut"


@dataclass(frozen=True)
class Lut:
    """A compensation LUT.

    Parameters
    ----------
    values : ndarray, shape (N,)
        Psi_LUT at ``theta_k = 2 pi k / N``, rad.
    name : str
        Motor name, used in C identifiers and provenance.
    provenance : dict
        Motor parameters the table was computed from.
    digest : str
        SHA-256 of the motor data and table settings it was computed from (:func:`build_lut`;
        :mod:`linsense.compensation.stamp`), "" for a table read from a file.

    Raises
    ------
    linsense.errors.InputError
        ``values`` not one dimension of at least 4 finite real numbers, or another argument of the
        wrong type.
    """

    values: np.ndarray
    name: str = "motor"
    provenance: dict = field(default_factory=dict)
    digest: str = field(default="", compare=False)

    def __post_init__(self) -> None:
        # one validated path: a NaN, complex or 2-D table was taken
        src = f"{_SRC}.Lut"
        v = np.array(reals(self.values, src, "values", "table values in rad", ndim=1, min_size=4))
        instance(self.name, src, "name", str, "a str")
        instance(self.provenance, src, "provenance", dict, "a dict")
        instance(self.digest, src, "digest", str, "a str")
        v.setflags(write=False)
        object.__setattr__(self, "values", v)

    @property
    def points(self) -> int:
        """Number of table points."""
        return self.values.size

    @property
    def theta(self) -> np.ndarray:
        """Table positions, rad."""
        return 2.0 * np.pi * np.arange(self.points) / self.points

    def __call__(self, theta: np.ndarray | float) -> np.ndarray:
        """Periodic linear interpolation at ``theta`` (rad), the rule of the C core."""
        return interpolate(self.values, theta)


def interpolate(table: np.ndarray, theta: np.ndarray | float) -> np.ndarray:
    """Periodic linear interpolation of ``table`` (N equally spaced points over 2 pi) at ``theta``.

    Parameters
    ----------
    table : ndarray, shape (N,)
        Values at ``theta_k = 2 pi k / N``.
    theta : float or ndarray
        Electrical angle(s), rad.

    Returns
    -------
    ndarray
        Interpolated values, unit of ``table``.

    Raises
    ------
    linsense.errors.InputError
        ``table`` not one dimension of at least one finite real number, ``theta`` not finite real
        numbers (an empty table was an IndexError, a string theta was read as a number).
    """
    src = f"{_SRC}.interpolate"
    table = reals(table, src, "table", "table values", ndim=1, min_size=1)
    n = table.size
    u = np.mod(reals(theta, src, "theta", "positions in rad") / (2.0 * np.pi) * n, n)
    k = np.floor(u).astype(int) % n  # u may round up to n exactly
    f = u - np.floor(u)
    return (1.0 - f) * table[k] + f * table[(k + 1) % n]


def _table_args(src: str, points, f_inj, quad, needs_f: bool = False) -> int:
    """A table's ``points`` (returned as an int), ``f_inj`` (None allowed unless ``needs_f``) and
    ``quad`` checked (the API refuses what the CLI refuses: 4.5 points, 10**9 points, a complex or
    negative frequency were accepted, the second until memory ran out)."""
    from linsense.limits import MAX_POINTS

    points = integer(points, src, "points", 4, MAX_POINTS)
    if f_inj is not None or needs_f:
        table_frequency(f_inj, src, "f_inj")
    real_arg(quad, src, "quad", 0.0, 1.0, high_open=True, what="a number")
    return points


def table_frequency(f_inj, source: str, key: str) -> float:
    """A table's injection frequency checked: a positive number of Hz within
    :data:`~linsense.limits.MIN_F_INJ` .. :data:`~linsense.limits.MAX_F_INJ` (what ``lut --f-inj``
    refuses, by this function).

    Parameters
    ----------
    f_inj : object
        The frequency, Hz.
    source, key : str
        Where it was given, for the message (``"--f-inj", ""`` for the option).

    Returns
    -------
    float
        ``float(f_inj)``.

    Raises
    ------
    linsense.errors.InputError
        Not a positive number, or outside the range (saying why the range, and the slip of unit
        that brings it within: kHz typed for Hz made a table at 1 Hz).
    """
    from linsense.limits import MAX_F_INJ, MIN_F_INJ
    from linsense.plausible import slip
    from linsense.version import docs

    if not (is_real(f_inj) and f_inj > 0 and math.isfinite(f_inj)):
        raise InputError(source, key, f"must be a positive frequency in Hz, got {brief(f_inj)}")
    f = float(f_inj)
    if not MIN_F_INJ <= f <= MAX_F_INJ:
        slipped = slip("injection_frequency", f)
        why = (f"is below the lower limit of {MIN_F_INJ:g} Hz (an HF injection: the design's lowest, "
               "f_pwm / 4 of a 500 Hz PWM" if f < MIN_F_INJ else
               f"is beyond the limit of {MAX_F_INJ:g} Hz (half of a 1 MHz PWM")
        raise InputError(source, key, f"{f:g} Hz {why}; {docs('limits')})"
                         + (f"; {slipped}" if slipped else ""))
    return f


def build_lut(motor, points: int, f_inj: float | None = None, quad: float = 0.0,
              injection: str = "pulsating") -> Lut:
    """Psi_LUT of ``motor`` sampled at ``points`` positions over one electrical period.

    Without ``f_inj`` this is eq. (12) (with ``quad``: the elliptical injection's table with R_s
    neglected, which kappa moves as much as eq. 12's: -2.5 against -8.3 deg on a motor of the class);
    with it (Hz), the resistance-aware angle of
    :func:`~linsense.analysis.hf.psi_lut_resistive` for that injection frequency and the
    injection's quadrature share ``quad`` (0: pulsating, as the paper). ``injection="rotating"``:
    the rotating-vector injection's table as the drive reads it, ``psi_rot`` against the position
    (:func:`~linsense.analysis.rotating.psi_rotating`; without ``f_inj`` the R_s = 0 limit;
    docs/theory.md; :func:`~linsense.analysis.rotating.rotating_lut` is the open-loop inverse).
    ``injection="square"``: the square wave's table at ``f_inj`` (e.g. f_pwm / 2),
    :func:`~linsense.analysis.square.psi_square` (without ``f_inj``: eq. 12, its R_s = 0 limit).

    Parameters
    ----------
    motor : Motor
        The motor.
    points : int
        Table points over one electrical period, 4 .. :data:`linsense.limits.MAX_POINTS`.
    f_inj : float or None, optional
        Injection frequency, Hz (None: without resistance).
    quad : float, optional
        Quadrature share of the injection, in [0, 1).
    injection : {"pulsating", "rotating", "square"}, optional
        The injection the table is for.

    Returns
    -------
    Lut
        The table, rad, with the motor's provenance and the model used.

    Raises
    ------
    linsense.errors.InputError
        ``motor`` not a motor (:func:`~linsense.model.motor.as_motor`), ``points``, ``injection``,
        ``f_inj`` or ``quad`` out of range.
    """
    src = "linsense.compensation.build_lut"
    motor = as_motor(motor, src)
    points = _table_args(src, points, f_inj, quad)
    injection = choice(injection, src, "injection", INJECTIONS)
    theta = 2.0 * np.pi * np.arange(points) / points
    prov = motor.provenance()
    digest = data_digest(motor=motor, table={"points": points, "f_inj": f_inj, "quad": quad,
                                             "injection": injection})
    if injection == "rotating":
        from linsense.analysis.hf import table_model
        from linsense.analysis.rotating import psi_rotating

        # the drive's table: read at the observer's estimate, which at the equilibrium is the true
        # position, so sampled against the position (R_s = 0 without f_inj)
        m, f = table_model(motor, f_inj)
        values = psi_rotating(m, theta, f)
        prov = {**prov, "injection": "rotating",
                "lut_model": "R_s = 0 (e*)" if f_inj is None else "with R_s at f_inj"}
        if f_inj is not None:
            prov["f_inj"] = f_inj
    elif injection == "square" and f_inj is not None:
        from linsense.analysis.square import psi_square

        values = psi_square(motor, theta, f_inj)
        prov = {**prov, "injection": "square", "f_inj": f_inj, "lut_model": "with R_s at f_inj"}
    elif f_inj is None and not quad:
        values = psi_lut(motor, theta)
    elif f_inj is None:  # (the elliptical injection's table without R_s: kappa moves it as much as R_s)
        from linsense.analysis.hf import table_model

        m0, f0 = table_model(motor, None)
        values = psi_lut_resistive(m0, theta, f0, quad=quad)
        prov = {**prov, "lut_model": "R_s = 0", "inject_quad": quad}
    else:
        values = psi_lut_resistive(motor, theta, f_inj, quad=quad)
        prov = {**prov, "f_inj": f_inj, "lut_model": "with R_s at f_inj"}
        if quad:
            prov["inject_quad"] = quad
    return Lut(values, name=motor.name, provenance=prov, digest=digest)


#: relative step of R_s for the tables' slopes in it (central differences; the tables are smooth in
#: R_s: the linearisation leaves 0.2 deg at +30 % on ecce2010, docs/tuning.md "The hot winding")
R_SLOPE_STEP = 0.02


def resistance_slope(motor, table, n: int) -> np.ndarray:
    """``d table / dk_r`` of the ``n``-point table that ``table(motor)`` computes.

    Per unit of the resistance's scale ``k_r`` (``R_s = k_r R_s0``): central difference over
    :data:`R_SLOPE_STEP`, zeros for a motor without resistance. The tables' slopes the drive reads
    as it measures ``k_r`` (docs/tuning.md, "The hot winding").

    Parameters
    ----------
    motor : Motor
        The motor.
    table : callable
        ``table(motor) -> array of n values``.
    n : int
        The table's length.

    Returns
    -------
    ndarray, shape (n,)
        Unit of the table per unit of ``k_r``.

    Raises
    ------
    linsense.errors.InputError
        ``motor`` not a motor, ``table`` not callable, ``n`` not a number of points.
    """
    from linsense.limits import MAX_POINTS

    src = f"{_SRC}.resistance_slope"
    motor = as_motor(motor, src)
    if not callable(table):
        raise InputError(src, "table", f"expected a function of the motor, got {shown(table)}")
    n = integer(n, src, "n", 1, MAX_POINTS, "a number of points")
    if not motor.R_s > 0:
        return np.zeros(n)
    h = R_SLOPE_STEP
    hi, lo = (np.asarray(table(dataclasses.replace(motor, R_s=motor.R_s * (1.0 + s * h))))
              for s in (1.0, -1.0))
    return (hi - lo) / (2.0 * h)


def lut_r_slope(motor, points: int, f_inj: float, quad: float = 0.0) -> np.ndarray:
    """``dPsi_LUT/dk_r`` (rad per unit of ``k_r``) of the resistance-aware table.

    :func:`build_lut` with ``f_inj`` at its ``points`` positions (:func:`resistance_slope`): the
    drive measures ``k_r`` online (``ls_dtres_adapt``) and reads
    ``Psi_LUT + (k_r - 1) dPsi_LUT/dk_r`` (``ls_demod_cfg.comp_r``).

    Parameters
    ----------
    motor : Motor
        The motor.
    points : int
        Table points.
    f_inj : float
        Injection frequency, Hz.
    quad : float, optional
        Quadrature share of the injection.

    Returns
    -------
    ndarray, shape (points,)
        rad per unit of ``k_r``.

    Raises
    ------
    linsense.errors.InputError
        As :func:`build_lut`.
    """
    src = f"{_SRC}.lut_r_slope"
    motor = as_motor(motor, src)
    points = _table_args(src, points, f_inj, quad, needs_f=True)
    return resistance_slope(motor, lambda m: build_lut(m, points, f_inj=f_inj, quad=quad).values, points)


# ---------------------------------------------------------------------- exports
def _lut(lut, src: str) -> Lut:
    """``lut`` if it is a :class:`Lut`, else InputError naming the argument."""
    return instance(lut, src, "lut", Lut, "a Lut (build_lut, read_lut)")


def to_csv(lut: Lut) -> str:
    """``theta_deg,psi_lut_deg`` rows (electrical degrees, 12 significant digits).

    Parameters
    ----------
    lut : Lut
        The table.

    Returns
    -------
    str
        The CSV text.

    Raises
    ------
    linsense.errors.InputError
        ``lut`` not a :class:`Lut`.
    """
    lut = _lut(lut, f"{_SRC}.to_csv")
    lines = ["theta_deg,psi_lut_deg"]
    pairs = zip(np.degrees(lut.theta), np.degrees(lut.values), strict=True)
    lines += [f"{t:.12g},{p:.12g}" for t, p in pairs]
    return "\n".join(lines) + "\n"


def to_json(lut: Lut) -> str:
    """JSON document in SI units (rad) with provenance and the interpolation rule.

    Parameters
    ----------
    lut : Lut
        The table.

    Returns
    -------
    str
        The JSON text (format ``linsense-lut``, version 1).

    Raises
    ------
    linsense.errors.InputError
        ``lut`` not a :class:`Lut`.
    """
    lut = _lut(lut, f"{_SRC}.to_json")
    doc = {
        "format": "linsense-lut",
        "version": 1,
        "generator": f"linsense {__version__}",
        "quantity": (
            "Psi_LUT with R_s at f_inj (linsense.analysis.hf.psi_lut_resistive)"
            if "f_inj" in (lut.provenance or {}) else "Psi_LUT = atan(-L_dq/L_q), paper eq. (12)"
        ),
        "motor": lut.provenance or {"name": lut.name},
        "points": lut.points,
        "angle_unit": "rad (electrical)",
        "interpolation": "periodic linear, theta_k = 2*pi*k/points",
        "theta": [float(t) for t in lut.theta],
        "psi_lut": [float(v) for v in lut.values],
    }
    return json.dumps(doc, indent=1) + "\n"


#: C99's keywords, which are not identifiers (``lut --symbol int`` wrote a header that did not
#: compile)
C_KEYWORDS = frozenset(
    "auto break case char const continue default do double else enum extern float for goto if "
    "inline int long register restrict return short signed sizeof static struct switch typedef "
    "union unsigned void volatile while".split())
#: what a name a user gives for C (``lut --symbol``, ``tune --name``) may not be besides: C11's and
#: C23's keywords, and C++'s (a header may be included from C++)
C_RESERVED_WORDS = C_KEYWORDS | frozenset(
    "alignas alignof bool constexpr false nullptr static_assert thread_local true typeof typeof_unqual "
    "and and_eq asm bitand bitor catch char8_t char16_t char32_t class compl concept consteval "
    "constinit const_cast co_await co_return co_yield decltype delete dynamic_cast explicit export "
    "friend mutable namespace new noexcept not not_eq operator or or_eq private protected public "
    "reinterpret_cast requires static_cast template this throw try typeid typename using virtual "
    "wchar_t xor xor_eq".split())
#: names of the C standard library a generated array or function may not take (a header that
#: includes math.h or stdio.h would not compile)
C_LIBRARY_NAMES = frozenset(
    "sin cos tan asin acos atan atan2 sinh cosh tanh exp exp2 log log2 log10 pow sqrt cbrt hypot ceil "
    "floor fabs fmod round trunc fmin fmax sinf cosf sqrtf fabsf NAN INFINITY HUGE_VAL M_PI abs labs "
    "div malloc calloc realloc free exit abort atoi atof rand srand qsort bsearch memcpy memmove memset "
    "memcmp strlen strcpy strcmp printf fprintf sprintf snprintf puts putchar getchar FILE stdin stdout "
    "stderr EOF errno assert NULL offsetof main".split())
#: initial characters of an identifier or macro name C99 compilers must tell apart (5.2.4.1)
C_SIGNIFICANT_CHARS = 63
_C_IDENTIFIER = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")


def c_identifier(name: str) -> str:
    """A valid lower-case C identifier derived from ``name`` (a motor's name, for a default C name).

    ``m_`` before a leading digit or a C keyword (``_t`` after it, as it was, is POSIX's); ``motor``
    when nothing is left. A name a user gives for C is checked by :func:`c_symbol` instead, never
    rewritten.

    Parameters
    ----------
    name : str
        Any text.

    Returns
    -------
    str
        The identifier.
    """
    ident = re.sub(r"[^0-9a-zA-Z_]", "_", name).lower().strip("_") or "motor"
    return f"m_{ident}" if ident[0].isdigit() or ident in C_RESERVED_WORDS else ident


def c_name_problem(full: str, longest_suffix: int = 0) -> str | None:
    """What is wrong with ``full`` as the name of a generated C array or function, or None.

    The one rule of every C name linsense writes from a user's text: a C identifier (``A-Z a-z
    0-9 _``, not first a digit), not a keyword (C99 to C23, C++), not reserved (a name at file
    scope starting with ``_``; POSIX's type names ending in ``_t``), not a name of the C standard
    library or of linsense's C library (case aside: ``LS_LUT`` makes the guard ``LS_LUT_H`` of
    ls_lut.h), and short enough that the header's longest name built on it stays within the
    :data:`C_SIGNIFICANT_CHARS` characters C compilers must tell apart.

    Parameters
    ----------
    full : str
        The whole name (with any prefix the header puts before a user's part).
    longest_suffix : int, optional
        Characters the header's longest name adds to it (``_ANGLE_UNIT_RAD``: 15).

    Returns
    -------
    str or None
        Why it cannot be used, a phrase after the name ("is a C keyword"); None if it can.
    """
    if not _C_IDENTIFIER.fullmatch(full):
        bad = next((ch for ch in full if not (ch.isascii() and (ch.isalnum() or ch == "_"))), None)
        what = f"{bad!r} is not one of them" if bad is not None else \
            "it must not start with a digit" if full else "it is empty"
        return f"is not a C identifier (letters A-Z a-z, digits and _ only: {what})"
    if full in C_RESERVED_WORDS:
        return "is a keyword of C (or C++)"
    if full.startswith("_"):
        return "is reserved in C (a name at file scope starting with _)"
    if full.endswith("_t"):
        return "is reserved by POSIX for type names (a name ending in _t)"
    if full in C_LIBRARY_NAMES:
        return "is a name of the C standard library"
    if full.lower() in _ls_names():
        return "is a name of linsense's C library (ls_*.h)"
    if len(full) + longest_suffix > C_SIGNIFICANT_CHARS:
        return (f"is {len(full)} characters: with the {longest_suffix} the header adds, beyond the "
                f"{C_SIGNIFICANT_CHARS} C compilers must tell apart")
    return None


def _ls_names() -> frozenset[str]:
    """The names linsense's C library declares (functions, constants, types), lower-case."""
    from linsense.ctrl import ffi, lib

    return frozenset(n.lower() for n in [*dir(lib), *ffi.list_types()[0]])


def c_symbol(name: str, source: str, prefix: str = "", longest_suffix: int = 0) -> str:
    """A user's name for C (``lut --symbol``, ``tune --name``), checked: returned unchanged or refused.

    Never rewritten (``'my lut!'`` became ``my_lut`` and ``int`` became ``int_t`` without a word):
    the rule is :func:`c_name_problem`'s, on ``prefix + name``.

    Parameters
    ----------
    name : str
        The name given.
    source : str
        The option or argument it came from, for the message (``--symbol``).
    prefix : str, optional
        What the header puts before it (``ls_cfg_``).
    longest_suffix : int, optional
        Characters the header's longest name adds after it.

    Returns
    -------
    str
        ``name``.

    Raises
    ------
    linsense.errors.InputError
        Naming ``source``, the name and the rule it breaks.
    """
    why = c_name_problem(prefix + str(name), longest_suffix)
    if why is not None:
        shown_name = f"{name!r}" if not prefix else f"{name!r} (the C name {prefix + str(name)!r})"
        raise InputError(source, "", f"{shown_name} {why}: give another name")
    return name


#: characters the LUT header adds to its symbol in its longest name (``<SYMBOL>_ANGLE_UNIT_RAD``)
LUT_SUFFIX_CHARS = len("_ANGLE_UNIT_RAD")


def default_lut_symbol(motor_name: str, source: str, key: str = "") -> str:
    """The LUT header's array when no symbol is given: ``ls_lut_<motor name>``, the name made a C
    identifier (``ls_lut_motor`` when nothing of it is left), checked by :func:`c_name_problem`.

    Parameters
    ----------
    motor_name : str
        The motor's name.
    source : str
        Named in the message (the motor file).
    key : str, optional
        Its key (``motor.name``).

    Returns
    -------
    str
        The symbol.

    Raises
    ------
    linsense.errors.InputError
        The name makes one C cannot take (a motor named ``step`` makes ``ls_lut_step``, the C
        library's function): give the symbol.
    """
    sym = c_identifier(f"ls_lut_{motor_name}")
    sym = "ls_lut_motor" if sym == "ls_lut" else sym
    why = c_name_problem(sym, LUT_SUFFIX_CHARS)
    if why is not None:
        raise InputError(source, key, f"the C name made from the motor's name {motor_name!r}, {sym!r}, "
                                      f"{why}: give the symbol (--symbol)")
    return sym


def c_comment_text(text: str) -> str:
    """``text`` safe inside a C comment.

    A user's ``*/`` (a motor name) ended the comment and the rest was compiled as C; a ``/*`` is a
    -Wcomment warning.

    Parameters
    ----------
    text : str
        Any text.

    Returns
    -------
    str
        ``text`` with ``*/`` and ``/*`` split by a space.
    """
    return str(text).replace("*/", "* /").replace("/*", "/ *")


def _c_float(v: float) -> str:
    """A float literal that round-trips float32 exactly (9 significant digits)."""
    s = f"{float(np.float32(v)):.9g}"
    if "e" not in s and "." not in s:
        s += ".0"
    return s + "f"


def to_c_header(lut: Lut, symbol: str | None = None) -> str:
    """C99 header: ``static const float <symbol>[<SYMBOL>_LEN]`` in rad, with provenance.

    Stamped (:mod:`linsense.compensation.stamp`) with the linsense version and the SHA-256 of the
    motor data and table settings (:attr:`Lut.digest`; of the values and provenance for a table
    read from a file), as comment lines and the macros ``<SYMBOL>_LIB_VERSION`` and
    ``<SYMBOL>_DATA_SHA256``.

    Parameters
    ----------
    lut : Lut
        The table.
    symbol : str or None, optional
        The array's name, used as given (:func:`c_symbol` refuses a name C cannot take); default
        ``ls_lut_<motor name>`` (the motor name made a C identifier).

    Returns
    -------
    str
        The header's text.

    Raises
    ------
    linsense.errors.InputError
        A symbol (or the default made from the motor's name) C cannot take, naming the rule;
        ``lut`` not a :class:`Lut`, ``symbol`` neither None nor a str.
    """
    lut = _lut(lut, f"{_SRC}.to_c_header")
    if symbol is not None:
        instance(symbol, f"{_SRC}.to_c_header", "symbol", str, "None or a str")
    sym = c_symbol(symbol, "symbol", longest_suffix=LUT_SUFFIX_CHARS) if symbol is not None else \
        default_lut_symbol(lut.name, "symbol")
    up = sym.upper()
    # (a motor name is the user's text: "*/" in it ended the comment and the header did not compile,
    # "/*" in it is a -Wcomment warning)
    prov = "\n".join(c_comment_text(f" *   {k} = {shown(v)}")
                     for k, v in (lut.provenance or {"name": lut.name}).items())
    # (the data it was made from: the motor and the table's settings; a table read from a file: its
    # values and provenance)
    digest = lut.digest or data_digest(table=lut.values, provenance=lut.provenance or {})
    rows = []
    vals = [_c_float(v) for v in lut.values]
    for i in range(0, len(vals), 6):
        rows.append("    " + ", ".join(vals[i : i + 6]) + ",")
    return (
        f"/* Generated by linsense {__version__}: do not edit.\n"
        f" *\n"
        + (
            " * Compensation look-up table Psi_LUT(theta) over one electrical period, including the\n"
            " * winding resistance at the injection frequency (psi_lut_resistive in linsense).\n"
            if "f_inj" in (lut.provenance or {}) else
            " * Compensation look-up table Psi_LUT(theta) = atan(-L_dq/L_q) (Giangrande et al.,\n"
            " * IEEE ECCE 2010, eq. 12) over one electrical period.\n"
        ) +
        f" * Table: {lut.points} points at theta_k = 2*pi*k/{lut.points} rad (electrical),\n"
        f" * k = 0..{lut.points - 1}.\n"
        f" * Angle unit of the values: rad (electrical). Read with periodic linear interpolation\n"
        f" * (ls_lut_step in linsense/ls_lut.h).\n"
        f" * Motor:\n{prov}\n"
        + stamp_comment(digest, "the motor data and table settings" if lut.digest else "the table") +
        f" */\n"
        f"#ifndef {up}_H\n"
        f"#define {up}_H\n\n"
        f"#define {up}_LEN {lut.points}\n"
        f"#define {up}_ANGLE_UNIT_RAD 1\n"
        + stamp_macros(up, digest) + "\n"
        f"static const float {sym}[{up}_LEN] = {{\n" + "\n".join(rows) + "\n};\n\n"
        f"#endif /* {up}_H */\n"
    )


def export(lut: Lut, fmt: str, symbol: str | None = None) -> str:
    """Text of ``lut`` in ``fmt`` (``csv``, ``json`` or ``c``).

    Parameters
    ----------
    lut : Lut
        The table.
    fmt : {"csv", "json", "c"}
        The format.
    symbol : str or None, optional
        The C array's name (``c`` only).

    Returns
    -------
    str
        The text.

    Raises
    ------
    linsense.errors.InputError
        An unknown ``fmt`` (the closest named), ``lut`` not a :class:`Lut`.
    """
    fmt = choice(fmt, f"{_SRC}.export", "fmt", FORMATS, "format")
    if fmt == "csv":
        return to_csv(lut)
    if fmt == "json":
        return to_json(lut)
    return to_c_header(lut, symbol)


# ---------------------------------------------------------------------- readers
def _check_grid(theta: np.ndarray, src: str) -> None:
    n = theta.size
    if n < 4:
        raise InputError(src, "", f"a LUT needs at least 4 points, got {n}")
    expected = 2.0 * np.pi * np.arange(n) / n
    bad = np.nonzero(np.abs(theta - expected) > 1e-9 * 2 * np.pi + 1e-9)[0]
    if bad.size:
        raise InputError(src, f"row {bad[0] + 2}", "positions are not the equally spaced grid 2*pi*k/N")


def read_lut_csv(path: str | Path) -> Lut:
    """Read a LUT written by :func:`to_csv`.

    Parameters
    ----------
    path : str or Path
        The CSV file.

    Returns
    -------
    Lut
        The table, rad, named after the file.

    Raises
    ------
    linsense.errors.InputError
        A bad header, row or grid, naming the row.
    """
    src = str(path_arg(path, f"{_SRC}.read_lut_csv", "path", "a LUT's CSV file"))
    rows = csv_rows(path, "LUT")  # (bounded, BOM skipped: docs/limits.md)
    header = next(rows)[1]
    if header[:2] != ["theta_deg", "psi_lut_deg"]:
        raise InputError(src, "header", "expected columns theta_deg,psi_lut_deg")
    data = []
    for r, row in rows:
        check_width(src, r, row, header)
        try:
            vals = [float(row[0]), float(row[1])]
        except (ValueError, IndexError):
            raise InputError(src, f"row {r}", f"not two numbers: {row!r}") from None
        if not all(math.isfinite(v) for v in vals):
            raise InputError(src, f"row {r}", f"not finite: {row!r}")
        data.append(vals)
    arr = np.radians(np.array(data).reshape(-1, 2))
    _check_grid(arr[:, 0], src)
    return Lut(arr[:, 1], name=Path(src).stem)


def read_lut_json(path: str | Path) -> Lut:
    """Read a LUT written by :func:`to_json`.

    Parameters
    ----------
    path : str or Path
        The JSON file.

    Returns
    -------
    Lut
        The table, rad, with the file's motor provenance.

    Raises
    ------
    linsense.errors.InputError
        Not a linsense LUT, missing or non-finite arrays, a bad grid.
    """
    src = str(path_arg(path, f"{_SRC}.read_lut_json", "path", "a LUT's JSON file"))
    try:
        doc = json.loads(read_text_file(path, "LUT"))
    except ValueError as exc:  # (JSONDecodeError is a ValueError)
        raise InputError(src, "", f"cannot read the LUT: {exc}") from None
    if not isinstance(doc, dict) or doc.get("format") != "linsense-lut":
        got = doc.get("format") if isinstance(doc, dict) else type(doc).__name__
        raise InputError(src, "format", f"not a linsense LUT: {got!r}")
    arrays = {}
    for key in ("theta", "psi_lut"):
        try:
            arrays[key] = np.asarray(doc[key], dtype=float).reshape(-1)
        except (KeyError, TypeError, ValueError):
            got = str(doc.get(key))[:60]
            raise InputError(src, key, f"missing or not a list of numbers: {got!r}") from None
        if not np.all(np.isfinite(arrays[key])):
            raise InputError(src, key, "not finite")
    if arrays["theta"].size != arrays["psi_lut"].size:
        n_psi, n_theta = arrays["psi_lut"].size, arrays["theta"].size
        raise InputError(src, "psi_lut", f"{n_psi} values for {n_theta} positions")
    _check_grid(arrays["theta"], src)
    motor = doc.get("motor", {})
    motor = motor if isinstance(motor, dict) else {}
    return Lut(arrays["psi_lut"], name=str(motor.get("name", "motor")), provenance=motor)


def read_c_header(text: str) -> np.ndarray:
    """Values of the (single) float table in a header written by :func:`to_c_header`.

    Parameters
    ----------
    text : str
        The header's text.

    Returns
    -------
    ndarray
        The table's values, rad.

    Raises
    ------
    InputError
        When ``text`` holds no ``static const float NAME[LEN] = { ... };`` table of numbers.
    """
    instance(text, f"{_SRC}.read_c_header", "text", str, "the header's text (a str)")
    # (the table's own braces: a motor name with "{" in the provenance comment was read as the table)
    m = re.search(r"static const float \w+\[\w+\] = \{([^}]*)\};", text)
    try:
        if m is None:
            raise ValueError("no 'static const float NAME[LEN] = {...};' table")
        return np.array([float(tok.strip().rstrip("f")) for tok in m.group(1).split(",") if tok.strip()])
    except ValueError as exc:
        raise InputError("<C header>", "", f"not a LUT header of linsense: {exc}") from None


def read_lut(path: str | Path) -> Lut:
    """Read a LUT from CSV or JSON, by the file's suffix.

    Parameters
    ----------
    path : str or Path
        A ``.json`` file (:func:`read_lut_json`) or else a CSV (:func:`read_lut_csv`).

    Returns
    -------
    Lut
        The table.

    Raises
    ------
    linsense.errors.InputError
        As the reader.
    """
    p = path_arg(path, f"{_SRC}.read_lut", "path", "a LUT's CSV or JSON file")
    if p.suffix.lower() == ".json":
        return read_lut_json(p)
    return read_lut_csv(p)


