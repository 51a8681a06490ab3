"""Measured compensation tables: the stamped JSON ``linsense calibrate`` writes, which the simulator
reads (``observer.lut_model = "measured"``, ``observer.lut_file``).

A measured table is only valid on the drive it was measured for: the motor data the drive believes
in (its model motor, which computes the drive's other tables and gains), the injection's shape, its
frequency (the table depends on it through R_s) and its q-axis share kappa. The file carries these
as a stamp (:class:`TableStamp`); :func:`read_measured_table` compares the stamp with the drive that
reads it and refuses a table of another drive. Its point count may differ from the drive's: it is
then resampled with the firmware's periodic linear interpolation
(:func:`linsense.compensation.lut.interpolate`), which is how the drive would read the measured
points anyway.

The document (format ``linsense-measured-lut``; written by :func:`measured_table_json`, sorted
keys, so that the same table gives the same bytes)::

    {"format": "linsense-measured-lut", "unit": "rad",
     "stamp": {"motor_sha256": "...", "motor": "ecce2010", "injection": "pulsating",
               "f_inj": 1000.0, "quad": 0.9, "points": 56},
     "theta": [0.0, 0.1121997..., ...], "psi_lut": [...], "metrics": {...}}

``theta`` is the grid ``2 pi k / N`` (rad, ``k = 0 .. N-1``), ``psi_lut`` the table (rad, electrical).
Besides these five keys only the informational keys :data:`INFO_KEYS` may appear (``metrics``: the
calibration's, ``comment``: free text); they are read past unchecked. Any other top-level key, and
any stamp key other than the six, is refused: a key the reader does not know is not silently
ignored (a hand-written ``"unit_theta": "deg"`` would otherwise change nothing).
"""

from __future__ import annotations

import json
import math
import numbers
import os
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np

from linsense._check import choice, real, reals
from linsense.compensation.lut import INJECTIONS, interpolate
from linsense.compensation.stamp import data_digest
from linsense.errors import InputError, shown
from linsense.model.motor import as_motor

__all__ = ["FORMAT", "INFO_KEYS", "INJECTIONS", "PSI_MAX", "MeasuredTable", "TableStamp", "end_effect_fit",
           "fit_report", "interpolation_error", "measured_table_json", "read_measured_table",
           "resolution_warning", "table_stamp"]

#: the document's ``format``
FORMAT = "linsense-measured-lut"
#: the keys every document holds
CORE_KEYS = ("format", "unit", "stamp", "theta", "psi_lut")
#: informational top-level keys, written by :func:`measured_table_json` through ``extra`` and read
#: past without a check (``metrics``: the calibration's; ``comment``: free text)
INFO_KEYS = ("metrics", "comment")
#: the stamp's keys (:class:`TableStamp`'s fields)
STAMP_KEYS = ("motor_sha256", "motor", "injection", "f_inj", "quad", "points")
#: the largest compensation angle a table can hold, rad: 45 electrical degrees. The demodulated
#: error goes as ``sin 2 (e - Psi)`` (docs/theory.md, section 6: of its two roots per half turn the
#: stable one is within 45 deg of zero); beyond 45 deg its slope changes sign, the observer would
#: settle on the other root, so such a value cannot be a compensation table (the model tables of
#: every motor linsense ships stay below 24 deg)
PSI_MAX = math.pi / 4.0
#: relative difference of the injection frequency beyond which a stamp is another drive's
F_INJ_RTOL = 1e-6
#: difference of kappa beyond which a stamp is another drive's
QUAD_ATOL = 1e-9
#: digits of a digest shown in messages
_DIGEST_SHOWN = 12


#: tolerance of a grid position, rad (as :func:`linsense.compensation.lut.read_lut_json`)
GRID_TOL = 1e-9 * 2.0 * math.pi + 1e-9


