"""The firmware's blocks one by one from Python, for the tests (moved out of :mod:`linsense.ctrl`:
nothing in the package uses them; the docs present only the drive).

Each class creates a module state of the C library (``ls_biquad``, ``ls_inject``, ``ls_demod``,
``ls_observer``) from keyword arguments in SI units, refuses a bad configuration with
:class:`linsense.ctrl.ConfigError` naming the field (the C ``ls_<module>_init`` decides) and runs
whole numpy arrays through the C code in one call (the loops are the binding's C helpers,
``csrc/py/ls_py.h``). :class:`Drive` adds ``reset``, ``step`` and ``run`` (recorded measurements,
no plant) to :class:`linsense.ctrl.Drive`. Samples are converted to ``LS_REAL`` on the way in and
returned as float64 arrays; angles are unwrapped electrical angles. ``Lut``, ``make_lut``,
``ConfigError``, ``ffi``, ``lib`` and ``drive_default_cfg`` are re-exported, so that a test can
take this module where it took ``linsense.ctrl``.

Example
-------
>>> bp = Biquad("bandpass", f0=1000.0, q=2.0, fs=16000.0)
>>> y = bp.run(x)                                          # doctest: +SKIP
>>> b, a = bp.coefficients                                 # what the C code computed
"""

from __future__ import annotations

import numbers
from collections.abc import Callable
from typing import Any, NamedTuple

import numpy as np

from linsense import ctrl
from linsense.ctrl import (
    _ENUMS,
    ConfigError,
    Lut,
    _as_array,
    _brief,
    _enum,
    _enum_name,
    _in,
    _p,
    _real_array,
    _shape_ok,
    config_error,
    drive_default_cfg,
    ffi,
    from_pos,
    lib,
    make_lut,
    to_pos,
)
from linsense.errors import InputError

__all__ = ["Biquad", "ConfigError", "DemodOutput", "Demodulator", "Drive", "DriveOutput", "Injection", "Lut",
           "Observer", "ObserverOutput", "drive_default_cfg", "ffi", "lib", "make_lut"]


# ------------------------------------------------------------------------------ helpers
def _struct_dict(cdata) -> dict:
    """Fields of a struct (pointer or value) as a dict."""
    t = ffi.typeof(cdata)
    if t.kind == "pointer":
        t = t.item
    return {name: getattr(cdata, name) for name, _ in t.fields}


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


def _good(section: str) -> dict:
    """Known-good sub-configuration from the drive defaults (reference for naming bad fields)."""
    return _struct_dict(getattr(drive_default_cfg(), section))


def _real(source: str, key: str, value: Any, optional: bool = False) -> float | None:
    """``value`` as a Python float: a real number (int, float or a numpy scalar of a real dtype; NaN
    and inf are left to the C init, which refuses them by field), else :class:`InputError` naming
    ``key``, what was given and what is expected (None, a bool, a string, a complex number or an
    array was a TypeError or was taken as 1.0 before this check). ``optional``: None is returned as None."""
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
        return float(lib.ls_observer_speed(self.state))

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


class Drive(ctrl.Drive):
    """:class:`linsense.ctrl.Drive` stepped from Python: ``reset``, ``step`` and ``run``."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.cmd = ffi.new("ls_cmd *")

    def reset(self, theta: float = 0.0) -> None:
        """Clear every state and fault; mode off; position estimates at ``theta`` (rad)."""
        lib.ls_drive_reset(self.state, to_pos(theta))

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
