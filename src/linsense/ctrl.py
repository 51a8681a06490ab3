"""Python binding of the C99 firmware library (``csrc/``), compiled into :mod:`linsense._ctrl`.

A thin layer over the cffi extension: the raw ``ffi`` and ``lib`` objects give every C function
and struct of ``linsense/ls_*.h``; the classes below create the module states from keyword
arguments in SI units (electrical radians, Hz, s, A, V, N, m, kg), refuse bad configurations with
:class:`ConfigError` (the C ``ls_<module>_init`` decides, Python only names the field), and run
whole numpy arrays through the C code in one call (the loops are C helpers, no Python per
sample). Samples are converted to ``LS_REAL`` (float, as on the MCU) on the way in and returned
as float64 arrays.

Example
-------
>>> from linsense import ctrl
>>> bp = ctrl.Biquad("bandpass", f0=1000.0, q=2.0, fs=16000.0)
>>> y = bp.run(x)                                          # doctest: +SKIP
>>> b, a = bp.coefficients                                 # what the C code computed

Angles passed to and returned by the observer and the drive helpers are *unwrapped* electrical
angles, ``theta = 2 pi period + angle``, computed in double from the C ``ls_pos``.
"""

from __future__ import annotations

import numbers
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any, NamedTuple

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
    "Biquad",
    "Injection",
    "Demodulator",
    "DemodOutput",
    "Observer",
    "ObserverOutput",
    "Drive",
    "DriveOutput",
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
    """Digest of the sources the extension was compiled from ("" for an extension too old to say)."""
    try:
        return ffi.string(lib.ls_py_source_digest()).decode()
    except AttributeError:
        return ""


def source_tree_digest() -> str | None:
    """Digest of ``csrc/`` and ``_build_ctrl.py`` in the source tree, None outside one (wheel)."""
    here = Path(__file__).resolve()
    csrc = here.parents[2] / "csrc"
    script = here.with_name("_build_ctrl.py")
    if not (csrc / "ctrl").is_dir() or not script.is_file():
        return None
    return source_digest(csrc, script)


def _check_stale() -> None:
    """In a source tree (editable install), warn if csrc/ changed since the extension was built."""
    tree = source_tree_digest()
    if tree is not None and built_digest() != tree:
        warnings.warn(
            "linsense._ctrl was compiled from other C sources than those in csrc/ (or another "
            "_build_ctrl.py): rebuild it with `pip install -e .`",
            RuntimeWarning,
            stacklevel=3,
        )


_check_stale()

#: numpy dtype of the C library's ``LS_REAL`` (float32 unless built with ``-DLS_REAL_DOUBLE``).
REAL = np.dtype(np.float32) if lib.ls_py_real_size() == 4 else np.dtype(np.float64)

_TWO_PI = 2.0 * np.pi
_STATUS = {lib.LS_OK: "LS_OK", lib.LS_ERR_NULL: "LS_ERR_NULL", lib.LS_ERR_PARAM: "LS_ERR_PARAM"}

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


def _struct_dict(cdata) -> dict:
    """Fields of a struct (pointer or value) as a dict."""
    t = ffi.typeof(cdata)
    if t.kind == "pointer":
        t = t.item
    return {name: getattr(cdata, name) for name, _ in t.fields}


def _enum(module: str, field: str, value: Any) -> int:
    if isinstance(value, str):
        table = _ENUMS[(module, field)]
        try:
            return table[value.lower()]
        except KeyError:
            raise config_error(module, {field: value}, lib.LS_ERR_PARAM,
                              f"one of {', '.join(table)}") from None
    return int(value)


