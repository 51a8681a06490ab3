"""Which scenario key a refusal of the controller library comes from, with its value and limit.

``ls_drive_init`` answers a configuration with one status: it does not say which field broke
which rule. The scenario keys fill the fields of ``ls_drive_cfg`` (:func:`linsense.sim.build.build`),
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

#: C field of ls_drive_cfg -> (scenario keys that fill it, in order of precedence; the factor
#: from the first key's unit to the field's, or None where the field is computed from the keys).
#: The first key the scenario gives is named; none given: the first (a designed or default value).
FIELDS: dict[str, tuple[tuple[str, ...], float | None]] = {
    "fs": (("inverter.f_pwm",), 1.0),
    "force_constant": (("controller.model.force_constant", "motor"), 1.0),
    "i_max": (("controller.i_max",), 1.0),
    "delay_comp": (("control.delay_comp",), 1.0),
    "hf_delay": (("observer.hf_delay_s",), 1.0),
    "enc_counts": (("sensors.encoder_counts_per_period",), 1.0),
    "inject.amplitude": (("injection.amplitude",), 1.0),
    "inject.freq": (("injection.frequency", "inverter.f_pwm"), 1.0),
    "inject.ramp_rate": (("injection.ramp_rate",), 1.0),
    "inject.quad": (("injection.quadrature",), 1.0),
    "bpf.f0": (("injection.frequency", "inverter.f_pwm"), 1.0),
    "bpf.q": (("injection.filter_q",), 1.0),
    "sep.f0": (("injection.frequency", "inverter.f_pwm"), 1.0),
    "sep.q": (("injection.filter_q",), 1.0),
    "demod.f_lpf": (("observer.demod_lpf_hz",), 1.0),
    "demod.gain": (("controller.model.demod_gain", "controller.model.L_q", "controller.model.L_d",
                    "controller.model.motor"), None),
    "demod.min_level": (("observer.min_level",), 1.0),
    "demod.f_notch": (("injection.frequency", "observer.demod_notch"), None),
    "obs.k1": (("observer.k1", "observer.bandwidth_hz"), None),
    "obs.k2": (("observer.k2", "observer.bandwidth_hz"), None),
    "obs.k3": (("observer.k3", "observer.bandwidth_hz"), None),
    "obs.mass": (("controller.model.mass", "motor"), 1.0),
    "obs.omega_max": (("observer.omega_max",), 1.0),
    "obs.force_max": (("observer.force_max",), 1.0),
    "current.kp": (("controller.current_kp", "controller.current_bandwidth_hz", "controller.model.L_d",
                    "controller.model.L_q"), None),
    "current.ki": (("controller.current_ki", "controller.model.R_s", "controller.current_bandwidth_hz"),
                   None),
    "current.l_d": (("controller.model.L_d", "controller.model.motor"), 1.0),
    "current.l_q": (("controller.model.L_q", "controller.model.motor"), 1.0),
    "current.psi_pm": (("controller.model.psi_pm", "controller.model.motor"), 1.0),
    "pos.kp_x": (("controller.kp_x",), 1.0),
    "pos.kd_x": (("controller.kd_x",), 1.0),
    "pos.v_max": (("controller.v_max",), 1.0),
    "pos.speed.kp": (("controller.speed_kp", "controller.speed_bandwidth_hz", "controller.model.mass"), None),
    "pos.speed.ki": (("controller.speed_ki", "controller.speed_bandwidth_hz", "controller.model.mass"), None),
    "pos.mass": (("controller.model.mass", "motor"), 1.0),
    "pos.force_max": (("controller.i_max", "controller.model.force_constant"), None),
    "pos.speed.out_min": (("controller.i_max", "controller.model.force_constant"), None),
    "pos.speed.out_max": (("controller.i_max", "controller.model.force_constant"), None),
    "traj.v_max": (("reference.v_max",), 1.0),
    "traj.a_max": (("reference.a_max",), 1.0),
    "traj.v_step": (("controller.v_max",), 1.0),
    "traj.a_step": (("controller.step_a_max",), 1.0),
    "traj.a_lpf": (("observer.demod_lpf_hz",), None),
    "mod.dead_time": (("inverter.dead_time",), 1.0),
    "mod.i_band": (("inverter.dtc_current_band",), 1.0),
    "mod.l_ripple": (("controller.model.L_d", "controller.model.L_q", "controller.model.motor"), None),
    "dtres.r_s": (("controller.model.R_s", "controller.model.motor"), 1.0),
    "dtres.l_d": (("controller.model.L_d", "controller.model.motor"), 1.0),
    "dtres.l_q": (("controller.model.L_q", "controller.model.motor"), 1.0),
    "prot.i_max": (("protection.i_max",), 1.0),
    "prot.v_dc_min": (("protection.v_dc_min", "inverter.v_dc"), None),
    "prot.v_dc_max": (("protection.v_dc_max", "inverter.v_dc"), None),
    "prot.err_max": (("protection.err_max",), 1.0),
    "prot.err_time": (("protection.err_time",), 1.0),
    "prot.omega_max": (("protection.omega_max",), 1.0),
    "cal.points": (("calibration.points",), 1.0),
    "cal.k_int": (("calibration.k_int",), 1.0),
    "cal.t_settle": (("calibration.t_settle", "controller.kp_x"), 1.0),
    "cal.t_hold": (("calibration.t_hold", "calibration.k_int"), 1.0),
    "cal.tol": (("calibration.tol_deg",), math.pi / 180.0),
    "cal.t_max": (("calibration.t_max", "calibration.t_hold", "calibration.k_int"), 1.0),
    "cal.dither_amp": (("calibration.dither_a",), 1.0),
    "cal.dither_freq": (("calibration.dither_hz",), 1.0),
    "i_d_inj": (("injection.d_current", "controller.i_max"), None),
    "startup.t_lock": (("startup.t_lock",), 1.0),
    "startup.err_lock": (("startup.err_lock_deg",), math.pi / 180.0),
    "startup.t_quiet": (("startup.t_quiet",), 1.0),
    "startup.v_pulse": (("startup.v_pulse",), 1.0),
    "startup.t_pulse": (("startup.t_pulse",), 1.0),
    "startup.t_rest": (("startup.t_rest",), 1.0),
    "startup.pairs": (("startup.pairs",), 1.0),
    "startup.i_min": (("startup.i_min",), 1.0),
    "startup.t_settle": (("startup.t_settle",), 1.0),
    "startup.lock_gain": (("observer.bandwidth_hz", "observer.demod_lpf_hz"), None),
}

#: the sampling rate of every module: one scenario key, inverter.f_pwm
FS_FIELDS = ("fs", "inject.fs", "bpf.fs", "sep.fs", "demod.fs", "obs.fs", "enc_obs.fs", "current.fs",
             "pos.speed.fs", "traj.fs", "mod.f_pwm", "dtres.fs", "prot.fs", "startup.fs")


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
    """The value of the fields ``paths`` (set together) nearest to the refused one that
    ``ls_drive_init`` accepts with the rest of ``cfg`` as it is: a bisection between the default
    and the refused value, in logarithmic steps across decades; None if the default is refused."""
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
    """The scenario key to name for the C field ``path``: the first of its keys the scenario
    gives, else the first (a designed or default value)."""
    keys = FIELDS[path][0] if path != "fs" else ("inverter.f_pwm",)
    for k in keys:
        if k in given:
            return k
    return keys[0]


def given_keys(data: dict, prefix: str = "") -> set[str]:
    """The dotted keys of a scenario's given data (:meth:`Scenario.given`)."""
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
