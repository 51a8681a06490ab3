"""Python binding of the C99 firmware library (``csrc/``), compiled into :mod:`linsense._ctrl`.

A thin layer over the cffi extension: the raw ``ffi`` and ``lib`` objects give every C function
and struct of ``linsense/ls_*.h`` (declarations generated from the headers by
``tools/build_ctrl.py``); :class:`Drive` creates and configures the complete drive, :class:`Lut`
a table for it, and both refuse bad configurations with :class:`ConfigError` (the C
``ls_<module>_init`` decides, Python only names the field). Values are in SI units (electrical
radians, Hz, s, A, V, N, m, kg); positions are *unwrapped* electrical angles,
``theta = 2 pi period + angle``, computed in double from the C ``ls_pos``.

Example
-------
>>> from linsense import ctrl
>>> cfg = ctrl.drive_default_cfg()                         # the documented defaults, to edit
>>> drive = ctrl.Drive(cfg, comp=table)                    # doctest: +SKIP
>>> drive.set_position(0.0); drive.set_mode("sensorless_lut")  # doctest: +SKIP
"""

from __future__ import annotations

import functools
import math
import numbers
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from linsense._check import brief, closest_key, real
from linsense._ctrl import ffi, lib
from linsense._digest import source_digest
from linsense.errors import ConfigError, InputError

__all__ = [
    "ffi",
    "lib",
    "REAL",
    "ConfigError",
    "Lut",
    "make_lut",
    "Drive",
    "drive_default_cfg",
    "to_pos",
    "from_pos",
    "cfg_fields",
    "refused_group",
    "c_limit",
    "explain_drive_refusal",
    "EQUAL_FIELDS",
    "V_INJ_SHARE_MAX",
    "RIPPLE_MAX",
    "STARTUP_PAIRS_MAX",
    "STARTUP_PULSE_STEPS_MIN",
    "STARTUP_REST_STEPS_MIN",
    "injection_fits",
    "observer_gains",
    "emf_init",
    "emf_omega_min",
]


def _realize_types() -> None:
    """Realize every C type of the extension now, at import, in one thread. cffi realizes types
    lazily on first use and, on GIL builds of CPython, without a lock (python-cffi/cffi#271): the
    sweep's worker threads creating their first ``ls_sim_cfg`` together crashed once in
    ``realize_c_type.c`` ("builder != NULL"). Realized types are only read afterwards."""
    typedefs, structs, unions = ffi.list_types()
    for name in typedefs:
        ffi.typeof(name)
    for name in structs:
        ffi.typeof(f"struct {name}")
    for name in unions:
        ffi.typeof(f"union {name}")
    for name in ("float", "double", "int32_t", "uint32_t", "uint8_t", "char", "float[]", "double[]",
                 "float *", "double *", "int32_t *", "uint32_t *"):
        ffi.typeof(name)
    for name in dir(lib):  # (functions and constants: their types too)
        getattr(lib, name)


_realize_types()


def built_digest() -> str:
    """Digest of the sources the extension was compiled from.

    Returns
    -------
    str
        Hex digest ("" for an extension too old to say).
    """
    try:
        return ffi.string(lib.ls_py_source_digest()).decode()
    except AttributeError:
        return ""


def source_tree_digest() -> str | None:
    """Digest of ``csrc/`` and the build's Python inputs (``tools/build_ctrl.py``, its flag tables
    ``tools/build_flags.py``, ``setup.py``) in the source tree.

    Returns
    -------
    str or None
        Hex digest; None outside a source tree (a wheel).
    """
    root = Path(__file__).resolve().parents[2]
    if not (root / "csrc" / "ctrl").is_dir() or not (root / "tools" / "build_ctrl.py").is_file():
        return None
    return source_digest(root)


def _check_stale() -> None:
    """In a source tree (editable install), warn if csrc/ changed since the extension was built."""
    tree = source_tree_digest()
    if tree is not None and built_digest() != tree:
        warnings.warn(
            "linsense._ctrl was compiled from other C sources than those in csrc/ (or another "
            "tools/build_ctrl.py): rebuild it with `pip install -e .`",
            RuntimeWarning,
            stacklevel=3,
        )


_check_stale()

#: numpy dtype of the C library's ``LS_REAL`` (float32 unless built with ``-DLS_REAL_DOUBLE``).
REAL = np.dtype(np.float32) if ffi.sizeof("LS_REAL") == 4 else np.dtype(np.float64)

_TWO_PI = 2.0 * np.pi
_STATUS = {lib.LS_OK: "LS_OK", lib.LS_ERR_NULL: "LS_ERR_NULL", lib.LS_ERR_PARAM: "LS_ERR_PARAM",
           lib.LS_ERR_VERSION: "LS_ERR_VERSION"}

def _lim(value: float) -> str:
    """A limit of the C library (a ``LS_R(...)`` macro read through the binding) for a message."""
    return f"{value:g}"