def _init_module(module: str, init: Callable, state_type: str, cfg_type: str, values: dict,
                 good: dict, keep: list) -> tuple[Any, Any]:
    """Fill a config struct from ``values``, run ``init``; on refusal name the culprit fields.

    A field is named when substituting its value alone into the known-good configuration
    ``good`` (the drive's defaults) makes the C init refuse; if no single field does, the fields
    that differ from ``good`` are named together (a rule that combines fields).
    """

    def fill(vals: dict):
        cfg = ffi.new(cfg_type + " *")
        for k, v in vals.items():
            if isinstance(v, Lut):
                v = v.ptr
            elif v is None:
                v = ffi.NULL
            setattr(cfg, k, v)
        return cfg

    cfg = fill({**good, **values})
    state = ffi.new(state_type + " *")
    status = init(state, cfg)
    if status == lib.LS_OK:
        keep.append(cfg)
        return state, cfg
    blamed = {}
    for k, v in values.items():
        if init(ffi.new(state_type + " *"), fill({**good, k: v})) != lib.LS_OK:
            blamed[k] = v
    if not blamed:
        blamed = {k: v for k, v in values.items() if good.get(k) != v}
    shown = {k: (_enum_name(module, k, v) if (module, k) in _ENUMS else v) for k, v in blamed.items()}
    raise config_error(module, shown, status)


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


def _good(section: str) -> dict:
    """Known-good sub-configuration from the drive defaults (reference for naming bad fields)."""
    return _struct_dict(getattr(drive_default_cfg(), section))


def to_pos(theta: float):
    """Unwrapped electrical angle (rad) -> ``ls_pos`` (period count + angle in [0, 2 pi)).

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
    return lib.ls_py_pos_norm(p[0])


def from_pos(p) -> float:
    """``ls_pos`` -> unwrapped electrical angle (rad), in double."""
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
    """A :class:`Lut` from a numpy array (or a compensation ``Lut``); see :class:`Lut`."""
    return values if isinstance(values, Lut) else Lut(values)


# ------------------------------------------------------------------------------ filters
class Biquad:
    """``ls_biquad``: cookbook low-pass, band-pass or notch filter.

    Parameters
    ----------
    type : {"lowpass", "bandpass", "notch"}
        Filter type.
    f0 : float
        Corner (low-pass) or centre frequency, Hz.
    q : float
        Quality factor (0.7071 gives a Butterworth low-pass).
    fs : float
        Sampling rate, Hz.

    Raises
    ------
    InputError
        An argument that is not a real number (``type``: not a name), naming it.
    ConfigError
        If ``ls_biquad_init`` refuses the configuration.
    """

    def __init__(self, type: str = "lowpass", *, f0: float, q: float = 0.70710678, fs: float) -> None:
        self._keep: list = []
        values = {"type": _type("Biquad", "ls_biquad", type), "f0": _real("Biquad", "f0", f0),
                  "q": _real("Biquad", "q", q), "fs": _real("Biquad", "fs", fs)}
        self.state, self.cfg = _init_module("ls_biquad", lib.ls_biquad_init, "ls_biquad", "ls_biquad_cfg",
                                            values, _good("bpf"), self._keep)

    @property
    def coefficients(self) -> tuple[np.ndarray, np.ndarray]:
        """``(b, a)`` as computed by the C code: ``b = [b0, b1, b2]``, ``a = [1, a1, a2]``."""
        s = self.state
        return np.array([s.b0, s.b1, s.b2]), np.array([1.0, s.a1, s.a2])

    def reset(self) -> None:
        """Clear the filter state (``ls_biquad_reset``)."""
        lib.ls_biquad_reset(self.state)

    def run(self, x: Any) -> np.ndarray:
        """Filter the samples ``x`` (continuing from the present state).

        Parameters
        ----------
        x : array_like, shape (n,)

        Returns
        -------
        ndarray of float64, shape (n,)
        """
        x = _in(x)
        y = np.empty_like(x)
        lib.ls_py_biquad_run(self.state, _p(x), x.size, _p(y))
        return y


# ------------------------------------------------------------------------------ injection
class Injection:
    """``ls_inject``: pulsating HF voltage ``A cos(phi)`` with a phase-continuous carrier.

    Parameters
    ----------
    amplitude : float
        Peak HF voltage when on, V.
    freq : float
        Injection frequency, Hz.
    fs : float
        Sampling rate, Hz (>= 4 freq).
    ramp_rate : float
        Amplitude slew when switched on or off, V/s.
    on : bool
        Switch the injection on after init (it then ramps up at ``ramp_rate``).

    Raises
    ------
    InputError
        An argument that is not a real number (``on``: not a bool), naming it.
    ConfigError
        If ``ls_inject_init`` refuses the configuration.
    """

    def __init__(self, *, amplitude: float, freq: float, fs: float, ramp_rate: float = 1200.0,
                 on: bool = True) -> None:
        self._keep: list = []
        values = {k: _real("Injection", k, v) for k, v in
                  (("amplitude", amplitude), ("freq", freq), ("fs", fs), ("ramp_rate", ramp_rate))}
        if not isinstance(on, bool | np.bool_):
            raise InputError("Injection", "on", f"expected True or False, got {_brief(on)} "
                             f"({type(on).__name__})")
        self.state, self.cfg = _init_module("ls_inject", lib.ls_inject_init, "ls_inject", "ls_inject_cfg",
                                            values, _good("inject"), self._keep)
        self.enable(on)

    def enable(self, on: bool = True) -> None:
        """Request the injection on (ramp up) or off (ramp down)."""
        lib.ls_inject_enable(self.state, bool(on))

    def reset(self) -> None:
        """Phase 0, amplitude 0, off."""
        lib.ls_inject_reset(self.state)

    def run(self, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``n`` steps.

        Returns
        -------
        v : ndarray, shape (n,)
            HF voltage of each step, V.
        car_c, car_s : ndarray, shape (n,)
            The carrier phasor each step used (cos and sin of its phase), as the drive passes it
            to the demodulator.
        """
        v, c, s = (np.empty(int(n)) for _ in range(3))
        lib.ls_py_inject_run(self.state, int(n), _p(v), _p(c), _p(s))
        return v, c, s


