"""Which scenario key a refusal of the controller library comes from, with its value and limit.

``ls_drive_init`` answers a configuration with one status: it does not say which field broke
which rule. The scenario keys fill the fields of ``ls_drive_cfg`` through one mapping
(:mod:`linsense.tune.cfgmap`, also read by the build and ``tune --format c``),
so the culprit is found by asking the C library itself: each field in turn is put back to the
firmware's default (``ls_drive_default_cfg``) in a copy of the refused configuration, and the field
whose default makes ``ls_drive_init`` accept it is the one at fault. Its limit is then read from the
C library too, by bisection between the default (accepted) and the value given (refused): the
largest (or smallest) value ``ls_drive_init`` accepts with everything else as the scenario has it.
No C limit is restated in Python, so the message follows the library when its limits change.
"""

from __future__ import annotations

import math

import numpy as np

from linsense.ctrl import REAL, drive_default_cfg, ffi, lib
from linsense.tune.cfgmap import FS_FIELDS, ROWS

#: C field of ls_drive_cfg -> (scenario keys that fill it, in order of precedence; the factor
#: from the first key's unit to the field's, or None where the field is computed from the keys).
#: The first key the scenario gives is named; none given: the first (a designed or default value).
#: The rows of the one mapping (linsense.tune.cfgmap) the refusal is searched in.
FIELDS: dict[str, tuple[tuple[str, ...], float | None]] = {
    r.field: (r.keys, r.scale) for r in ROWS if r.sim and r.blame
}
#: (FS_FIELDS, from the mapping: the sampling rate of every module, one scenario key, inverter.f_pwm)

def _get(cfg, path: str):
    obj = cfg
    for part in path.split("."):
        obj = getattr(obj, part)
    return obj


def _set(cfg, path: str, value) -> None:
    *head, last = path.split(".")
    obj = cfg
    for part in head:
        obj = getattr(obj, part)
    setattr(obj, last, value)


def _copy(cfg):
    c = ffi.new("ls_drive_cfg *")
    ffi.memmove(c, cfg, ffi.sizeof("ls_drive_cfg"))
    return c


def _accepts(cfg) -> bool:
    return lib.ls_drive_init(ffi.new("ls_drive *"), cfg) == lib.LS_OK


def culprit(cfg, given: set[str]):
    """``(key, field, base)`` for the refused ``cfg`` (``ls_drive_cfg *``), or None when no single
    scenario key explains the refusal.

    ``key`` is the scenario key whose fields, put back together to the firmware's default, make
    ``ls_drive_init`` accept the configuration (the keys the scenario gives tried first); ``field``
    the one of them refused by itself, the others at their defaults; ``base`` the configuration in
    which ``field`` alone is refused (to find its limit in). A key none of whose fields is refused
    within the scenario's configuration is looked for in the firmware's default configuration
    (a rule of its own field alone, such as the largest sampling rate).

    Parameters
    ----------
    cfg : cffi ``ls_drive_cfg *``
        The refused configuration.
    given : set of str
        The dotted keys the scenario gives.

    Returns
    -------
    tuple of (str, str, cffi ``ls_drive_cfg *``) or None
        ``(key, field, base)``.
    """
    default = drive_default_cfg()
    groups: dict[str, list[str]] = {}
    for path in FIELDS:
        if _get(cfg, path) != _get(default, path):
            groups.setdefault(scenario_key(path, given), []).append(path)
    if any(_get(cfg, p) != _get(default, p) for p in FS_FIELDS):
        groups.setdefault("inverter.f_pwm", []).extend(FS_FIELDS)
    order = sorted(groups, key=lambda k: k not in given)  # (stable: the table's order within)

    def reset(c, paths):
        for path in paths:
            _set(c, path, _get(default, path))
        return c

    for key in order:
        paths = groups[key]
        if key == "inverter.f_pwm" or not _accepts(reset(_copy(cfg), paths)):
            continue
        for path in paths:
            base = reset(_copy(cfg), [p for p in paths if p != path])
            if not _accepts(base):
                return key, path, base
        return key, paths[0], _copy(cfg)
    for key in order:  # (a field refused by itself, whatever the rest)
        paths = FS_FIELDS if key == "inverter.f_pwm" else groups[key]
        # the scenario's configuration as far as it is accepted without this key's fields
        near = _copy(default)
        for other in FIELDS:
            if other not in paths and _get(near, other) != _get(cfg, other):
                trial = _copy(near)
                _set(trial, other, _get(cfg, other))
                if _accepts(trial):
                    near = trial
        if key == "inverter.f_pwm":
            base = _copy(near)
            for path in FS_FIELDS:
                _set(base, path, _get(cfg, path))
            if not _accepts(base):
                return key, "fs", base
            continue
        for path in paths:
            base = _copy(near)
            _set(base, path, _get(cfg, path))
            if not _accepts(base):
                return key, path, base
    return None