# Allowed ranges of the configuration fields, as documented in the C headers (for messages only:
# the C init functions decide what is refused); the limits are the headers' macros (lib.LS_...).
_RULES = {
    "ls_lut": {"len": "number of points over one electrical period, >= 4", "table": "finite values"},
    "ls_biquad": {
        "type": "lowpass, bandpass or notch",
        "f0": "Hz, > 0 and < fs/2",
        "q": f"quality factor, {_lim(lib.LS_BIQUAD_Q_MIN)} .. {_lim(lib.LS_BIQUAD_Q_MAX)}",
        "fs": "Hz, sampling rate, > 0 and > 2 f0",
    },
    "ls_inject": {
        "amplitude": "V, >= 0",
        "freq": "Hz, > 0",
        "fs": "Hz, sampling rate, >= 4 freq",
        "ramp_rate": "V/s, > 0",
    },
    "ls_demod": {
        "method": "product or heterodyne",
        "f_lpf": "Hz, low-pass corner, > 0 and < fs/2",
        "fs": "Hz, sampling rate, > 2 f_lpf",
        "gain": f"L_q/(L_q - L_d), finite, non-zero, |gain| <= {_lim(lib.LS_DEMOD_GAIN_MAX)}",
        "comp": "ls_lut with >= 4 points",
        "gain_table": "ls_lut with >= 4 points",
        "min_level": "A^2, >= 0",
    },
    "ls_observer": {
        "type": "pll or mech",
        "fs": "Hz, > 0",
        "k1": f"1/s, > 0, k1 Ts <= {_lim(lib.LS_OBS_K1_TS_MAX)} (beyond, the discrete observer is unstable)",
        "k2": f"1/s^2, > 0, k2 Ts^2 <= {_lim(lib.LS_OBS_K2_TS2_MAX)}",
        "k3": f"1/s^3, > 0 for mech, k3 Ts^3 <= {_lim(lib.LS_OBS_K3_TS3_MAX)}",
        "pole_pitch": "m, > 0",
        "mass": "kg, > 0 for mech",
        "omega_max": "rad/s, > 0, omega_max Ts <= pi (half a period per step)",
        "force_max": "N, > 0 for mech; it may move the estimate at most pi per step",
    },
    "ls_emf": {
        "fs": "Hz, sampling rate, > 0",
        "r_s": "ohm, >= 0",
        "l_d": "H, > 0",
        "l_q": "H, > 0",
        "f_lpf": f"Hz, > 0, f_lpf <= {_lim(lib.LS_EMF_FLPF_FS_MAX)} fs",
        "omega_max": f"rad/s, > 0, omega_max / fs <= {_lim(lib.LS_EMF_OMEGA_TS_MAX)}",
        "err_r": f"relative uncertainty of the resistance, 0 .. {_lim(lib.LS_EMF_ERR_REL_MAX)}",
        "err_l": f"relative uncertainty of l_q, 0 .. {_lim(lib.LS_EMF_ERR_REL_MAX)}",
        "u_err": "V, the inverter's voltage error bound, >= 0",
        "i_noise": "A rms per sample, >= 0",
        "psi_pm": "Wb, the magnets' positive-sequence flux, >= 0; > 0 when neg_re or neg_im is not 0",
        "pm_shift": f"rad, the positive sequence's phase, |pm_shift| <= {_lim(lib.LS_EMF_PM_SHIFT_MAX)}",
        "neg_re": f"the negative sequence over the positive, |n| < {_lim(lib.LS_EMF_NEG_MAX)} (beyond: not a "
                  "three-phase motor)",
        "neg_im": f"the negative sequence over the positive, |n| < {_lim(lib.LS_EMF_NEG_MAX)}",
    },
}

#: the injection's largest share of the linear range at the under-voltage limit (ls_drive_init's)
V_INJ_SHARE_MAX = float(lib.LS_DRIVE_V_INJ_SHARE_MAX)
#: -, the least share of the force constant a d-current may leave (ls_drive_init's; ls_drive.h)
KF_SHARE_MIN = float(lib.LS_DRIVE_KF_SHARE_MIN)
#: -, LS_MODE_COMMISSION's largest cal.slope (ls_drive.h)
CAL_SLOPE_MAX = float(lib.LS_DRIVE_CAL_SLOPE_MAX)
#: -, LS_MODE_COMMISSION learns at |v| >= this share of the trajectory's v_max (ls_drive.h)
LEARN_CRUISE = float(lib.LS_DRIVE_LEARN_CRUISE)
#: the EMF low-pass corner's largest share of the sampling rate (ls_emf_init's)
EMF_FLPF_FS_MAX = float(lib.LS_EMF_FLPF_FS_MAX)
#: -, the SPEED step runs the EMF estimate from this share of ``fuse.v_lo`` up (ls_fuse_emf_run)
FUSE_EMF_ON = float(lib.LS_FUSE_EMF_ON)
#: -, and stops it below this share of ``fuse.v_lo``
FUSE_EMF_OFF = float(lib.LS_FUSE_EMF_OFF)
#: the largest ``|ripple_c| + |ripple_s|`` ls_drive_init accepts
RIPPLE_MAX = float(lib.LS_DRIVE_RIPPLE_MAX)
#: the most start-up pulse pairs ls_startup_init accepts
STARTUP_PAIRS_MAX = int(lib.LS_STARTUP_PAIRS_MAX)
#: the shortest start-up pulse ls_startup_init accepts, PWM periods (t_pulse rounded)
STARTUP_PULSE_STEPS_MIN = int(lib.LS_STARTUP_PULSE_STEPS_MIN)
#: the shortest rest before a start-up pulse ls_startup_init accepts, PWM periods (t_rest rounded)
STARTUP_REST_STEPS_MIN = int(lib.LS_STARTUP_REST_STEPS_MIN)


def injection_fits(amplitude: float, v_dc_min: float) -> bool:
    """Whether an injection leaves the fundamental its share of the bus (the C library's rule).

    ``ls_drive_inject_fits``: ``amplitude sqrt(3) / v_dc_min`` below :data:`V_INJ_SHARE_MAX`, as
    ``ls_drive_init`` decides it (in the library's real type).

    Parameters
    ----------
    amplitude : float
        The injection's amplitude, V (peak).
    v_dc_min : float
        The under-voltage limit, V.

    Returns
    -------
    bool
        True when ``ls_drive_init`` accepts the pair.
    """
    return bool(lib.ls_drive_inject_fits(amplitude, v_dc_min))


def observer_gains(f_bw: float, mech: bool) -> tuple[float, ...]:
    """The observer's gains for a bandwidth, by the C library's rule (``ls_observer_gains``).

    Parameters
    ----------
    f_bw : float
        Bandwidth, Hz (all poles at ``-2 pi f_bw``).
    mech : bool
        The mechanical observer (k1, k2, k3), else the PLL (k1, k2).

    Returns
    -------
    tuple of float
        ``(k1, k2, k3)`` (1/s, 1/s^2, 1/s^3) or ``(k1, k2)``, as the library computes them.
    """
    cfg = ffi.new("ls_observer_cfg *")
    cfg.type = lib.LS_OBS_MECH if mech else lib.LS_OBS_PLL
    lib.ls_observer_gains(cfg, f_bw)
    return (float(cfg.k1), float(cfg.k2), float(cfg.k3)) if mech else (float(cfg.k1), float(cfg.k2))