# ------------------------------------------------------------------------------ demodulator
class DemodOutput(NamedTuple):
    """Per-sample outputs of :meth:`Demodulator.run`."""

    err: np.ndarray  # rad, estimate of theta - theta_est (0 while the HF level is too low)
    ratio: np.ndarray  # -, normalised error before the gain
    level: np.ndarray  # A^2, mean-square HF current


class Demodulator:
    """``ls_demod``: HF currents -> position-error signal in the compensated frame.

    Parameters
    ----------
    fs : float
        Sampling rate, Hz.
    f_lpf : float
        Corner of the 2nd-order low-pass filters, Hz.
    gain : float
        ``g = L_q/(L_q - L_d)``: ``err = g * ratio``.
    method : {"product", "heterodyne"}
        Error estimator (see ``linsense/ls_demod.h``).
    comp : array_like or Lut, optional
        Compensation table ``Psi_LUT(theta_est)``, rad; None: no compensation.
    gain_table : array_like or Lut, optional
        Position-scheduled gain ``g(theta_est)``; replaces ``gain`` while enabled.
    min_level : float
        Mean-square HF current (A^2) below which ``err`` is held at 0.

    Raises
    ------
    InputError
        An argument that is not a real number (a table: not one dimension of them), naming it.
    ConfigError
        If ``ls_demod_init`` (or ``ls_lut_init`` for a table) refuses the configuration.
    """

    def __init__(self, *, fs: float, f_lpf: float = 150.0, gain: float, method: str = "product",
                 comp: Any = None, gain_table: Any = None, min_level: float = 0.0) -> None:
        fs, f_lpf, gain, min_level = (_real("Demodulator", k, v) for k, v in
                                      (("fs", fs), ("f_lpf", f_lpf), ("gain", gain),
                                       ("min_level", min_level)))
        if not isinstance(method, str):
            raise InputError("Demodulator", "method",
                             f"expected 'product' or 'heterodyne', got {_brief(method)}")
        try:
            self.comp = None if comp is None else make_lut(comp)
            self.gain_table = None if gain_table is None else make_lut(gain_table)
        except InputError as exc:  # (named as this constructor's argument)
            arg = "comp" if self.__dict__.get("comp", 0) == 0 else "gain_table"
            raise InputError("Demodulator", exc.key.replace("values", arg, 1), exc.message) from None
        self._keep: list = []
        values = {"method": _enum("ls_demod", "method", method), "f_lpf": f_lpf, "fs": fs, "gain": gain,
                  "comp": self.comp, "gain_table": self.gain_table, "min_level": min_level}
        self.state, self.cfg = _init_module("ls_demod", lib.ls_demod_init, "ls_demod", "ls_demod_cfg",
                                            values, _good("demod"), self._keep)

    def reset(self) -> None:
        """Clear the filters and outputs."""
        lib.ls_demod_reset(self.state)

    def set_comp(self, on: bool) -> None:
        """Switch the compensation table on (only if one was given) or off."""
        lib.ls_demod_set_comp(self.state, bool(on))

    def set_gain_table(self, on: bool) -> None:
        """Switch the position-scheduled gain on (only if a table was given) or off."""
        lib.ls_demod_set_gain_table(self.state, bool(on))

    def run(self, i_a: Any, i_b: Any, theta_est: Any, car_c: Any = None, car_s: Any = None,
            psi_cal: Any = None) -> DemodOutput:
        """Run ``ls_demod_step`` over whole arrays.

        Parameters
        ----------
        i_a, i_b : array_like, shape (n,)
            Band-passed alpha-beta HF currents, A.
        theta_est : array_like, shape (n,) or scalar
            Estimated electrical angle, rad.
        car_c, car_s : array_like, optional
            Injection carrier (cos, sin of its phase); required by the heterodyne method.
        psi_cal : array_like or scalar, optional
            Extra compensation angle, rad (0 if omitted).

        Returns
        -------
        DemodOutput
            ``err`` (rad), ``ratio`` and ``level`` (A^2) after each sample.
        """
        i_a = _in(i_a)
        n = i_a.size
        i_b = _in(i_b, n)
        th = _in(theta_est, n)
        if self.state.cfg.method == lib.LS_DEMOD_HETERODYNE and (car_c is None or car_s is None):
            raise ValueError("the heterodyne demodulator needs the carrier (car_c, car_s)")
        cc = None if car_c is None else _in(car_c, n)
        cs = None if car_s is None else _in(car_s, n)
        pc = None if psi_cal is None else _in(psi_cal, n)
        err, ratio, level = (np.empty(n) for _ in range(3))
        lib.ls_py_demod_run(self.state, _p(i_a), _p(i_b), _p(th), _p(cc), _p(cs), _p(pc), n,
                            _p(err), _p(ratio), _p(level))
        return DemodOutput(err, ratio, level)

    @property
    def err(self) -> float:
        """Error estimate at the last step, rad."""
        return float(self.state.err)

    @property
    def ratio(self) -> float:
        """Normalised error before the gain at the last step."""
        return float(self.state.ratio)

    @property
    def level(self) -> float:
        """Mean-square HF current at the last step, A^2."""
        return float(self.state.level)

    @property
    def psi(self) -> float:
        """Total compensation angle used at the last step, rad."""
        return float(self.state.psi)

    @property
    def valid(self) -> bool:
        """HF level above ``min_level`` at the last step."""
        return bool(self.state.valid)