@dataclass(frozen=True)
class TableStamp:
    """What a measured table is valid for: the drive it was measured on.

    Attributes
    ----------
    motor_sha256 : str
        :func:`linsense.compensation.stamp.data_digest` ``(motor=motor)`` of the motor the drive
        believes in (its model motor, ``controller.model.motor`` or the scenario's motor, as loaded),
        not of the plant it ran on.
    motor : str
        That motor's name.
    injection : str
        The injection's shape, ``"pulsating"``, ``"rotating"`` or ``"square"``.
    f_inj : float
        The injection frequency the drive ran, Hz (the square wave: ``f_pwm / 2``).
    quad : float
        The injection's q-axis share kappa (0 for the rotating vector and the square wave).
    points : int
        The table's number of points.
    """

    motor_sha256: str
    motor: str
    injection: str
    f_inj: float
    quad: float
    points: int

    def as_dict(self) -> dict:
        """The stamp as the document writes it.

        Returns
        -------
        dict
            ``motor_sha256``, ``motor``, ``injection``, ``f_inj`` (Hz), ``quad``, ``points``.
        """
        return asdict(self)


def table_stamp(motor, injection: str, f_inj: float, quad: float, points: int) -> TableStamp:
    """The stamp of a table measured on a drive believing in ``motor``.

    Parameters
    ----------
    motor : Motor
        The motor the drive believes in (its model motor, as loaded: before any
        ``controller.model`` override of single values).
    injection : {"pulsating", "rotating", "square"}
        The injection's shape.
    f_inj : float
        The injection frequency the drive runs, Hz (the square wave: ``f_pwm / 2``).
    quad : float
        Kappa, in [0, 1).
    points : int
        The table's number of points, at least 4.

    Returns
    -------
    TableStamp
        The stamp.

    Raises
    ------
    linsense.errors.InputError
        An argument out of range (naming it).
    """
    src = "linsense.compensation.measured.table_stamp"
    injection, f_inj, quad, points = _drive_args(src, motor, injection, f_inj, quad, points)
    return TableStamp(data_digest(motor=motor), str(motor.name), injection, f_inj, quad, points)


def _drive_args(src: str, motor, injection, f_inj, quad, points) -> tuple[str, float, float, int]:
    """The drive's values checked: (injection, f_inj, quad, points)."""
    from linsense._check import real as real_arg
    from linsense.limits import MAX_F_INJ, MAX_POINTS, MIN_F_INJ
    from linsense.model.motor import Motor

    if not isinstance(motor, Motor):
        raise InputError(src, "motor", f"expected a Motor, got {type(motor).__name__}")
    if injection not in INJECTIONS:
        raise InputError(src, "injection", f"must be one of {', '.join(map(repr, INJECTIONS))}, "
                         f"got {shown(injection)}")
    f_inj = real_arg(f_inj, src, "f_inj", MIN_F_INJ, MAX_F_INJ, what="a frequency in Hz")
    quad = real_arg(quad, src, "quad", 0.0, 1.0, high_open=True, what="a number")
    if isinstance(points, bool) or not isinstance(points, numbers.Integral) or not 4 <= points <= MAX_POINTS:
        raise InputError(src, "points", f"must be an integer in 4 .. {MAX_POINTS:,}, got {shown(points)}")
    return injection, f_inj, quad, int(points)


def measured_table_json(psi: np.ndarray, stamp: TableStamp, extra: dict | None = None) -> str:
    """The stamped JSON document of a measured table.

    Sorted keys and exact floats (``repr``): the same table and stamp give the same bytes, and
    :func:`read_measured_table` reads back the same values bit for bit.

    Parameters
    ----------
    psi : ndarray, shape (N,)
        The table at ``theta_k = 2 pi k / N``, rad; ``N`` must be ``stamp.points``.
    stamp : TableStamp
        The drive it was measured on (:func:`table_stamp`).
    extra : dict or None, optional
        Informational top-level keys, among :data:`INFO_KEYS` (e.g. ``{"metrics": {...}}``), of JSON
        values.

    Returns
    -------
    str
        The document, ending with a newline.

    Raises
    ------
    linsense.errors.InputError
        A table the reader would refuse (not finite, fewer than 4 points, beyond 45 deg, its length
        not ``stamp.points``), an ``extra`` key outside :data:`INFO_KEYS` or a value that is not JSON.
    """
    src = "linsense.compensation.measured.measured_table_json"
    if not isinstance(stamp, TableStamp):
        raise InputError(src, "stamp", f"expected a TableStamp, got {type(stamp).__name__}")
    v = np.asarray(psi, dtype=float)
    if v.ndim != 1 or v.size < 4:
        raise InputError(src, "psi", f"a table is a list of at least 4 values, got shape {v.shape}")
    if v.size != stamp.points:
        raise InputError(src, "psi", f"{v.size} values for a stamp of {stamp.points} points")
    bad = np.nonzero(~np.isfinite(v))[0]
    if bad.size:
        raise InputError(src, f"psi[{bad[0]}]", f"not finite: {shown(v[bad[0]])}")
    _check_psi(src, v, "psi")
    extra = dict(extra or {})
    unknown = sorted(set(extra) - set(INFO_KEYS), key=str)
    if unknown:
        raise InputError(src, "extra", f"{shown(unknown[0])} is not an informational key of a measured "
                         f"table (one of {', '.join(INFO_KEYS)}): the reader refuses keys it does not know")
    n = v.size
    doc = {"format": FORMAT, "unit": "rad", "stamp": stamp.as_dict(),
           "theta": [2.0 * math.pi * k / n for k in range(n)], "psi_lut": [float(x) for x in v], **extra}
    try:
        return json.dumps(doc, sort_keys=True, indent=1, allow_nan=False) + "\n"
    except (TypeError, ValueError) as exc:
        raise InputError(src, "extra", f"not JSON values: {exc}") from None


