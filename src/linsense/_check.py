"""The arguments of the public Python API, checked in one place.

The command line refuses bad input with one line naming the file, the key and the value; the
Python API does the same through these helpers: every public function (``linsense.__all__``, the
subpackages' ``__all__``, the analysis, compensation and example functions the documentation
shows) passes its arguments through them before any work, and a wrong type, shape, NaN, None,
complex number, empty table or unknown name ends in one :class:`~linsense.errors.InputError`
whose source is the function, whose key is the argument, and whose message gives the value and
what is expected. It ended in a NaN, a silently dropped imaginary part, or Python's own
AttributeError, TypeError, IndexError or KeyError.

A motor argument is checked by :func:`linsense.model.motor.as_motor` (a layer above: it loads
presets), which uses these helpers.
"""

from __future__ import annotations

import difflib
import math
import numbers
import os
from pathlib import Path

import numpy as np

from linsense.errors import InputError, shown

#: characters of a value shown in a message before it is cut (one line: an array's repr has several)
_SHOWN_CHARS = 60


def brief(value) -> str:
    """A user's value on one short line, for a message.

    Parameters
    ----------
    value : object
        The value.

    Returns
    -------
    str
        ``repr`` (a numpy scalar as the plain number: :func:`~linsense.errors.shown`) on one line,
        cut to 60 characters.
    """
    r = " ".join(shown(value).split())
    return r if len(r) <= _SHOWN_CHARS else r[:_SHOWN_CHARS - 3] + "..."


def repr_line(value) -> str:
    """``repr`` of a user's value on one line (an array's has several), otherwise uncut.

    Parameters
    ----------
    value : object
        The value.

    Returns
    -------
    str
        ``repr(value)``, its runs of white space made one space when it holds a line break.
    """
    r = repr(value)
    return " ".join(r.split()) if "\n" in r else r


def closest_key(key: str, known) -> str:
    """A hint naming the known key (or name) closest to ``key``.

    Parameters
    ----------
    key : str
        The unknown key.
    known : iterable of str
        The known keys.

    Returns
    -------
    str
        `` (did you mean 'x'?)``, or an empty string when none is close.
    """
    known = list(known)
    if len(key) > 3 * max(map(len, known), default=0):
        return ""  # (no match can reach the cutoff 0.6; difflib took 6 s on a 50 MB key)
    match = difflib.get_close_matches(key, list(known), n=1, cutoff=0.6)
    if not match:
        lowered = {k.lower(): k for k in known}
        match = [lowered[key.lower()]] if key.lower() in lowered else []
    return f" (did you mean '{match[0]}'?)" if match else ""


def is_real(v) -> bool:
    """Whether ``v`` is one finite real number (not a boolean, complex, string, None or array).

    Parameters
    ----------
    v : object
        The value.

    Returns
    -------
    bool
        True for a finite int or float (numpy's included).
    """
    if not isinstance(v, numbers.Real) or isinstance(v, bool | np.bool_):
        return False
    try:
        return math.isfinite(v)
    except OverflowError:  # (an int beyond a float: 10**400)
        return False


def real(v, source: str, name: str, low: float = -math.inf, high: float = math.inf, *,
         low_open: bool = False, high_open: bool = False, what: str = "a finite real number",
         kind: str | None = None) -> float:
    """``v`` as a float if it is a real, finite number within ``low`` .. ``high``.

    Not a boolean, complex, string, None or array; open ends where asked.

    Parameters
    ----------
    v : object
        The argument.
    source : str
        Where it was given (the function), for the message.
    name : str
        The argument's name, for the message.
    low, high : float, optional
        The range (infinite by default).
    low_open, high_open : bool, optional
        Whether ``low`` / ``high`` themselves are refused.
    what : str, optional
        What the argument must be, for the message.
    kind : str or None, optional
        Its kind of quantity (:data:`linsense.plausible.KINDS`): a refused number gets the slip of
        unit that brings it within the range ("did you type kHz?").

    Returns
    -------
    float
        ``float(v)``.

    Raises
    ------
    linsense.errors.InputError
        Naming ``source``, ``name``, the range and the value.
    """
    ok = is_real(v)
    if ok:
        ok = (v > low if low_open else v >= low) and (v < high if high_open else v <= high)
    if not ok:
        lo = "" if low == -math.inf else f"{'(' if low_open else '['}{low:g}"
        hi = "" if high == math.inf else f"{high:g}{')' if high_open else ']'}"
        rng = f" in {lo or '(-inf'}, {hi or 'inf)'}" if lo or hi else ""
        hint = ""
        if kind is not None and is_real(v):
            from linsense.plausible import slip

            def inside(x: float) -> bool:
                return (x > low if low_open else x >= low) and (x < high if high_open else x <= high)

            hint = slip(kind, float(v), ok=inside)
        raise InputError(source, name, f"must be {what}{rng}, got {brief(v)}" + (f"; {hint}" if hint else ""))
    return float(v)


def integer(v, source: str, name: str, low: int, high: int | None = None, what: str = "an integer") -> int:
    """``v`` as an int if it is an integer (not a boolean, not a float) in ``low`` .. ``high``.

    Parameters
    ----------
    v : object
        The argument.
    source : str
        Where it was given (the function), for the message.
    name : str
        The argument's name, for the message.
    low : int
        The smallest allowed.
    high : int or None, optional
        The largest allowed (None: no limit).
    what : str, optional
        What the argument is, for the message.

    Returns
    -------
    int
        ``int(v)``.

    Raises
    ------
    linsense.errors.InputError
        Naming ``source``, ``name``, the range and the value.
    """
    if isinstance(v, bool | np.bool_) or not isinstance(v, numbers.Integral) or not (
            low <= v and (high is None or v <= high)):
        rng = f"{low:,} .. {high:,} (docs/limits.md)" if high is not None else f"at least {low:,}"
        raise InputError(source, name, f"must be {what} in {rng}, got {brief(v)}")
    return int(v)