# ------------------------------------------------------------------------------ observer
class ObserverOutput(NamedTuple):
    """Per-sample outputs of :meth:`Observer.run` and :meth:`Observer.track`."""

    theta: np.ndarray  # rad, unwrapped estimated electrical angle
    omega: np.ndarray  # rad/s, estimated electrical speed
    f_load: np.ndarray  # N, estimated load force (MECH)


class Observer:
    """``ls_observer``: PLL or mechanical-model tracking observer.

    Parameters
    ----------
    type : {"pll", "mech"}
        Observer structure.
    fs : float
        Sampling rate, Hz.
    pole_pitch : float
        Electrical period tau, m.
    omega_max : float
        Clamp of the speed estimate, electrical rad/s.
    f_bw : float, optional
        Bandwidth, Hz: gains from ``ls_observer_gains`` (all poles at ``-2 pi f_bw``).
    k1, k2, k3 : float, optional
        Explicit gains (1/s, 1/s^2, 1/s^3); override those from ``f_bw``.
    mass : float, optional
        Moving mass, kg (mech).
    force_max : float, optional
        Clamp of the load-force estimate, N (mech).

    Raises
    ------
    InputError
        An argument that is not a real number (``type``: not a name), or neither ``f_bw`` nor
        ``k1`` and ``k2`` given, naming it.
    ConfigError
        If ``ls_observer_init`` refuses the configuration.
    """

    def __init__(self, type: str = "pll", *, fs: float, pole_pitch: float, omega_max: float,
                 f_bw: float | None = None, k1: float | None = None, k2: float | None = None,
                 k3: float | None = None, mass: float = 0.0, force_max: float = 0.0) -> None:
        t = _type("Observer", "ls_observer", type)
        fs, pole_pitch, omega_max, mass, force_max = (
            _real("Observer", k, v) for k, v in (("fs", fs), ("pole_pitch", pole_pitch),
                                                 ("omega_max", omega_max), ("mass", mass),
                                                 ("force_max", force_max)))
        f_bw, k1, k2, k3 = (_real("Observer", k, v, optional=True)
                            for k, v in (("f_bw", f_bw), ("k1", k1), ("k2", k2), ("k3", k3)))
        gains = {"k1": 0.0, "k2": 0.0, "k3": 0.0}
        if f_bw is not None:
            tmp = ffi.new("ls_observer_cfg *", {"type": t})
            lib.ls_observer_gains(tmp, f_bw)
            gains = {"k1": tmp.k1, "k2": tmp.k2, "k3": tmp.k3}
        for k, v in (("k1", k1), ("k2", k2), ("k3", k3)):
            if v is not None:
                gains[k] = v
        if f_bw is None and (k1 is None or k2 is None):
            raise InputError("Observer", "f_bw", "missing: give f_bw or the gains k1, k2 (and k3 for mech)")
        values = {"type": t, "fs": fs, "pole_pitch": pole_pitch, "omega_max": omega_max, **gains,
                  "mass": mass, "force_max": force_max}
        good = _good("obs")
        if t == lib.LS_OBS_MECH:
            tmp = ffi.new("ls_observer_cfg *", {"type": t})
            lib.ls_observer_gains(tmp, 40.0)
            good.update(type=t, k1=tmp.k1, k2=tmp.k2, k3=tmp.k3)
        self._keep: list = []
        self.state, self.cfg = _init_module("ls_observer", lib.ls_observer_init, "ls_observer",
                                            "ls_observer_cfg", values, good, self._keep)

    def reset(self, theta: float = 0.0) -> None:
        """Zero speed and load force; position at ``theta`` (unwrapped rad)."""
        lib.ls_observer_reset(self.state, to_pos(theta))

    def _run(self, fn, x: Any, f_motor: Any) -> ObserverOutput:
        x = _in(x)
        n = x.size
        fm = None if f_motor is None else _in(f_motor, n)
        th, om, fl = (np.empty(n) for _ in range(3))
        fn(self.state, _p(x), _p(fm), n, _p(th), _p(om), _p(fl))
        return ObserverOutput(th, om, fl)

    def run(self, eps: Any, f_motor: Any = None) -> ObserverOutput:
        """Open loop: step with the given errors ``eps`` (rad) and motor forces (N, default 0)."""
        return self._run(lib.ls_py_observer_run, eps, f_motor)

    def track(self, theta: Any, f_motor: Any = None) -> ObserverOutput:
        """Closed loop on a known angle, as with an encoder: ``eps = theta[k] - theta_est``.

        Parameters
        ----------
        theta : array_like, shape (n,)
            True unwrapped electrical angle, rad.
        f_motor : array_like or scalar, optional
            Motor force from the current reference, N (MECH).
        """
        return self._run(lib.ls_py_observer_track, theta, f_motor)

    @property
    def theta(self) -> float:
        """Estimated unwrapped angle, rad."""
        return from_pos(self.state.pos)

    @property
    def omega(self) -> float:
        """Estimated electrical speed, rad/s."""
        return float(self.state.omega)

    @property
    def speed(self) -> float:
        """Estimated speed, m/s (``ls_observer_speed``)."""
        return float(lib.ls_py_observer_speed(self.state))

    @property
    def f_load(self) -> float:
        """Estimated load force, N."""
        return float(self.state.f_load)