@dataclass(frozen=True, eq=False)
class MeasuredTable:
    """A measured table as a drive reads it (:func:`read_measured_table`).

    Attributes
    ----------
    values : ndarray
        The table at the drive's ``points`` positions ``2 pi k / points``, rad (read-only).
    stamp : TableStamp
        The file's stamp (its ``points`` is the file's count).
    resampled : bool
        Whether the file's table had another number of points.
    note : str
        One line saying what was done to the file's table ("" when it is used as it is).
    source : str
        The file's path.
    raw : ndarray or None
        The file's own table at its ``stamp.points`` positions, rad (read-only; what
        :func:`fit_report` judges).
    """

    values: np.ndarray
    stamp: TableStamp
    resampled: bool
    note: str
    source: str
    raw: np.ndarray | None = None


def read_measured_table(path: str | os.PathLike, *, motor, injection: str, f_inj: float, quad: float,
                        points: int, via: tuple[str, str, str] | None = None) -> MeasuredTable:
    """Read a stamped measured table for a drive, checking that it is this drive's.

    The checks, each refused in one :class:`~linsense.errors.InputError` naming the file and the key
    (or the row, as ``psi_lut[12]``): a missing, empty or unreadable file, not JSON, another format;
    a key the format does not have; a stamp missing a key or with a value of the wrong kind; missing
    or non-numeric arrays, a non-finite value (the first bad row), arrays of different lengths,
    fewer than 4 points; positions that are not the equally spaced grid ``2 pi k / N`` over the
    whole period (the first bad row; positions beyond 2 pi: "looks like degrees"); a value beyond
    +-45 electrical deg (:data:`PSI_MAX`; "degrees written as radians?" where it would be a
    plausible angle in degrees); a stamp of another drive: another motor (by its data's digest:
    the message names both motors and the first 12 hex digits of both digests), injection shape,
    frequency (beyond :data:`F_INJ_RTOL` relative) or kappa (beyond :data:`QUAD_ATOL`).

    A table of another number of points is not refused: it is resampled to ``points`` with the
    firmware's periodic linear interpolation (:func:`linsense.compensation.lut.interpolate`), and
    :attr:`MeasuredTable.note` says so.

    Parameters
    ----------
    path : str or os.PathLike
        The JSON file (``lut_measured.json`` of ``linsense calibrate``).
    motor : Motor
        The motor the drive believes in, as loaded (its model motor, before a ``controller.model``
        override of single values).
    injection : {"pulsating", "rotating", "square"}
        The drive's injection shape.
    f_inj : float
        The injection frequency the drive runs, Hz (the square wave: ``f_pwm / 2``).
    quad : float
        The drive's kappa.
    points : int
        The table length the drive wants.
    via : tuple of str or None, optional
        ``(file, key, value)`` where the table was named, when not on the command line: a scenario's
        ``observer.lut_file`` and the value as written there. A refusal of the table is then said as
        that key's (``s.toml: observer.lut_file: 't.json': t.json: stamp.motor_sha256: ...``), so that
        the message names the file of the chain that brought the table, whichever command reads it.

    Returns
    -------
    MeasuredTable
        The table at ``points`` positions, rad, with the file's stamp.

    Raises
    ------
    linsense.errors.InputError
        As above; or a drive argument out of range (naming the function and the argument).
    """
    injection, f_inj, quad, points = _drive_args("linsense.compensation.measured.read_measured_table",
                                                 motor, injection, f_inj, quad, points)
    src = os.fspath(path) if isinstance(path, os.PathLike) else str(path)
    if via is None:
        return _read_measured(src, motor, injection, f_inj, quad, points)
    try:
        return _read_measured(src, motor, injection, f_inj, quad, points)
    except InputError as exc:
        where, key, value = via
        raise InputError(where, key, f"{value!r}: {exc}") from None