def reals(v, source: str, name: str, what: str = "real numbers", *, ndim: int | None = None,
          min_size: int = 0, finite: bool = True, bound: float | None = None) -> np.ndarray:
    """``v`` as a float64 array if it is real numbers (a number, a sequence or an array of them).

    Refused: None, strings, booleans, complex numbers (their imaginary part was dropped without a
    word), dicts and other objects, ragged sequences, NaN and infinities (unless ``finite`` is
    False), fewer than ``min_size`` values, another number of dimensions than ``ndim``.

    Parameters
    ----------
    v : object
        The argument.
    source : str
        Where it was given (the function), for the message.
    name : str
        The argument's name, for the message.
    what : str, optional
        What the values are (their unit), for the message.
    ndim : int or None, optional
        The number of dimensions required (None: any; a number is 0).
    min_size : int, optional
        The fewest values.
    finite : bool, optional
        Whether NaN and infinities are refused.
    bound : float or None, optional
        The largest magnitude allowed (None: any).

    Returns
    -------
    ndarray of float64
        The values.

    Raises
    ------
    linsense.errors.InputError
        Naming ``source``, ``name``, what is expected and the value.
    """
    expected = f"{'finite ' if finite else ''}{what}"
    if v is None or isinstance(v, str | bytes | dict | set | frozenset):
        raise InputError(source, name, f"expected {expected}, got {brief(v)}")
    try:
        a = np.asarray(v)
    except (TypeError, ValueError, OverflowError) as exc:  # (ragged sequences, huge ints)
        raise InputError(source, name, f"expected {expected}, got {brief(v)} ({exc})") from None
    if a.dtype.kind not in "iuf":
        kind = {"b": "booleans", "c": "complex numbers", "U": "strings", "S": "bytes",
                "O": "objects"}.get(a.dtype.kind, f"dtype {a.dtype}")
        raise InputError(source, name, f"expected {expected}, got {kind}: {brief(v)}")
    if ndim is not None and a.ndim != ndim:
        shape = "one number" if ndim == 0 else f"{ndim} dimension{'s' if ndim > 1 else ''}"
        raise InputError(source, name, f"expected {shape} of {expected}, got shape {a.shape}")
    if a.size < min_size:
        raise InputError(source, name, f"expected at least {min_size} {expected}, got {a.size}")
    a = a.astype(np.float64)
    if finite and not np.all(np.isfinite(a)):
        k = np.unravel_index(int(np.flatnonzero(~np.isfinite(a))[0]), a.shape)
        at = f"[{', '.join(map(str, k))}]" if a.ndim else ""
        raise InputError(source, f"{name}{at}", f"expected {expected}, got {float(a[k])!r}")
    if bound is not None and a.size and float(np.max(np.abs(a))) > bound:
        k = np.unravel_index(int(np.argmax(np.abs(a))), a.shape)
        at = f"[{', '.join(map(str, k))}]" if a.ndim else ""
        raise InputError(source, f"{name}{at}", f"{float(a[k])!r} is beyond the range of {what}, "
                         f"+-{bound:.6g} (docs/limits.md)")
    return a


def choice(v, source: str, name: str, known, what: str = "") -> str:
    """``v`` if it is one of the strings ``known``, else InputError naming the closest.

    Parameters
    ----------
    v : object
        The argument.
    source : str
        Where it was given (the function), for the message.
    name : str
        The argument's name, for the message.
    known : iterable of str
        The allowed values.
    what : str, optional
        What the argument names, for the message (e.g. "kind of example").

    Returns
    -------
    str
        ``v``.

    Raises
    ------
    linsense.errors.InputError
        Naming ``source``, ``name``, the allowed values, the closest and the value.
    """
    known = tuple(known)
    if isinstance(v, str) and v in known:
        return v
    hint = closest_key(v, known) if isinstance(v, str) else ""
    label = f"{what} " if what else ""
    raise InputError(source, name, f"unknown {label}{brief(v)}{hint}: one of {', '.join(known)}")


def path_arg(v, source: str, name: str, what: str = "a path") -> Path:
    """``v`` as a Path if it is a non-empty ``str`` or ``os.PathLike`` without a NUL character.

    Parameters
    ----------
    v : object
        The argument.
    source : str
        Where it was given (the function), for the message.
    name : str
        The argument's name, for the message.
    what : str, optional
        What the path is, for the message.

    Returns
    -------
    Path
        The path.

    Raises
    ------
    linsense.errors.InputError
        Naming ``source``, ``name`` and the value.
    """
    if isinstance(v, os.PathLike):
        v = os.fspath(v)
    if not isinstance(v, str) or not v.strip() or "\0" in v:
        raise InputError(source, name, f"expected {what} (a str or os.PathLike), got {brief(v)}")
    return Path(v)


def instance(v, source: str, name: str, cls: type | tuple[type, ...], what: str):
    """``v`` if it is an instance of ``cls``, else InputError naming what is expected.

    Parameters
    ----------
    v : object
        The argument.
    source : str
        Where it was given (the function), for the message.
    name : str
        The argument's name, for the message.
    cls : type or tuple of type
        The accepted type(s).
    what : str
        What is expected, for the message.

    Returns
    -------
    object
        ``v``.

    Raises
    ------
    linsense.errors.InputError
        Naming ``source``, ``name``, what is expected and the value's type.
    """
    if not isinstance(v, cls):
        raise InputError(source, name, f"expected {what}, got {brief(v)} ({type(v).__name__})")
    return v