# ------------------------------------------------------------------------------ drive
class DriveOutput(NamedTuple):
    """Per-step outputs of :meth:`Drive.run`."""

    duty: np.ndarray  # (n, 3), duty cycles
    fault: np.ndarray  # (n,), uint32 LS_FAULT_* bits
    enable: np.ndarray  # (n,), bool
    theta_est: np.ndarray  # (n,), rad, unwrapped HF observer estimate
    err: np.ndarray  # (n,), rad, demodulated error


class Drive:
    """``ls_drive``: the complete per-PWM-period controller.

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
        self.cmd = ffi.new("ls_cmd *")

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
        """``ls_drive_set_mode``; ``mode`` a name ("sensorless_lut", ...) or an ``LS_MODE_*`` value.

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

    def reset(self, theta: float = 0.0) -> None:
        """Clear every state and fault; mode off; position estimates at ``theta`` (rad)."""
        lib.ls_drive_reset(self.state, to_pos(theta))

    def set_position(self, theta: float) -> None:
        """Tell the HF observer where the mover is (unwrapped rad); :class:`ConfigError` if refused."""
        st = lib.ls_drive_set_position(self.state, to_pos(theta))
        if st != lib.LS_OK:
            raise config_error("ls_drive", {"theta": theta}, st, func="ls_drive_set_position")

    def set_load(self, f_load: float) -> None:
        """``ls_drive_set_load``: start in equilibrium with the load force ``f_load`` (N, opposing
        positive motion when > 0); call after :meth:`set_position`."""
        st = lib.ls_drive_set_load(self.state, float(f_load))
        if st != lib.LS_OK:
            raise config_error("ls_drive", {"f_load": f_load}, st, func="ls_drive_set_load")

    def step(self, i_abc: Any, v_dc: float, enc_count: int | None = None):
        """One PWM period (``ls_drive_step``).

        Parameters
        ----------
        i_abc : array_like of real numbers, shape (3,)
            Phase currents, A. A NaN or infinite current is a measurement the drive handles: it
            trips ``LS_FAULT_NONFINITE``.
        v_dc : real number
            DC-bus voltage, V (non-finite: as ``i_abc``).
        enc_count : int, optional
            Encoder count, an integer within int32 (an integral float is taken); None: encoder
            not valid.

        Returns
        -------
        cdata ``ls_cmd *``
            The command of this step (overwritten by the next call; copy fields you keep).

        Raises
        ------
        InputError
            ``i_abc`` not three real numbers, ``v_dc`` not one, ``enc_count`` not an integer within
            int32: one line naming the argument, what was given and what is expected.
        """
        i = _real_array("Drive.step", "i_abc", i_abc, "three phase currents, shape (3,)", ((3,),))
        vdc = _real_array("Drive.step", "v_dc", v_dc, "one bus voltage, a real number", ((),))
        enc = None if enc_count is None else _counts("Drive.step", "enc_count", enc_count, ((),))
        meas = ffi.new("ls_meas *")
        for k in range(3):
            meas.i_abc[k] = float(i[k])
        meas.v_dc = float(vdc)
        meas.enc_valid = enc is not None
        meas.enc_count = 0 if enc is None else int(enc)
        lib.ls_drive_step(self.state, meas, self.cmd)
        return self.cmd

    def run(self, i_abc: Any, v_dc: Any, enc_count: Any = None) -> DriveOutput:
        """Step the drive over recorded measurements (no plant in the loop).

        Parameters
        ----------
        i_abc : array_like of real numbers, shape (n, 3)
            Phase currents, A, one row per PWM period (non-finite values: see :meth:`step`).
        v_dc : real number or array_like, shape (n,)
            DC-bus voltage, V.
        enc_count : int or array_like of int, shape (n,), optional
            Encoder counts within int32; None: encoder not valid.

        Raises
        ------
        InputError
            A wrong shape, a non-real dtype, a non-integer or out-of-range count: one line naming
            the argument, what was given and what is expected.
        """
        i = _real_array("Drive.run", "i_abc", i_abc, "one row of three phase currents per period, "
                        "shape (n, 3)", ((None, 3),))
        i = np.ascontiguousarray(i, dtype=np.float64)
        n = i.shape[0]
        vdc = _real_array("Drive.run", "v_dc", v_dc, f"a real number or one per period, shape ({n},)",
                          ((), (n,)))
        vdc = _in(vdc, n)
        enc = None if enc_count is None else np.ascontiguousarray(
            np.broadcast_to(_counts("Drive.run", "enc_count", enc_count, ((), (n,))), (n,)), dtype=np.int32)
        duty = np.empty((n, 3))
        fault = np.empty(n, dtype=np.uint32)
        enable = np.empty(n, dtype=np.uint8)
        th, err = np.empty(n), np.empty(n)
        lib.ls_py_drive_run(self.state, _p(i), _p(vdc), _p(enc, "int32_t[]"), n, _p(duty),
                            _p(fault, "uint32_t[]"), _p(enable, "uint8_t[]"), _p(th), _p(err))
        return DriveOutput(duty, fault, enable.astype(bool), th, err)


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


