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

import warnings
from pathlib import Path
from typing import Any

import numpy as np

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
    """Digest of ``csrc/`` and ``tools/build_ctrl.py`` in the source tree.

    Returns
    -------
    str or None
        Hex digest; None outside a source tree (a wheel).
    """
    root = Path(__file__).resolve().parents[2]
    csrc = root / "csrc"
    script = root / "tools" / "build_ctrl.py"
    if not (csrc / "ctrl").is_dir() or not script.is_file():
        return None
    return source_digest(csrc, script)


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

# Allowed ranges of the configuration fields, as documented in the C headers (for messages only:
# the C init functions decide what is refused).
_RULES = {
    "ls_lut": {"len": "number of points over one electrical period, >= 4", "table": "finite values"},
    "ls_biquad": {
        "type": "lowpass, bandpass or notch",
        "f0": "Hz, > 0 and < fs/2",
        "q": "quality factor, 1e-3 .. 1e3",
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
        "gain": "L_q/(L_q - L_d), finite, non-zero, |gain| <= 1e4",
        "comp": "ls_lut with >= 4 points",
        "gain_table": "ls_lut with >= 4 points",
        "min_level": "A^2, >= 0",
    },
    "ls_observer": {
        "type": "pll or mech",
        "fs": "Hz, > 0",
        "k1": "1/s, > 0, k1 Ts <= 1 (beyond, the discrete observer is unstable)",
        "k2": "1/s^2, > 0, k2 Ts^2 <= 1",
        "k3": "1/s^3, > 0 for mech, k3 Ts^3 <= 1",
        "pole_pitch": "m, > 0",
        "mass": "kg, > 0 for mech",
        "omega_max": "rad/s, > 0, omega_max Ts <= pi (half a period per step)",
        "force_max": "N, > 0 for mech; it may move the estimate at most pi per step",
    },
}

_ENUMS = {
    ("ls_biquad", "type"): {"lowpass": lib.LS_BIQUAD_LOWPASS, "bandpass": lib.LS_BIQUAD_BANDPASS,
                            "notch": lib.LS_BIQUAD_NOTCH},
    ("ls_demod", "method"): {"product": lib.LS_DEMOD_PRODUCT, "heterodyne": lib.LS_DEMOD_HETERODYNE},
    ("ls_observer", "type"): {"pll": lib.LS_OBS_PLL, "mech": lib.LS_OBS_MECH},
    ("ls_drive", "mode"): {"off": lib.LS_MODE_OFF, "sensored": lib.LS_MODE_SENSORED,
                           "sensorless_lut": lib.LS_MODE_SENSORLESS_LUT,
                           "sensorless_nolut": lib.LS_MODE_SENSORLESS_NOLUT,
                           "calibration": lib.LS_MODE_CALIBRATION, "startup": lib.LS_MODE_STARTUP},
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
                              f"one of {', '.join(table)}") from None
    return int(value)


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
    ConfigError
        ``theta`` not finite or beyond the firmware's position range (``LS_POS_PERIOD_MAX``
        periods either side, docs/firmware.md).
    """
    theta = float(theta)
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
    """
    return p.period * _TWO_PI + float(p.theta)


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
        # one dimension of real numbers (issue 23: a string was a ValueError, a 2-D array was flattened
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
    ConfigError
        If ``ls_drive_init`` refuses; the message names the sub-configurations whose own init
        refuses them, or the drive-level rule.
    """

    def __init__(self, cfg: Any = None, *, comp: Any = None, gain_table: Any = None,
                 comp_r: Any = None, gain_r: Any = None) -> None:
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
        if status != lib.LS_OK:
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
                "injection amplitude * sqrt(3) < 0.8 prot.v_dc_min, valid cal settings")

    def set_mode(self, mode: str | int) -> None:
        """``ls_drive_set_mode``.

        Parameters
        ----------
        mode : str or int
            A name ("sensorless_lut", ...) or an ``LS_MODE_*`` value.

        Raises
        ------
        ConfigError
            If the mode needs a table or setting the configuration lacks.
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
        ConfigError
            When ``ls_drive_set_load`` refuses it (a force that is not finite in ``LS_REAL``).
        """
        st = lib.ls_drive_set_load(self.state, float(f_load))
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