def _read_measured(src: str, motor, injection: str, f_inj: float, quad: float, points: int) -> MeasuredTable:
    """:func:`read_measured_table` of the checked drive arguments."""
    from linsense.io import read_text_file
    from linsense.limits import MAX_POINTS

    doc = _document(src, read_text_file(Path(src), "measured table"))
    stamp = _stamp(src, doc.get("stamp"))
    theta = _numbers(src, doc, "theta")
    psi = _numbers(src, doc, "psi_lut")
    n = psi.size
    if theta.size != n:
        raise InputError(src, "psi_lut", f"{n} values for {theta.size} positions (theta)")
    if n < 4:
        raise InputError(src, "psi_lut", f"a table needs at least 4 points, got {n}")
    if n > MAX_POINTS:
        raise InputError(src, "psi_lut", f"{n:,} points, beyond the limit of {MAX_POINTS:,} (docs/limits.md)")
    if stamp.points != n:
        raise InputError(src, "stamp.points", f"{stamp.points} but the file holds {n} values")
    _check_grid(src, theta)
    _check_psi(src, psi, "psi_lut")
    _check_stamp(src, stamp, motor, injection, f_inj, quad)
    if n == points:
        values, note = psi, ""
    else:
        values = interpolate(psi, 2.0 * np.pi * np.arange(points) / points)
        note = (f"{n}-point table resampled to {points} points with the firmware's periodic linear "
                "interpolation")
    values = np.array(values, dtype=float)
    values.setflags(write=False)
    psi.setflags(write=False)
    return MeasuredTable(values, stamp, n != points, note, src, psi)


# ---------------------------------------------------------------------- the reader's checks
class _Twice(Exception):
    """A key given twice in one JSON object."""

    def __init__(self, key: str) -> None:
        super().__init__(key)
        self.key = key


def _once(pairs: list) -> dict:
    """A JSON object's pairs as a dict, each key once (json's own keeps the last silently)."""
    out = {}
    for k, v in pairs:
        if k in out:
            raise _Twice(str(k))
        out[k] = v
    return out


def _document(src: str, text: str) -> dict:
    """The parsed document, its format, unit and top-level keys checked."""
    if not text.strip():
        raise InputError(src, "", "empty file: expected a measured table (the stamped lut_measured.json "
                         "linsense calibrate writes)")
    try:
        doc = json.loads(text.removeprefix("\ufeff"), object_pairs_hook=_once)  # (a BOM skipped)
    except _Twice as exc:
        why = "given twice (a key once per JSON object: which would count?)"
        raise InputError(src, exc.key, why) from None
    except (ValueError, RecursionError) as exc:  # (JSONDecodeError is a ValueError)
        head = text.lstrip("\ufeff").lstrip()[:12].lower()
        csv = head.startswith("theta_deg")
        hint = (": a CSV table (theta_deg,psi_lut_deg) has no stamp (the drive it is valid for); give the "
                "stamped lut_measured.json that linsense calibrate writes (beside its lut_measured.csv)"
                if csv else " (expected the stamped lut_measured.json linsense calibrate writes)")
        what = "nested too deeply" if isinstance(exc, RecursionError) else str(exc)
        raise InputError(src, "", f"not JSON: {what}{hint}") from None
    if not isinstance(doc, dict):
        raise InputError(src, "", f"not a measured table: a JSON {type(doc).__name__}, expected an object "
                         f"with format {FORMAT!r}")
    fmt = doc.get("format")
    if fmt != FORMAT:
        hint = (": a model table (linsense lut --format json) has no stamp, and a drive computes the model's "
                "table itself: give no measured table (no --table; in a scenario observer.lut_model = "
                "\"resistive\")") if fmt == "linsense-lut" else \
            " (the stamped lut_measured.json linsense calibrate writes)"
        got = "missing" if "format" not in doc else shown(fmt)
        raise InputError(src, "format", f"not a linsense measured table: {got}, expected {FORMAT!r}{hint}")
    unit = doc.get("unit")
    if unit != "rad":
        got = "missing" if "unit" not in doc else shown(unit)
        raise InputError(src, "unit", f"must be 'rad' (the table's angles, electrical), got {got}")
    unknown = [k for k in doc if k not in CORE_KEYS and k not in INFO_KEYS]
    if unknown:
        from linsense._check import closest_key

        key = str(unknown[0])
        raise InputError(src, key, f"not a key of a measured table{closest_key(key, CORE_KEYS + INFO_KEYS)} "
                         f"(known: {', '.join(CORE_KEYS + INFO_KEYS)})")
    return doc