def _real(source: str, key: str, value: Any, optional: bool = False) -> float | None:
    """``value`` as a Python float: a real number (int, float or a numpy scalar of a real dtype; NaN
    and inf are left to the C init, which refuses them by field), else :class:`InputError` naming
    ``key``, what was given and what is expected (None, a bool, a string, a complex number or an
    array was a TypeError or was taken as 1.0, issue 23). ``optional``: None is returned as None."""
    if value is None and optional:
        return None
    ok = isinstance(value, numbers.Real) and not isinstance(value, bool | np.bool_)
    if isinstance(value, np.ndarray) and value.ndim == 0 and value.dtype.kind in "iuf":
        value, ok = value.item(), True
    if not ok:
        raise InputError(source, key, f"expected a real number, got {_brief(value)} ({type(value).__name__})")
    try:
        return float(value)
    except OverflowError:  # (an int beyond a double)
        raise InputError(source, key, f"{_brief(value)} is beyond the range of a double (1.8e308)") from None


def _type(source: str, module: str, value: Any) -> int:
    """The C enum value of the argument ``type`` given by name (or as the C value, an int)."""
    table = _ENUMS[(module, "type")]
    integral = isinstance(value, numbers.Integral) and not isinstance(value, bool | np.bool_)
    if isinstance(value, str) or integral:
        return _enum(module, "type", value)
    raise InputError(source, "type", f"expected one of {', '.join(map(repr, table))}, got {_brief(value)} "
                     f"({type(value).__name__})")