#: the fields of ``ls_emf_cfg``, in declaration order
EMF_FIELDS = tuple(name for name, _ in ffi.typeof("ls_emf_cfg").fields)
#: the array fields of ``ls_emf_cfg`` (the flux harmonics' slots) and their lengths
EMF_ARRAYS = {name: f.type.length for name, f in ffi.typeof("ls_emf_cfg").fields if f.type.kind == "array"}


def _emf_value(source: str, key: str, value: Any):
    """One ``ls_emf_cfg`` field's value: a number, or for an array field a sequence of its length
    (integers for an unsigned field's, such as the harmonics' orders)."""
    n = EMF_ARRAYS.get(key)
    if n is None:
        return _number(value, source, key)
    seq = list(value) if isinstance(value, (list, tuple, np.ndarray)) else None
    if seq is None or len(seq) != n:
        raise InputError(source, key, f"expected {n} numbers, got {_show(value)}")
    out = [_number(v, source, f"{key}[{i}]") for i, v in enumerate(seq)]
    if key == "harm_order":
        if not all(float(v).is_integer() and 0 <= v < 2**32 for v in out):
            raise InputError(source, key, f"expected {n} whole numbers >= 0, got {_show(value)}")
        out = [int(v) for v in out]
    return out


def emf_init(values: dict):
    """An ``ls_emf`` (the extended-EMF position error, ``linsense/ls_emf.h``) initialised by the C
    library, or :class:`ConfigError` naming each field ``ls_emf_init`` refuses.

    A field is named when it alone, put into a configuration the library accepts (the given
    sampling rate, unit inductances, no uncertainty, a magnet flux without imbalance), is refused;
    else each field whose accepted value alone makes the given configuration accepted (a pair that
    only fails together, such as an imbalance without a magnet flux); else every field.

    Parameters
    ----------
    values : dict
        Every field of ``ls_emf_cfg`` (:data:`EMF_FIELDS`), SI units.

    Returns
    -------
    tuple of (cdata ``ls_emf *``, cdata ``ls_emf_cfg *``)
        The state and its configuration.

    Raises
    ------
    InputError
        A field missing, unknown or not a real number.
    ConfigError
        ``ls_emf_init`` refuses the configuration.
    """
    missing = [k for k in EMF_FIELDS if k not in values]
    unknown = [k for k in values if k not in EMF_FIELDS]
    if missing or unknown:
        raise InputError("emf_init", (missing or unknown)[0],
                         f"{'missing' if missing else 'unknown'}: the fields are {', '.join(EMF_FIELDS)}")
    vals = {k: _emf_value("emf_init", k, v) for k, v in values.items()}
    state = ffi.new("ls_emf *")
    cfg = ffi.new("ls_emf_cfg *", vals)
    status = lib.ls_emf_init(state, cfg)
    if status == lib.LS_OK:
        return state, cfg
    fs = vals["fs"] if math.isfinite(vals["fs"]) and vals["fs"] > 0 else 16000.0
    good = dict.fromkeys(EMF_FIELDS, 0.0) | {k: [0] * n for k, n in EMF_ARRAYS.items()}
    good |= {"fs": fs, "l_d": 1.0e-3, "l_q": 1.0e-3, "f_lpf": 0.01 * fs,
                                              "omega_max": 0.01 * fs, "psi_pm": 1.0}

    def accepted(v: dict) -> bool:
        return lib.ls_emf_init(ffi.new("ls_emf *"), ffi.new("ls_emf_cfg *", v)) == lib.LS_OK

    blamed = ({k: v for k, v in vals.items() if not accepted(good | {k: v})}
              or {k: v for k, v in vals.items() if accepted(vals | {k: good[k]})})
    raise config_error("ls_emf", blamed or vals, status)


def emf_omega_min(values: dict, i_mag: float, psi: float, eps_max: float, k_r: float = 1.0) -> float:
    """The lowest electrical speed from which the EMF estimate's bound holds (``ls_emf_omega_min``).

    Parameters
    ----------
    values : dict
        The ``ls_emf_cfg`` fields (:func:`emf_init`).
    i_mag : float
        The current's magnitude, A (on the q-axis).
    psi : float
        The magnets' flux linkage, Wb.
    eps_max : float
        The bound on the position error, rad, in (0, pi/2).
    k_r : float, optional
        The resistance's scale (a warm winding).

    Returns
    -------
    float
        rad/s; ``inf`` when no speed up to ``omega_max`` reaches the bound.

    Raises
    ------
    ConfigError
        ``ls_emf_init`` refuses ``values``.
    InputError
        ``i_mag``, ``eps_max`` or ``k_r`` out of their ranges.
    """
    # (the C function answers LS_REAL_MAX, "never", for these too: refused here, not read as never)
    i_mag = real(i_mag, "emf_omega_min", "i_mag", 0.0, what="a current in A")
    eps_max = real(eps_max, "emf_omega_min", "eps_max", 0.0, 0.5 * math.pi, low_open=True, high_open=True,
                   what="an angle in rad")
    k_r = real(k_r, "emf_omega_min", "k_r", 0.0, low_open=True, what="a resistance scale")
    state, _ = emf_init(values)
    w = float(lib.ls_emf_omega_min(state, i_mag, psi, eps_max, k_r))
    return math.inf if w >= float(np.finfo(REAL).max) else w


_ENUMS = {
    ("ls_biquad", "type"): {"lowpass": lib.LS_BIQUAD_LOWPASS, "bandpass": lib.LS_BIQUAD_BANDPASS,
                            "notch": lib.LS_BIQUAD_NOTCH},
    ("ls_demod", "method"): {"product": lib.LS_DEMOD_PRODUCT, "heterodyne": lib.LS_DEMOD_HETERODYNE},
    ("ls_observer", "type"): {"pll": lib.LS_OBS_PLL, "mech": lib.LS_OBS_MECH},
    ("ls_drive", "mode"): {"off": lib.LS_MODE_OFF, "sensored": lib.LS_MODE_SENSORED,
                           "sensorless_lut": lib.LS_MODE_SENSORLESS_LUT,
                           "sensorless_nolut": lib.LS_MODE_SENSORLESS_NOLUT,
                           "calibration": lib.LS_MODE_CALIBRATION, "startup": lib.LS_MODE_STARTUP,
                           "commission": lib.LS_MODE_COMMISSION},
}


