"""The stamp of a generated C header: the linsense version that wrote it and a digest of its data.

Every header linsense generates for the firmware (the LUT of ``linsense lut --format c``, the drive
configuration ``ls_cfg_<name>.h`` of ``linsense tune --format c`` and ``linsense firmware export``)
states the version of linsense that wrote it and the SHA-256 of the motor and drive data it was
made from, as comment lines and as macros (``<PREFIX>_LIB_VERSION``, ``<PREFIX>_DATA_SHA256``).
The configuration header also sets ``ls_drive_cfg.lib_version``, which ``ls_drive_init`` compares
with the library's ``LS_VERSION`` (a header of another version is refused: ``LS_ERR_VERSION``).

The digest is over the data's values, not over a file: the same motor gives the same digest from a
preset, a copied file or a path elsewhere (the motor's ``source`` and its table's file name are
left out); any changed number, table entry or drive setting gives another.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math

import numpy as np

from linsense.version import __version__

#: fields that name where data came from, not what it is (left out of the digest)
_WHERE = frozenset({"source", "description"})


def canonical(obj: object) -> object:
    """A JSON-serialisable form of ``obj`` in which every number is exact.

    Floats are written as their hexadecimal form (``float.hex``: bit-exact, no rounding), arrays as
    their shape and values, dataclasses as their fields without those that name a source (``source``,
    ``description``), mappings with sorted string keys.

    Parameters
    ----------
    obj : object
        Numbers, strings, None, booleans, sequences, mappings, numpy arrays and dataclasses of them.

    Returns
    -------
    object
        Nested lists, dicts and strings.

    Raises
    ------
    TypeError
        For a value of another kind.
    """
    if obj is None or isinstance(obj, (bool, str)):
        return obj
    if isinstance(obj, (int, np.integer)) and not isinstance(obj, bool):
        return int(obj)
    if isinstance(obj, (float, np.floating)):
        x = float(obj)
        return x.hex() if math.isfinite(x) else repr(x)
    if isinstance(obj, np.ndarray):
        return {"shape": list(obj.shape), "values": [canonical(v) for v in obj.astype(float).ravel()]}
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return {f.name: canonical(getattr(obj, f.name)) for f in dataclasses.fields(obj)
                if f.name not in _WHERE}
    if isinstance(obj, dict):
        return {str(k): canonical(v) for k, v in sorted(obj.items(), key=lambda kv: str(kv[0]))}
    if isinstance(obj, (list, tuple)):
        return [canonical(v) for v in obj]
    raise TypeError(f"no canonical form for {type(obj).__name__}")


def data_digest(**parts: object) -> str:
    """SHA-256 of the canonical JSON of ``parts`` (:func:`canonical`).

    Parameters
    ----------
    **parts : object
        The named data, e.g. ``motor=motor, drive=drive_data``.

    Returns
    -------
    str
        64 hexadecimal digits.
    """
    text = json.dumps(canonical(parts), sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()


def version_number(version: str = __version__) -> int:
    """The C library's ``LS_VERSION`` of a version string: ``0xMMmmpp``.

    Parameters
    ----------
    version : str, optional
        ``"major.minor.patch"`` (default linsense's own).

    Returns
    -------
    int
        ``major << 16 | minor << 8 | patch``.

    Raises
    ------
    ValueError
        For a version that is not three numbers below 256.
    """
    parts = version.split(".")
    if len(parts) != 3 or not all(p.isdigit() and int(p) < 256 for p in parts):
        raise ValueError(f"not a major.minor.patch version of numbers below 256: {version!r}")
    major, minor, patch = (int(p) for p in parts)
    return (major << 16) | (minor << 8) | patch


def stamp_comment(digest: str, what: str = "the motor and drive data") -> str:
    """The stamp's comment lines (each begins with `` * ``, inside a ``/* ... */`` block).

    Parameters
    ----------
    digest : str
        The data's digest (:func:`data_digest`).
    what : str, optional
        What the digest is over.

    Returns
    -------
    str
        Two lines, each ending with a newline.
    """
    return (f" * linsense {__version__} (LS_VERSION 0x{version_number():06x}); sha256 of {what} it was\n"
            f" * made from: {digest}\n")


def stamp_macros(prefix: str, digest: str) -> str:
    """The stamp as macros: ``<prefix>_LIB_VERSION`` (``0xMMmmpp``) and ``<prefix>_DATA_SHA256``.

    Parameters
    ----------
    prefix : str
        The macros' prefix (an upper-case C identifier, e.g. ``LS_CFG_ECCE2010``).
    digest : str
        The data's digest.

    Returns
    -------
    str
        Two ``#define`` lines, each ending with a newline.
    """
    return (f"#define {prefix}_LIB_VERSION 0x{version_number():06x}u /* linsense {__version__} */\n"
            f"#define {prefix}_DATA_SHA256 \"{digest}\"\n")