#: the range of an encoder count (ls_meas.enc_count is an int32_t)
_INT32 = (-(2**31), 2**31 - 1)


def _counts(source: str, key: str, value: Any, shape: tuple) -> np.ndarray:
    """Encoder counts as an int64 array: integers (or integral floats) within int32, else
    :class:`InputError` naming ``key`` (a NaN, 2.5 or 2**31 was silently cast to another count)."""
    what = ("an integer encoder count" if shape == ((),)
            else f"integer encoder counts, one or shape {shape[-1]}")
    a = _as_array(source, key, value, what)
    if a.dtype.kind not in "iuf":
        raise InputError(source, key, f"expected {what}, got {_brief(value)} (dtype {a.dtype})")
    if not _shape_ok(a.shape, shape):
        raise InputError(source, key, f"expected {what}, got shape {a.shape}")
    if a.dtype.kind == "f":
        bad = ~np.isfinite(a) | (a != np.round(a))
        if np.any(bad):
            raise InputError(source, key, f"expected {what}, got {float(a[bad].flat[0])!r} (not an integer)")
    lo, hi = (a.min(), a.max()) if a.size else (0, 0)
    if lo < _INT32[0] or hi > _INT32[1]:
        v = lo if lo < _INT32[0] else hi
        raise InputError(source, key, f"{int(v)} is beyond the int32 range of a count "
                         f"[{_INT32[0]}, {_INT32[1]}] (ls_meas.enc_count)")
    return a.astype(np.int64)
