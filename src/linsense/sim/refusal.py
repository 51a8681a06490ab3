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

from linsense.ctrl import c_limit, cfg_get, drive_default_cfg, limit_rule, refused_group
from linsense.tune.cfgmap import FS_FIELDS, ROWS

#: C field of ls_drive_cfg -> (scenario keys that fill it, in order of precedence; the factor
#: from the first key's unit to the field's, or None where the field is computed from the keys).
#: The first key the scenario gives is named; none given: the first (a designed or default value).
#: The rows of the one mapping (linsense.tune.cfgmap) the refusal is searched in.
FIELDS: dict[str, tuple[tuple[str, ...], float | None]] = {
    r.field: (r.keys, r.scale) for r in ROWS if r.sim and r.blame
}
#: (FS_FIELDS, from the mapping: the sampling rate of every module, one scenario key, inverter.f_pwm)


def culprit(cfg, given: set[str]):
    """``(key, field, base)`` for the refused ``cfg`` (``ls_drive_cfg *``), or None when no single
    scenario key explains the refusal.

    The search of :func:`linsense.ctrl.refused_group` (the one :class:`linsense.ctrl.Drive` runs over
    the C fields) over the scenario keys: ``key`` is the scenario key whose fields, put back together
    to the firmware's default, make ``ls_drive_init`` accept the configuration (the keys the scenario
    gives tried first); ``field`` the one of them refused by itself, the others at their defaults;
    ``base`` the configuration in which ``field`` alone is refused (to find its limit in). A key none
    of whose fields is refused within the scenario's configuration is looked for in the firmware's
    default configuration (a rule of its own field alone, such as the largest sampling rate).

    Parameters
    ----------
    cfg : cffi ``ls_drive_cfg *``
        The refused configuration.
    given : set of str
        The dotted keys the scenario gives.

    Returns
    -------
    tuple of (str, str, cffi ``ls_drive_cfg *``) or None
        ``(key, field, base)``; ``field`` is ``"fs"`` for the sampling rates (set together).
    """
    default = drive_default_cfg()
    groups: dict[str, list[str]] = {}
    for path in FIELDS:
        if cfg_get(cfg, path) != cfg_get(default, path):
            groups.setdefault(scenario_key(path, given), []).append(path)
    if any(cfg_get(cfg, p) != cfg_get(default, p) for p in FS_FIELDS):
        groups["inverter.f_pwm"] = list(FS_FIELDS)
    order = sorted(groups, key=lambda k: k not in given)  # (stable: the table's order within)
    found = refused_group(cfg, {k: tuple(groups[k]) for k in order}, tuple(FIELDS),
                          frozenset({"inverter.f_pwm"}))
    if found is None:
        return None
    key, paths, base = found
    return key, "fs" if key == "inverter.f_pwm" else paths[0], base


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
    field = float(cfg_get(base, path))
    scale = 1.0 if path == "fs" else FIELDS[path][1]
    direct = path == "fs" or (scale is not None and key == FIELDS[path][0][0]
                              and math.isclose(field, value * scale, rel_tol=1e-6))
    lim, words = limit_rule(field, c_limit(base, paths))
    shown = value if isinstance(value, str) else _num(value) if isinstance(value, float) else repr(value)
    if direct and lim is not None:
        msg = (f"{shown} is {words} value the controller library accepts here, {_num(lim / scale)} "
               f"(ls_drive_init, field {path})")
    elif lim is not None:
        msg = (f"{shown} makes the controller's {path} = {_num(field)}, {words} value the "
               f"controller library accepts here, {_num(lim)} (ls_drive_init)")
    else:
        rule = "refused by ls_drive_init" if words == "refused" else words
        msg = f"{shown} makes the controller's {path} = {_num(field)}: {rule} (ls_drive_init)"
    return key, msg