def c_limit(cfg, paths: tuple[str, ...]) -> float | None:
    """The value of the fields ``paths`` nearest to the refused one that ``ls_drive_init`` accepts.

    With the rest of ``cfg`` as it is (the fields set together): a bisection between the default and
    the refused value, in logarithmic steps across decades.

    Parameters
    ----------
    cfg : cffi ``ls_drive_cfg *``
        The refused configuration.
    paths : tuple of str
        The fields' struct paths.

    Returns
    -------
    float or None
        The limit, in the field's unit; None if the default is refused.
    """
    c = _copy(cfg)
    good = float(_get(drive_default_cfg(), paths[0]))
    bad = float(_get(c, paths[0]))
    integer = isinstance(_get(c, paths[0]), int)
    if not math.isfinite(good) or math.isnan(bad):
        return None
    if math.isinf(bad):  # (an overflow: from the largest finite value the field holds)
        bad = math.copysign(float(np.finfo(REAL).max), bad)

    def put(v: float) -> float:
        for p in paths:
            _set(c, p, int(v) if integer else v)
        return float(_get(c, paths[0]))  # (as the C field holds it: LS_REAL may be a float)

    put(good)
    if not _accepts(c):
        return None
    for _ in range(200):
        if good > 0 and bad > 0 and max(good, bad) > 4.0 * min(good, bad):
            mid = math.sqrt(good * bad)
        else:
            mid = 0.5 * (good + bad)
        if integer:
            mid = math.floor(mid) if bad > good else math.ceil(mid)
        mid = put(mid)
        if mid in (good, bad):
            break
        if _accepts(c):
            good = mid
        else:
            bad = mid
    return good


def scenario_key(path: str, given: set[str]) -> str:
    """The scenario key to name for the C field ``path``.

    The first of its keys the scenario gives, else the first (a designed or default value).

    Parameters
    ----------
    path : str
        The struct path in ``ls_drive_cfg`` (``"fs"``: the sampling rates).
    given : set of str
        The dotted keys the scenario gives.

    Returns
    -------
    str
        The dotted key.
    """
    keys = FIELDS[path][0] if path != "fs" else ("inverter.f_pwm",)
    for k in keys:
        if k in given:
            return k
    return keys[0]


def given_keys(data: dict, prefix: str = "") -> set[str]:
    """The dotted keys of a scenario's given data (:meth:`Scenario.given`).

    Parameters
    ----------
    data : dict
        Nested keys.
    prefix : str, optional
        Prepended to every key.

    Returns
    -------
    set of str
        Every dotted key, sections included.
    """
    out = set()
    for k, v in data.items():
        out.add(prefix + k)
        if isinstance(v, dict):
            out |= given_keys(v, prefix + k + ".")
    return out


def _num(v: float) -> str:
    return f"{v:.6g}"


def explain(cfg, given: set[str], value_of) -> tuple[str, str] | None:
    """``(key, message)`` for the refused ``cfg``: the scenario key the user wrote, its value and
    the limit ``ls_drive_init`` sets, or None if no single field explains the refusal.

    Parameters
    ----------
    cfg : cdata ``ls_drive_cfg *``
        The configuration ``ls_drive_init`` refused.
    given : set of str
        The dotted keys the scenario gives.
    value_of : callable
        ``value_of(key)``: the scenario's value of a dotted key (given, designed or default).

    Returns
    -------
    tuple of (str, str) or None
        ``(key, message)``.
    """
    found = culprit(cfg, given)
    if found is None:
        return None
    key, path, base = found
    value = value_of(key)
    paths = FS_FIELDS if path == "fs" else (path,)
    field = float(_get(base, path))
    lim = c_limit(base, paths)
    scale = 1.0 if path == "fs" else FIELDS[path][1]
    direct = path == "fs" or (scale is not None and key == FIELDS[path][0][0]
                              and math.isclose(field, value * scale, rel_tol=1e-6))
    where = "above the largest" if lim is not None and field > lim else "below the smallest"
    shown = value if isinstance(value, str) else _num(value) if isinstance(value, float) else repr(value)
    if lim is not None and 0.0 < abs(lim) < float(np.finfo(REAL).tiny):
        lim = None  # (the smallest positive number the field holds: the rule is "> 0")
        rule = "it must be above 0"
    elif lim is not None and abs(lim) > 0.5 * float(np.finfo(REAL).max):
        lim = None  # (the largest number it holds: the rule is "finite")
        rule = "it must be finite"
    else:
        rule = "refused by ls_drive_init"
    if direct and lim is not None:
        msg = (f"{shown} is {where} value the controller library accepts here, {_num(lim / scale)} "
               f"(ls_drive_init, field {path})")
    elif lim is not None:
        msg = (f"{shown} makes the controller's {path} = {_num(field)}, {where} value the "
               f"controller library accepts here, {_num(lim)} (ls_drive_init)")
    else:
        msg = f"{shown} makes the controller's {path} = {_num(field)}: {rule} (ls_drive_init)"
    return key, msg