def config_error(module: str, fields: dict, status: int, detail: str = "", func: str = "") -> ConfigError:
    """The :class:`~linsense.errors.ConfigError` of a configuration refused by the C library's
    ``ls_<module>_init`` (non-zero ``ls_status``), its message naming each field with what C allows.

    Parameters
    ----------
    module : str
        C module, e.g. ``"ls_inject"``.
    fields : dict
        The offending field(s) and their values (empty when no single field could be named).
    status : int
        The ``ls_status`` returned (``LS_ERR_NULL`` = 1, ``LS_ERR_PARAM`` = 2).
    detail : str, optional
        Extra explanation appended to the message.
    func : str, optional
        The refusing C function (default ``<module>_init``).

    Returns
    -------
    ConfigError
        The error to raise.
    """

    rules = _RULES.get(module, {})
    parts = []
    for k, v in dict(fields).items():
        rule = rules.get(k)
        parts.append(f"{k} = {_show(v)}" + (f" (allowed: {rule})" if rule else ""))
    what = "; ".join(parts) if parts else "configuration"
    func = func or f"{module}_init"
    msg = f"{module}: {what} refused by {func} ({_STATUS.get(int(status), int(status))})"
    return ConfigError(module, fields, status, msg + (f": {detail}" if detail else ""))


def _show(v: Any) -> str:
    if isinstance(v, Lut):
        return f"<Lut of {v.len} points>"
    if isinstance(v, float):
        return f"{v:.6g}"
    if isinstance(v, str):
        return v
    return repr(v)


# ------------------------------------------------------------------------------ helpers
def _in(x: Any, n: int | None = None) -> np.ndarray:
    """Contiguous float64 copy/view of ``x``, broadcast to ``n`` samples if given."""
    a = np.asarray(x, dtype=np.float64)
    if n is not None:
        a = np.broadcast_to(a, (n,))
    return np.ascontiguousarray(a, dtype=np.float64)


def _p(a: np.ndarray | None, ctype: str = "double[]"):
    """cffi pointer to a numpy array's memory (NULL for None)."""
    return ffi.NULL if a is None else ffi.from_buffer(ctype, a)


def _enum(module: str, field: str, value: Any) -> int:
    if isinstance(value, str):
        table = _ENUMS[(module, field)]
        try:
            return table[value.lower()]
        except KeyError:
            raise config_error(module, {field: value}, lib.LS_ERR_PARAM,
                              f"one of {', '.join(table)}{closest_key(value.lower(), table)}") from None
    table = _ENUMS[(module, field)]
    integral = isinstance(value, numbers.Integral) and not isinstance(value, bool | np.bool_)
    if not (integral and value in table.values()):
        raise InputError(module, field, f"expected one of {', '.join(table)} (or its LS_ value, an int), "
                         f"got {brief(value)} ({type(value).__name__})")
    return int(value)


def _number(value: Any, source: str, name: str) -> float:
    """``value`` as a float if it is a real number (NaN and infinities pass: the C library decides),
    else InputError naming ``name`` (a string "1" was read as 1.0, None was a TypeError)."""
    if isinstance(value, bool | np.bool_) or not isinstance(value, numbers.Real):
        raise InputError(source, name, f"expected a real number, got {brief(value)} ({type(value).__name__})")
    try:
        return float(value)
    except OverflowError:  # (an int beyond a double)
        raise InputError(source, name, f"{brief(value)} is beyond the range of a double") from None


def _enum_name(module: str, field: str, value: Any) -> Any:
    for name, v in _ENUMS[(module, field)].items():
        if v == value:
            return name
    return value


def drive_default_cfg():
    """``ls_drive_default_cfg``: the documented defaults (16 kHz, 12 V / 1 kHz, ecce2010 motor).

    Returns
    -------
    cdata ``ls_drive_cfg *``
        A fresh, caller-owned configuration to edit field by field.
    """
    cfg = ffi.new("ls_drive_cfg *")
    lib.ls_drive_default_cfg(cfg)
    return cfg


def to_pos(theta: float):
    """Unwrapped electrical angle (rad) -> ``ls_pos`` (period count + angle in [0, 2 pi)).

    Parameters
    ----------
    theta : float
        Unwrapped electrical angle, rad.

    Returns
    -------
    cffi ``ls_pos``
        The normalised position (``ls_pos_norm``).

    Raises
    ------
    InputError
        ``theta`` not a real number.
    ConfigError
        ``theta`` not finite or beyond the firmware's position range (``LS_POS_PERIOD_MAX``
        periods either side, docs/firmware.md).
    """
    theta = _number(theta, "to_pos", "theta")
    if not (np.isfinite(theta) and abs(theta) / _TWO_PI < lib.LS_POS_PERIOD_MAX):
        raise config_error("ls_pos", {"theta": theta}, lib.LS_ERR_PARAM,
                          f"a position is finite and within +-{lib.LS_POS_PERIOD_MAX} electrical periods",
                          func="ls_pos_norm")
    period = int(np.floor(theta / _TWO_PI))
    p = ffi.new("ls_pos *", {"period": period, "theta": theta - period * _TWO_PI})
    return lib.ls_pos_norm(p[0])


def from_pos(p) -> float:
    """``ls_pos`` -> unwrapped electrical angle (rad), in double.

    Parameters
    ----------
    p : cffi ``ls_pos``
        The position.

    Returns
    -------
    float
        rad.

    Raises
    ------
    InputError
        ``p`` not an ``ls_pos`` (:func:`to_pos`).
    """
    if not (isinstance(p, ffi.CData) and ffi.typeof(p) is ffi.typeof("ls_pos")):
        raise InputError("from_pos", "p", f"expected an ls_pos (to_pos), got {brief(p)} ({type(p).__name__})")
    return p.period * _TWO_PI + float(p.theta)