def _stamp(src: str, raw) -> TableStamp:
    """The file's stamp, each key present and of its kind."""
    if not isinstance(raw, dict):
        got = "missing" if raw is None else f"a {type(raw).__name__}"
        raise InputError(src, "stamp", f"{got}, expected an object with {', '.join(STAMP_KEYS)} (the "
                         "drive the table was measured on)")
    for k in raw:
        if k not in STAMP_KEYS:
            from linsense._check import closest_key

            raise InputError(src, f"stamp.{k}", f"not a stamp key{closest_key(str(k), STAMP_KEYS)} "
                             f"(known: {', '.join(STAMP_KEYS)})")
    missing = [k for k in STAMP_KEYS if k not in raw]
    if missing:
        raise InputError(src, f"stamp.{missing[0]}", "missing (the stamp says which drive the table is for)")
    sha, name, inj = raw["motor_sha256"], raw["motor"], raw["injection"]
    if not (isinstance(sha, str) and len(sha) == 64 and all(c in "0123456789abcdef" for c in sha)):
        raise InputError(src, "stamp.motor_sha256", f"expected 64 lower-case hex digits, got {shown(sha)}")
    if not isinstance(name, str):
        raise InputError(src, "stamp.motor", f"expected the motor's name, got {shown(name)}")
    if inj not in INJECTIONS:
        raise InputError(src, "stamp.injection", f"must be one of {', '.join(map(repr, INJECTIONS))}, "
                         f"got {shown(inj)}")
    vals = {}
    for k, ok, what in (("f_inj", lambda x: x > 0.0, "a frequency above 0 Hz"),
                        ("quad", lambda x: 0.0 <= x < 1.0, "kappa in [0, 1)")):
        x = _finite(raw[k])
        if x is None or not ok(x):
            raise InputError(src, f"stamp.{k}", f"expected {what}, got {shown(raw[k])}")
        vals[k] = x
    pts = raw["points"]
    if isinstance(pts, bool) or not isinstance(pts, int) or pts < 4:
        raise InputError(src, "stamp.points", f"expected an integer of at least 4, got {shown(pts)}")
    return TableStamp(sha, name, inj, vals["f_inj"], vals["quad"], pts)


def _is_number(x) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool)


def _finite(x) -> float | None:
    """``float(x)`` of a JSON number if it is finite (an integer beyond the float range is not),
    else None."""
    if not _is_number(x):
        return None
    try:
        v = float(x)
    except OverflowError:
        return None
    return v if math.isfinite(v) else None


def _numbers(src: str, doc: dict, key: str) -> np.ndarray:
    """The array ``doc[key]``, every row a finite number (the first bad row named)."""
    raw = doc.get(key)
    if not isinstance(raw, list):
        got = "missing" if key not in doc else f"a {type(raw).__name__}"
        raise InputError(src, key, f"{got}, expected a list of numbers (rad)")
    out = np.empty(len(raw))
    for i, x in enumerate(raw):
        if not _is_number(x):
            raise InputError(src, f"{key}[{i}]", f"not a number: {shown(x)}")
        v = _finite(x)
        if v is None:
            raise InputError(src, f"{key}[{i}]", f"not finite: {shown(x)}")
        out[i] = v
    return out