# ------------------------------------------------------------------------------ refusals
# ``ls_drive_init`` answers a configuration with one status. Which field broke which rule is found
# by asking the C library itself (no C limit restated in Python): each field in turn is put back to
# the firmware's default (``ls_drive_default_cfg``) in a copy of the refused configuration, and the
# field whose default makes ``ls_drive_init`` accept it is the one at fault; its limit is then read
# by bisection between the default (accepted) and the value given (refused). :class:`Drive` names
# the C field; the simulator (:mod:`linsense.sim.refusal`) runs the same search over the scenario
# keys that fill the fields (:mod:`linsense.tune.cfgmap`) and names the key.


@functools.cache
def cfg_fields(ctype: str = "ls_drive_cfg") -> tuple[str, ...]:
    """The struct paths of every number, boolean and enum of a C configuration (pointers left out).

    Parameters
    ----------
    ctype : str, optional
        The C struct, e.g. ``"ls_drive_cfg"``.

    Returns
    -------
    tuple of str
        Dotted paths (``"obs.mass"``; an array's items ``"emf.harm_re[0]"``), in declaration order.
    """
    def walk(t, prefix: str) -> list[str]:
        out = []
        for name, f in t.fields:
            if f.type.kind == "struct":
                out += walk(f.type, f"{prefix}{name}.")
            elif f.type.kind in ("primitive", "enum"):
                out.append(prefix + name)
            elif f.type.kind == "array" and f.type.item.kind in ("primitive", "enum"):
                out += [f"{prefix}{name}[{i}]" for i in range(f.type.length)]
        return out

    return tuple(walk(ffi.typeof(ctype), ""))


#: fields ``ls_drive_init`` requires to hold one value (its rule: every module at the drive's ``fs``,
#: one pole pitch), searched together: the name of each family -> its fields
EQUAL_FIELDS = {
    "fs": tuple(p for p in cfg_fields() if p.rsplit(".", 1)[-1] in ("fs", "f_pwm")),
    "pole_pitch": tuple(p for p in cfg_fields() if p.rsplit(".", 1)[-1] == "pole_pitch"),
}


def cfg_get(cfg, path: str):
    """The field ``path`` (dotted) of a cffi struct pointer.

    Parameters
    ----------
    cfg : cdata
        The configuration.
    path : str
        Dotted field path.

    Returns
    -------
    object
        Its value.
    """
    obj = cfg
    for part in path.split("."):
        name, _, index = part.partition("[")
        obj = getattr(obj, name)
        if index:
            obj = obj[int(index[:-1])]
    return obj


def cfg_set(cfg, path: str, value) -> None:
    """Set the field ``path`` (dotted) of a cffi struct pointer.

    Parameters
    ----------
    cfg : cdata
        The configuration.
    path : str
        Dotted field path.
    value : object
        The value.
    """
    *head, last = path.split(".")
    obj = cfg
    for part in head:
        obj = getattr(obj, part)
    set_member(obj, last, value)


def set_member(obj, member: str, value) -> None:
    """Set a struct's member, or an item of its array member (``"harm_re[0]"``).

    Parameters
    ----------
    obj : cdata
        The struct.
    member : str
        The member's name, with ``[i]`` for an array's item.
    value : object
        The value.
    """
    name, _, index = member.partition("[")
    if index:
        getattr(obj, name)[int(index[:-1])] = value
    else:
        setattr(obj, name, value)


def cfg_copy(cfg):
    """A copy of an ``ls_drive_cfg``.

    Parameters
    ----------
    cfg : cdata ``ls_drive_cfg *``
        The configuration.

    Returns
    -------
    cdata ``ls_drive_cfg *``
        A fresh copy (the tables it points to are shared).
    """
    c = ffi.new("ls_drive_cfg *")
    ffi.memmove(c, cfg, ffi.sizeof("ls_drive_cfg"))
    return c


def drive_accepts(cfg) -> bool:
    """Whether ``ls_drive_init`` accepts ``cfg``.

    Parameters
    ----------
    cfg : cdata ``ls_drive_cfg *``
        The configuration.

    Returns
    -------
    bool
        True for ``LS_OK``.
    """
    return lib.ls_drive_init(ffi.new("ls_drive *"), cfg) == lib.LS_OK


def refused_group(cfg, groups: dict[str, tuple[str, ...]], fields: tuple[str, ...],
                  together: frozenset[str] = frozenset()):
    """The group of fields a refused ``cfg`` is refused for, the field at fault and a configuration
    in which it alone is refused; None when no single group explains the refusal.

    First the group whose fields, put back together to the firmware's default, make ``ls_drive_init``
    accept the configuration (in the order of ``groups``); then, in the field of it refused by itself
    (the group's others at their defaults). Else a group refused by itself whatever the rest: its
    fields in the configuration accepted without them (a rule of its own field alone, such as the
    largest sampling rate). A group of ``together`` (the sampling rates, one value) is only ever set
    as a whole.

    Parameters
    ----------
    cfg : cdata ``ls_drive_cfg *``
        The refused configuration.
    groups : dict
        Name -> the struct paths of its fields that differ from the default, in the order to try.
    fields : tuple of str
        Every field searched (the configuration accepted without a group is built from them).
    together : frozenset of str, optional
        Names of groups whose fields are set together.

    Returns
    -------
    tuple of (str, tuple of str, cdata) or None
        ``(name, paths, base)``: the group, the field(s) at fault, the configuration to find its
        limit in.
    """
    default = drive_default_cfg()

    def reset(c, paths):
        for path in paths:
            cfg_set(c, path, cfg_get(default, path))
        return c

    for name, paths in groups.items():
        if name in together or not drive_accepts(reset(cfg_copy(cfg), paths)):
            continue
        for path in paths:
            base = reset(cfg_copy(cfg), [p for p in paths if p != path])
            if not drive_accepts(base):
                return name, (path,), base
        return name, paths[:1], cfg_copy(cfg)
    for name, paths in groups.items():  # (a field refused by itself, whatever the rest)
        near = cfg_copy(default)  # (the configuration as far as it is accepted without this group)
        for other in fields:
            if other not in paths and cfg_get(near, other) != cfg_get(cfg, other):
                trial = cfg_copy(near)
                cfg_set(trial, other, cfg_get(cfg, other))
                if drive_accepts(trial):
                    near = trial
        for one in ((paths,) if name in together else tuple((p,) for p in paths)):
            base = cfg_copy(near)
            for path in one:
                cfg_set(base, path, cfg_get(cfg, path))
            if not drive_accepts(base):
                return name, one, base
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
    c = cfg_copy(cfg)
    good = float(cfg_get(drive_default_cfg(), paths[0]))
    bad = float(cfg_get(c, paths[0]))
    integer = isinstance(cfg_get(c, paths[0]), int)
    if not math.isfinite(good) or math.isnan(bad):
        return None
    if math.isinf(bad):  # (an overflow: from the largest finite value the field holds)
        bad = math.copysign(float(np.finfo(REAL).max), bad)

    def put(v: float) -> float:
        for p in paths:
            cfg_set(c, p, int(v) if integer else v)
        return float(cfg_get(c, paths[0]))  # (as the C field holds it: LS_REAL may be a float)

    put(good)
    if not drive_accepts(c):
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
        if drive_accepts(c):
            good = mid
        else:
            bad = mid
    return good