def _check_grid(src: str, theta: np.ndarray) -> None:
    """Refuse positions that are not ``2 pi k / N`` over the whole period, naming the first bad row."""
    n = theta.size
    two_pi = 2.0 * math.pi
    tol = GRID_TOL
    beyond = np.nonzero(theta > two_pi + tol)[0]
    if beyond.size:
        i = int(beyond[0])
        in_deg = np.all(np.abs(theta - 360.0 * np.arange(n) / n) <= 1e-6 * 360.0)
        grid = " (the file's grid is 360 k / N)" if in_deg else ""
        raise InputError(src, f"theta[{i}]", f"{theta[i]:.9g} is beyond 2 pi rad, the period: looks like "
                         f"degrees{grid}; the positions are in rad, theta_k = 2 pi k / N")
    expected = two_pi * np.arange(n) / n
    bad = np.nonzero(np.abs(theta - expected) > tol)[0]
    if not bad.size:
        return
    i = int(bad[0])
    why = ("a table's positions are the equally spaced grid over one whole period, theta_k = 2 pi k / N "
           f"for k = 0 .. N-1 (N = {n} rows)")
    step = theta[1] - theta[0] if n > 1 else 0.0
    m = round(two_pi / step) if step > 0 else 0
    if m and np.all(np.abs(theta - two_pi * np.arange(n) / m) <= tol):
        if m == n - 1:
            why = f"the last row repeats the first at 2 pi: leave it out ({why})"
        elif m > n:
            why = (f"the grid 2 pi k / {m} with only {n} of its {m} rows: the table does not cover the "
                   f"whole period ({why})")
    raise InputError(src, f"theta[{i}]", f"{theta[i]:.9g} is not 2 pi k / N = {expected[i]:.9g}: {why}")


def _check_psi(src: str, psi: np.ndarray, key: str) -> None:
    """Refuse a value beyond +-45 electrical deg (:data:`PSI_MAX`), naming the first such row."""
    bad = np.nonzero(np.abs(psi) > PSI_MAX)[0]
    if not bad.size:
        return
    i = int(bad[0])
    x = float(psi[i])
    hint = (f"; degrees written as radians? (as degrees, {x:.6g} deg would be a plausible angle)"
            if abs(x) <= math.degrees(PSI_MAX) else "")
    raise InputError(src, f"{key}[{i}]", f"{x:.6g} rad ({math.degrees(x):.4g} deg) is beyond +-45 "
                     "electrical deg (pi/4 rad): the demodulated error goes as sin 2 (e - Psi), whose slope "
                     "changes sign there, so no observer settles on such a table (docs/theory.md, section 6)"
                     f"{hint}")


def _check_stamp(src: str, stamp: TableStamp, motor, injection: str, f_inj: float, quad: float) -> None:
    """Refuse a stamp of another drive than the one described, naming the stamp key and both values."""
    digest = data_digest(motor=motor)
    if stamp.motor_sha256 != digest:
        same = " (the same name, other data: an edited motor file?)" if stamp.motor == motor.name else ""
        renamed = stamp.motor != motor.name and \
            data_digest(motor=replace(motor, name=stamp.motor)) == stamp.motor_sha256
        if renamed:
            same = (f" (the same motor data under another name: the name is part of the stamp; name the "
                    f"motor {stamp.motor!r} again, or calibrate it under its new name)")
        raise InputError(src, "stamp.motor_sha256",
                         f"the table was measured on a drive believing in motor {stamp.motor!r} (sha256 "
                         f"{stamp.motor_sha256[:_DIGEST_SHOWN]}), this drive believes in motor "
                         f"{motor.name!r} (sha256 {digest[:_DIGEST_SHOWN]}){same}: a table is valid for the "
                         "motor data it was calibrated for; calibrate this drive (linsense calibrate)")
    if stamp.injection != injection:
        raise InputError(src, "stamp.injection", f"the table is for the {stamp.injection!r} injection, the "
                         f"drive runs {injection!r} (each injection has its own table)")
    if abs(stamp.f_inj - f_inj) > F_INJ_RTOL * abs(f_inj):
        raise InputError(src, "stamp.f_inj", f"the table was measured at {stamp.f_inj:.9g} Hz, the drive "
                         f"injects at {f_inj:.9g} Hz (the table depends on the frequency through R_s)")
    if abs(stamp.quad - quad) > QUAD_ATOL:
        raise InputError(src, "stamp.quad", f"the table was measured with kappa {stamp.quad!r}, the drive "
                         f"runs kappa {quad!r} (the table depends on the injection's q-axis share)")


#: the end-effect scales :func:`end_effect_fit` searches (of the motor file's dM0)
FIT_RANGE = (0.0, 3.0)