def limit_rule(value: float, lim: float | None) -> tuple[float | None, str]:
    """The words for a refused ``value`` and the limit :func:`c_limit` found.

    Parameters
    ----------
    value : float
        The refused value, in the field's unit.
    lim : float or None
        The nearest value accepted.

    Returns
    -------
    lim : float or None
        The limit to name, None where the rule is "above 0" or "finite" (the smallest or largest
        number the field holds) or unknown.
    words : str
        ``"above the largest"`` or ``"below the smallest"`` with a limit; else the rule.
    """
    if math.isnan(value):
        return None, "it must be a finite number"
    if lim is not None and 0.0 < abs(lim) < float(np.finfo(REAL).tiny):
        return None, "it must be above 0"
    if lim is not None and abs(lim) > 0.5 * float(np.finfo(REAL).max):
        return None, "it must be finite"
    if lim is None:
        return None, "refused"
    return lim, "above the largest" if value > lim else "below the smallest"


def explain_drive_refusal(cfg) -> tuple[dict, str] | None:
    """The field(s) of a configuration ``ls_drive_init`` refuses, their value and the limit.

    :func:`refused_group` over every field of ``ls_drive_cfg`` that differs from the default (the
    sampling rates together), then :func:`c_limit`.

    Parameters
    ----------
    cfg : cdata ``ls_drive_cfg *``
        The refused configuration.

    Returns
    -------
    tuple of (dict, str) or None
        ``({field: value}, words)`` naming the limit, or None when no single field explains the
        refusal.
    """
    default = drive_default_cfg()
    families = {p for paths in EQUAL_FIELDS.values() for p in paths}
    singles = tuple(p for p in cfg_fields() if p not in families)
    groups = {p: (p,) for p in singles if cfg_get(cfg, p) != cfg_get(default, p)}
    for name, paths in EQUAL_FIELDS.items():
        if any(cfg_get(cfg, p) != cfg_get(default, p) for p in paths):
            groups[name] = paths
    found = refused_group(cfg, groups, cfg_fields(), frozenset(EQUAL_FIELDS))
    if found is None:
        return None
    name, paths, base = found
    value = cfg_get(base, paths[0])
    others = {p: cfg_get(base, p) for p in paths[1:] if cfg_get(base, p) != value}
    if others:  # (a family of one value that holds several)
        (p, v), more = next(iter(others.items())), len(others) - 1
        also = f" (and {more} more field{'s' if more > 1 else ''})" if more else ""
        return {paths[0]: value}, (f"but {p} = {_show(float(v))}{also}: ls_drive_init takes one value for "
                                   f"{', '.join(paths[:2])} ... {paths[-1]} ({len(paths)} fields)")
    lim, words = limit_rule(float(value), c_limit(base, paths))
    if lim is None:
        text = words
    else:
        text = f"{words} value ls_drive_init accepts with the rest of this configuration, {lim:.6g}"
    if len(paths) > 1:
        text += f" (set together: {', '.join(paths)})"
    return {paths[0]: value}, text


# ------------------------------------------------------------------------------ LUT
class Lut:
    """An ``ls_lut`` over a float32 copy of ``values`` (kept alive by this object).

    Parameters
    ----------
    values : array_like, shape (N,)
        Table at ``theta_k = 2 pi k / N`` (unit of the table, e.g. rad), as written by
        ``linsense lut``; a :class:`linsense.compensation.lut.Lut` is accepted too.

    Attributes
    ----------
    ptr : cdata ``ls_lut *``
        The initialised C table, to put into a ``comp`` or ``gain_table`` field.
    table : ndarray of float32
        The backing array the C table borrows (read-only).

    Raises
    ------
    InputError
        ``values`` is not one dimension of real numbers, or a value is beyond a float32.
    ConfigError
        If ``ls_lut_init`` refuses the table (fewer than 4 points, non-finite values).
    """

    def __init__(self, values: Any) -> None:
        values = getattr(values, "values", values)
        # one dimension of real numbers (a string was a ValueError, a 2-D array was flattened
        # into one table, booleans were taken as 0 and 1)
        a = _real_array("Lut", "values", values, "a table of shape (N,)", ((None,),))
        big = np.abs(a) > np.finfo(np.float32).max
        if np.any(big & np.isfinite(a)):
            k = int(np.flatnonzero(big & np.isfinite(a))[0])
            raise InputError("Lut", f"values[{k}]", f"{float(a[k])!r} is beyond the range of the table's "
                             f"float32 ({float(np.finfo(np.float32).max):.4g})")
        table = a.astype(np.float32)
        table.setflags(write=False)
        self.table = table
        self.len = table.size
        # the C struct stores this pointer: keep both the array and the cffi buffer alive
        self._buf = ffi.from_buffer("float[]", table) if table.size else ffi.NULL
        self._cfg = ffi.new("ls_lut_cfg *", {"table": self._buf, "len": table.size})
        self.ptr = ffi.new("ls_lut *")
        status = lib.ls_lut_init(self.ptr, self._cfg)
        if status != lib.LS_OK:
            if table.size >= 4:
                bad = int(np.flatnonzero(~np.isfinite(table))[0]) if not np.all(np.isfinite(table)) else -1
                fields = {f"table[{bad}]": float(table[bad])} if bad >= 0 else {}
            else:
                fields = {"len": table.size}
            raise config_error("ls_lut", fields, status)

    def __call__(self, theta: Any) -> np.ndarray:
        """``ls_lut_step`` at each ``theta`` (rad); returns float64 of ``theta``'s shape."""
        t = np.asarray(theta, dtype=np.float64)
        flat = _in(t.ravel())
        out = np.empty_like(flat)
        lib.ls_py_lut_run(self.ptr, _p(flat), flat.size, _p(out))
        return out.reshape(t.shape)


class LearnedLut(Lut):
    """A :class:`Lut` the drive writes: ``LS_MODE_COMMISSION``'s table (``cfg.cal.table``, which
    ``cfg.demod.comp`` reads), with its work ``cfg.cal.learn`` (4 ``len`` floats).

    Parameters
    ----------
    values : array_like, shape (N,)
        The table it starts from, rad.

    Attributes
    ----------
    table : ndarray of float32
        The table as the drive leaves it (read it after the run).
    learn : cdata ``float[4 N]``
        The forward and backward estimates, rad, then the time each point was seen moving forward,
        backward, s (``ls_drive.h``, ``ls_cal_cfg.learn``).
    """

    def __init__(self, values: Any) -> None:
        super().__init__(values)
        self.table.setflags(write=True)  # (the drive writes it: LS_MODE_COMMISSION)
        self.learn = ffi.new("float[]", 4 * self.len)

    def attach(self, cfg: Any) -> None:
        """Point ``cfg.cal`` (an ``ls_drive_cfg *``) at the table and its work, ``cal.points`` its length.

        Parameters
        ----------
        cfg : cdata ``ls_drive_cfg *``
            The configuration, before ``ls_drive_init``.
        """
        cfg.cal.table = ffi.cast("float *", self._buf)
        cfg.cal.learn = self.learn
        cfg.cal.points = self.len


def make_lut(values: Any) -> Lut:
    """A :class:`Lut` from a numpy array (or a compensation ``Lut``); see :class:`Lut`.

    Parameters
    ----------
    values : array_like or Lut or linsense.compensation.lut.Lut
        The table over one electrical period (its ``values`` for a compensation ``Lut``; a
        :class:`Lut` is returned as it is).

    Returns
    -------
    Lut
        The C table over a float32 copy of the values.

    Raises
    ------
    InputError
        ``values`` is not one dimension of real numbers, or a value is beyond a float32.
    ConfigError
        If ``ls_lut_init`` refuses the table.
    """
    return values if isinstance(values, Lut) else Lut(values)