def end_effect_fit(motor, values: np.ndarray, injection: str, f_inj: float, quad: float) -> tuple:
    """The motor whose model table fits a measured one best, by its end effect alone.

    A measured table departs from the motor file's mostly by the end effect (the paper's dM0: the
    part of the motor the file knows least, docs/tuning.md, "The end-effect tolerance"); the drive's
    other tables (the demodulator's gain schedule, the table's slope in the resistance) follow the
    same end effect, so they are computed from the motor whose end effect the measured table says:
    ``perturbed(motor, 1, 1, k)`` with ``k`` minimising the mean square difference between its
    model table (:func:`linsense.compensation.lut.build_lut` for the injection) and ``values``,
    over :data:`FIT_RANGE`.

    Parameters
    ----------
    motor : Motor
        The motor the drive believes in (with the resistance it believes).
    values : ndarray
        The measured table, rad, on the grid ``2 pi k / N``.
    injection : str
        ``"pulsating"``, ``"rotating"`` or ``"square"``.
    f_inj : float
        The injection frequency the drive runs, Hz.
    quad : float
        Kappa (0 for the rotating vector and the square wave).

    Returns
    -------
    motor : Motor
        The fitted motor (``motor`` itself where the fit gives the file's end effect).
    k : float
        The end-effect scale.
    rms : float
        The fitted table's root-mean-square difference from ``values``, rad.

    Notes
    -----
    Each fit (about 0.4 s) is kept by its inputs' content, the last :data:`FITS_KEPT`: a table
    that ``tune`` reports, writes into a header and verifies with is fitted once.

    Raises
    ------
    linsense.errors.InputError
        An argument of the wrong kind or out of range, naming it.
    """
    src = "linsense.compensation.measured.end_effect_fit"
    motor = as_motor(motor, src)
    values = reals(values, src, "values", "table values in rad", ndim=1, min_size=4)
    injection = choice(injection, src, "injection", INJECTIONS)
    real(f_inj, src, "f_inj", 0.0, low_open=True, what="a positive frequency in Hz")
    real(quad, src, "quad", 0.0, 1.0, high_open=True)
    key = (data_digest(motor=motor), values.tobytes(), injection, float(f_inj), float(quad))
    hit = _FITS.get(key)
    if hit is None:
        hit = _fit(motor, values, injection, f_inj, quad)
        while len(_FITS) >= FITS_KEPT:
            _FITS.pop(next(iter(_FITS)))
        _FITS[key] = hit
    return hit


#: how many end-effect fits :func:`end_effect_fit` keeps
FITS_KEPT = 16
_FITS: dict = {}


def _fit(motor, values: np.ndarray, injection: str, f_inj: float, quad: float) -> tuple:
    """:func:`end_effect_fit`'s minimisation."""
    from scipy.optimize import minimize_scalar

    from linsense.compensation.lut import build_lut
    from linsense.model.tolerance import perturbed

    n = values.size
    shape_quad = quad if injection == "pulsating" else 0.0

    def table(k: float) -> np.ndarray:
        return build_lut(perturbed(motor, 1.0, 1.0, k), n, f_inj=f_inj, quad=shape_quad,
                         injection=injection).values

    def cost(k: float) -> float:
        try:
            return float(np.mean((table(k) - values) ** 2))
        except (ValueError, FloatingPointError, ArithmeticError):  # (no longer a motor: not a fit)
            return math.inf

    res = minimize_scalar(cost, bounds=FIT_RANGE, method="bounded", options={"xatol": 1e-4})
    k = float(res.x)
    if not math.isfinite(res.fun) or cost(1.0) <= res.fun:
        return motor, 1.0, math.sqrt(cost(1.0))
    return perturbed(motor, 1.0, 1.0, k), k, math.sqrt(float(res.fun))


#: a measured table whose end-effect fit leaves more than this (rms, electrical deg), or whose
#: end effect is off the file's by more than a factor :data:`FIT_SCALE_WARN`, is doubtful: a
#: calibration measures the paper's table to 0.1-0.4 deg, and an end effect off by a factor 2 is
#: another motor than the file's
FIT_RMS_WARN_DEG = 0.5
FIT_SCALE_WARN = 2.0


def fit_report(motor, values: np.ndarray, injection: str, f_inj: float, quad: float,
               points: int | None = None) -> tuple[str, str]:
    """What :func:`end_effect_fit` made of a measured table, as a person reads it.

    The table is judged at its own points (a table resampled to the drive's length carries the
    interpolation's error, which is no property of the motor); where the drive reads it at more
    points, the firmware's linear interpolation between them is judged too
    (:func:`interpolation_error`): a 12-point table of small30 is read 3.5 deg off the motor's own
    table between its points, which the fit blamed on the motor file.

    Parameters
    ----------
    motor : Motor
        The motor the drive believes in.
    values : ndarray
        The measured table at its own points ``2 pi k / N``, rad.
    injection : str
        The injection's shape.
    f_inj : float
        The injection frequency the drive runs, Hz.
    quad : float
        Kappa.
    points : int or None, optional
        The table length the drive reads it at (None: not judged).

    Returns
    -------
    line : str
        The fit: the end effect's scale and the fit's rms.
    warning : str
        "" for a table the fit explains, read at a resolution the drive can use; else why the table
        is doubtful.
    """
    values = np.asarray(values, dtype=float)
    _, k, rms = end_effect_fit(motor, values, injection, f_inj, quad)
    rms_deg = math.degrees(rms)
    line = (f"the end effect it says: {k:.3g} x the motor file's (the drive's model takes it; the fit "
            f"leaves {rms_deg:.2g} deg rms)")
    doubtful = rms_deg > FIT_RMS_WARN_DEG or not (1.0 / FIT_SCALE_WARN <= k <= FIT_SCALE_WARN)
    warnings = [f"the measured table does not look like this motor's: its end effect {k:.3g} x the file's, "
                f"{rms_deg:.2g} deg rms left by the fit (a calibration: 0.1-0.4 deg; bounds "
                f"{FIT_RMS_WARN_DEG:g} deg and a factor {FIT_SCALE_WARN:g}): check the calibration (its "
                f"metrics.json) and the motor file"] if doubtful else []
    if points is not None:
        warnings += [w for w in [resolution_warning(motor, values.size, injection, f_inj, quad, points)] if w]
    return line, "; ".join(warnings)


def resolution_warning(motor, n: int, injection: str, f_inj: float, quad: float, points: int) -> str:
    """Why a table of ``n`` points is too coarse for a drive that reads it at ``points``, or "".

    Its :func:`interpolation_error` beyond :data:`FIT_RMS_WARN_DEG` (a calibration's own accuracy);
    said by ``linsense calibrate`` as it writes such a table and by every command that reads one
    (:func:`fit_report`).

    Parameters
    ----------
    motor : Motor
        The motor the drive believes in.
    n : int
        The table's points.
    injection : str
        The injection's shape.
    f_inj : float
        The injection frequency the drive runs, Hz.
    quad : float
        Kappa.
    points : int
        The length the drive reads it at.

    Returns
    -------
    str
        The warning, or "".
    """
    if n >= points:
        return ""
    err = math.degrees(interpolation_error(motor, n, injection, f_inj, quad, points))
    if err <= FIT_RMS_WARN_DEG:
        return ""
    return (f"a {n}-point table: the firmware's linear interpolation between its points is off the motor's "
            f"own table by up to {err:.2g} deg (the model's table at {n} points read at {points}; bound "
            f"{FIT_RMS_WARN_DEG:g} deg): calibrate more positions (linsense calibrate --positions)")


def interpolation_error(motor, n: int, injection: str, f_inj: float, quad: float, points: int) -> float:
    """How far a table of ``n`` points is read off the motor's own table at ``points`` positions: the
    largest difference between the model's table at ``n`` points, read with the firmware's periodic
    linear interpolation (:func:`linsense.compensation.lut.interpolate`), and the model's table at
    ``points``.

    Parameters
    ----------
    motor : Motor
        The motor the drive believes in.
    n : int
        The table's points.
    injection : str
        The injection's shape.
    f_inj : float
        The injection frequency the drive runs, Hz.
    quad : float
        Kappa.
    points : int
        The length the drive reads it at.

    Returns
    -------
    float
        rad.
    """
    from linsense.compensation.lut import build_lut

    q = quad if injection == "pulsating" else 0.0
    fine = build_lut(motor, points, f_inj=f_inj, quad=q, injection=injection).values
    coarse = build_lut(motor, n, f_inj=f_inj, quad=q, injection=injection).values
    return float(np.max(np.abs(interpolate(coarse, 2.0 * np.pi * np.arange(points) / points) - fine)))