# ------------------------------------------------------------------------------ drive
class Drive:
    """``ls_drive``: the complete per-PWM-period controller, configured and set up from Python
    (the simulator steps it in C; ``ls_drive_step`` is ``lib.ls_drive_step(drive.state, ...)``).

    Parameters
    ----------
    cfg : cdata ``ls_drive_cfg *``, optional
        Configuration (default: :func:`drive_default_cfg`). It is copied by ``ls_drive_init``;
        tables it points to must stay alive: pass them as ``comp``/``gain_table`` instead.
    comp : array_like or Lut, optional
        Compensation table for ``cfg.demod.comp`` (kept alive by this object).
    gain_table : array_like or Lut, optional
        Position-scheduled demodulator gain for ``cfg.demod.gain_table``.
    comp_r, gain_r : array_like or Lut, optional
        The compensation and gain tables' slopes in the resistance's scale, for
        ``cfg.demod.comp_r`` and ``cfg.demod.gain_r`` (:func:`linsense.compensation.lut.lut_r_slope`,
        :func:`linsense.tune.design.gain_r_slope`).

    Raises
    ------
    InputError
        ``cfg`` not an ``ls_drive_cfg *`` (:func:`drive_default_cfg`), a table not one dimension of
        real numbers.
    ConfigError
        If ``ls_drive_init`` refuses: the message names the C field at fault, its value and the
        limit ``ls_drive_init`` sets with the rest of the configuration (:func:`explain_drive_refusal`;
        a scenario's refusal names its key: :mod:`linsense.sim.refusal`), else the sections refused.
    """

    def __init__(self, cfg: Any = None, *, comp: Any = None, gain_table: Any = None,
                 comp_r: Any = None, gain_r: Any = None) -> None:
        if cfg is not None and not (isinstance(cfg, ffi.CData)
                                    and ffi.typeof(cfg) is ffi.typeof("ls_drive_cfg *")):
            raise InputError("Drive", "cfg", f"expected None or an ls_drive_cfg * (ctrl.drive_default_cfg(), "
                             f"edited field by field), got {brief(cfg)} ({type(cfg).__name__})")
        self.cfg = drive_default_cfg() if cfg is None else cfg
        self.comp = None if comp is None else make_lut(comp)
        self.gain_table = None if gain_table is None else make_lut(gain_table)
        self.comp_r = None if comp_r is None else make_lut(comp_r)
        self.gain_r = None if gain_r is None else make_lut(gain_r)
        if self.comp_r is not None:
            self.cfg.demod.comp_r = self.comp_r.ptr
        if self.gain_r is not None:
            self.cfg.demod.gain_r = self.gain_r.ptr
        if self.comp is not None:
            self.cfg.demod.comp = self.comp.ptr
        if self.gain_table is not None:
            self.cfg.demod.gain_table = self.gain_table.ptr
        self.state = ffi.new("ls_drive *")
        status = lib.ls_drive_init(self.state, self.cfg)
        if status == lib.LS_ERR_VERSION:
            raise config_error("ls_drive", {"lib_version": int(self.cfg.lib_version)}, status,
                               f"the configuration was made for another version of the library (this "
                               f"one's is {int(drive_default_cfg().lib_version)}): regenerate it")
        if status != lib.LS_OK:
            told = explain_drive_refusal(self.cfg)
            if told is not None:
                raise config_error("ls_drive", *told[:1], status, told[1])
            raise config_error("ls_drive", self._blame(), status, self._detail())

    _SECTIONS = (("inject", "ls_inject"), ("bpf", "ls_biquad"), ("sep", "ls_biquad"),
                 ("demod", "ls_demod"), ("obs", "ls_observer"), ("enc_obs", "ls_observer"),
                 ("current", "ls_current"), ("pos", "ls_posctrl"), ("traj", "ls_traj"),
                 ("mod", "ls_mod"), ("prot", "ls_protect"))

    def _blame(self) -> dict:
        bad = {}
        fs = float(self.cfg.fs)
        for path in ("inject", "bpf", "sep", "demod", "obs", "enc_obs", "current", "traj", "prot",
                     "pos.speed", "dtres"):
            obj = self.cfg
            for part in path.split("."):
                obj = getattr(obj, part)
            if float(obj.fs) != fs:
                bad[f"{path}.fs"] = f"{float(obj.fs):g} Hz differs from the drive's fs = {fs:g} Hz"
        if self.cfg.startup.pairs != 0 and float(self.cfg.startup.fs) != fs:
            bad["startup.fs"] = f"{float(self.cfg.startup.fs):g} Hz differs from the drive's fs = {fs:g} Hz"
        sections = (self._SECTIONS + ((("dtres", "ls_dtres"),) if self.cfg.hf_dtres else ())
                    + ((("startup", "ls_startup"),) if self.cfg.startup.pairs != 0 else ()))
        for section, module in sections:
            init = getattr(lib, module + "_init")
            if init(ffi.new(module + " *"), ffi.addressof(self.cfg, section)) != lib.LS_OK:
                bad[section] = f"refused by {module}_init"
        return bad

    def _detail(self) -> str:
        if self._blame():
            return "see the named sections"
        return ("a drive-level rule: every module at the drive's fs, bpf a band-pass, sep a notch or "
                "low-pass, positive fs/pole_pitch/force_constant/i_max/enc_counts, delay_comp >= 0, "
                f"injection amplitude * sqrt(3) < {V_INJ_SHARE_MAX:g} prot.v_dc_min, valid cal settings")

    def set_mode(self, mode: str | int) -> None:
        """``ls_drive_set_mode``.

        Parameters
        ----------
        mode : str or int
            A name ("sensorless_lut", ...) or an ``LS_MODE_*`` value.

        Raises
        ------
        InputError
            ``mode`` neither a name nor an int.
        ConfigError
            If the mode needs a table or setting the configuration lacks, or an unknown name.
        """
        m = _enum("ls_drive", "mode", mode)
        status = lib.ls_drive_set_mode(self.state, m)
        if status != lib.LS_OK:
            raise config_error("ls_drive", {"mode": _enum_name("ls_drive", "mode", m)}, status,
                              "the mode needs cfg.demod.comp (sensorless_lut) or cfg.cal.table (calibration)",
                              func="ls_drive_set_mode")

    def set_position(self, theta: float) -> None:
        """Tell the HF observer where the mover is.

        Parameters
        ----------
        theta : float
            Unwrapped electrical angle, rad.

        Raises
        ------
        InputError
            ``theta`` not a real number.
        ConfigError
            When refused (:func:`to_pos`).
        """
        st = lib.ls_drive_set_position(self.state, to_pos(theta))
        if st != lib.LS_OK:
            raise config_error("ls_drive", {"theta": theta}, st, func="ls_drive_set_position")

    def set_load(self, f_load: float) -> None:
        """``ls_drive_set_load``: start in equilibrium with a load force; call after :meth:`set_position`.

        Parameters
        ----------
        f_load : float
            Load force, N, opposing positive motion when > 0.

        Raises
        ------
        InputError
            ``f_load`` not a real number.
        ConfigError
            When ``ls_drive_set_load`` refuses it (a force that is not finite in ``LS_REAL``).
        """
        st = lib.ls_drive_set_load(self.state, _number(f_load, "Drive.set_load", "f_load"))
        if st != lib.LS_OK:
            raise config_error("ls_drive", {"f_load": f_load}, st, func="ls_drive_set_load")

def _shape_ok(shape: tuple, shapes: tuple) -> bool:
    """``shape`` is one of ``shapes`` (None in one of them: any length)."""
    return any(len(w) == len(shape) and all(a is None or a == b for a, b in zip(w, shape, strict=True))
               for w in shapes)


def _as_array(source: str, key: str, value: Any, what: str) -> np.ndarray:
    """``value`` as a numpy array without conversion (strings, None and objects refused)."""
    try:
        a = np.asarray(value)
    except (TypeError, ValueError) as exc:  # (ragged lists)
        raise InputError(source, key, f"expected {what}, got {_brief(value)} ({exc})") from None
    return a


def _brief(value: Any) -> str:
    r = " ".join(repr(value).split())  # (one line: a numpy array's repr has several)
    return r if len(r) <= 60 else r[:57] + "..."


def _real_array(source: str, key: str, value: Any, what: str, shapes: tuple) -> np.ndarray:
    """``value`` as a float64 array of the given shape; :class:`InputError` naming ``key`` if it is
    not real numbers (bool, complex, strings, None, objects) or not of one of ``shapes``."""
    a = _as_array(source, key, value, what)
    if a.dtype.kind not in "iuf":
        raise InputError(source, key, f"expected {what}, real numbers, got {_brief(value)} "
                         f"(dtype {a.dtype})")
    if not _shape_ok(a.shape, shapes):
        raise InputError(source, key, f"expected {what}, got shape {a.shape}")
    return a.astype(np.float64)


