"""The plausible range of each kind of quantity a user types, and the slip of unit that explains a
value outside it ("did you type mH?"), in one table (:data:`KINDS`; docs/limits.md, "Plausibility").

Every input of a kind is held to the same row, wherever it is typed: a motor file
(:func:`linsense.model.motor.check_plausible`), a scenario or sweep file (the keys whose field names
its kind, :mod:`linsense.scenario.sections`), an option of the command, a bench or table file, the Python
API. A value outside the range is refused naming the key, the value, the range and the slip of unit
that would bring it in (:func:`check`); a value a rule of its own refuses (a dead time longer than
a tenth of the PWM period, a kappa of 1 or more) gets the slip that would make the rule hold
appended to the rule's message (:func:`slip`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

from linsense.errors import InputError


@dataclass(frozen=True)
class Kind:
    """One kind of quantity: its unit, its plausible range and the units it is mistyped in.

    Attributes
    ----------
    unit : str
        The unit the range is in (SI; ``""`` for a ratio).
    low : float
        The lowest plausible value, in :attr:`unit`.
    high : float
        The highest plausible value (the range's ends included).
    slips : tuple of (str, float)
        Units a value of this kind is typed in by mistake, each with its size in ``unit``
        (``("mH", 1e-3)``: 1 mH is 1e-3 H).
    of : str
        What the range holds, for the message ("real linear motors").
    """

    unit: str
    low: float
    high: float
    slips: tuple[tuple[str, float], ...]
    of: str

    def sizes(self) -> dict[str, float]:
        """Every unit of the kind (its own first) to its size in :attr:`unit`.

        Returns
        -------
        dict
            E.g. ``{"s": 1.0, "us": 1e-06, "ns": 1e-09}``.
        """
        return {self.unit: 1.0, **dict(self.slips)}

    def holds(self, value: float) -> bool:
        """Whether ``value`` (in :attr:`unit`) is within the range.

        Parameters
        ----------
        value : float
            The value.

        Returns
        -------
        bool
            ``low <= value <= high``.
        """
        return self.low <= value <= self.high


_DEG = math.pi / 180.0
#: the kinds of quantity and their plausible ranges. The motor's (``pole_pitch`` .. ``inductance``)
#: are the class of docs/limits.md with margin (pole pitch 20-100 mm, 24-300 V, L 0.1-100 mH, R_s
#: 0.1-20 ohm, 1 g - 10 t); the drive's: dead times of 10 ns (GaN) to a few us (IGBT), the PWM rates
#: of the controller library (from f_pwm / 4 >= 125 Hz, the lowest injection, to LS_DRIVE_FS_MAX),
#: injections of hundreds of Hz to half a 1 MHz PWM, buses of 24-300 V (up to a 1,200 V IGBT's),
#: currents to 1 kA, speeds to 20 m/s, strokes to 100 m; bandwidths to 100 kHz and electrical speeds
#: (rad/s) are held by the drive's own relations (a loop below the one it follows, a clamp above the
#: top speed), the slip of 2 pi between Hz and rad/s their hint; an angle error is at most pi; a noise
#: or a share is a fraction, a factor of a base value at most 10 (a percentage typed for it is 100);
#: the end effect on the magnets' flux: a phase linking 0.5 .. 1.5 times the nominal flux (measured
#: end phases lose a few to 15 %), its flux axis displaced by at most 30 electrical degrees (a few)
KINDS: dict[str, Kind] = {
    "pole_pitch": Kind("m", 1e-3, 1.0, (("mm", 1e-3), ("um", 1e-6)), "real linear motors"),
    "resistance": Kind("ohm", 0.0, 100.0, (("milliohm", 1e-3),), "real linear motors"),
    "force_constant": Kind("N/A", 1e-2, 1e4, (), "real linear motors"),
    "mass": Kind("kg", 1e-3, 1e4, (("g", 1e-3),), "real linear motors"),
    "inductance": Kind("H", 1e-6, 0.5, (("mH", 1e-3), ("uH", 1e-6), ("nH", 1e-9)), "real linear motors"),
    "stroke": Kind("m", 1e-3, 100.0, (("mm", 1e-3), ("um", 1e-6)), "linear-motor axes"),
    "dead_time": Kind("s", 0.0, 2e-5, (("us", 1e-6), ("ns", 1e-9)), "PWM inverters"),
    "time": Kind("s", 0.0, 3600.0, (("ms", 1e-3), ("us", 1e-6)), "simulated runs"),
    "pwm_frequency": Kind("Hz", 500.0, 1e6, (("kHz", 1e3),), "the controller library"),
    "injection_frequency": Kind("Hz", 125.0, 5e5, (("kHz", 1e3),), "HF injections"),
    "bandwidth": Kind("Hz", 0.0, 1e5, (("rad/s", 1.0 / (2.0 * math.pi)), ("kHz", 1e3)), "control loops"),
    "voltage": Kind("V", 1.0, 1500.0, (("mV", 1e-3), ("kV", 1e3)), "drives of linear motors"),
    "current": Kind("A", 0.0, 1000.0, (("mA", 1e-3), ("kA", 1e3)), "drives of linear motors"),
    "speed": Kind("m/s", 0.0, 20.0, (("mm/s", 1e-3),), "linear motors"),
    "force": Kind("N", 0.0, 1e5, (("kN", 1e3),), "linear motors"),
    "angular_speed": Kind("rad/s", 0.0, 1e7, (("Hz", 2.0 * math.pi),), "electrical speeds"),
    "angle_error": Kind("rad", 0.0, math.pi, (("deg", _DEG),), "electrical angle errors"),
    "angle": Kind("deg", 0.0, 360.0, (("rad", 1.0 / _DEG),), "electrical angles over one period"),
    "share": Kind("", 0.0, 1.0, (("%", 1e-2),), "shares"),
    "relative_noise": Kind("", 0.0, 0.5, (("%", 1e-2),), "measurement noise"),
    "factor": Kind("", -10.0, 10.0, (("%", 1e-2),), "factors of a base value"),
    "flux_scale": Kind("", 0.5, 1.5, (("%", 1e-2),), "a phase's magnet flux in real linear motors"),
    "flux_shift": Kind("deg", -30.0, 30.0, (("rad", 1.0 / _DEG),),
                       "a phase's magnet-flux phase in real linear motors"),
}


def _unit(value: float, unit: str) -> str:
    return f"{value:.6g} {unit}".strip()


def slip(kind: str, value: float, unit: str | None = None, ok: Callable[[float], bool] | None = None) -> str:
    """The slip of unit that explains ``value``, for a message: ``"did you type us? (0.8 us is 8e-07 s)"``.

    ``value`` is read in each unit of its kind other than the one it is given in; the first reading
    that ``ok`` accepts is the likely slip.

    Parameters
    ----------
    kind : str
        A key of :data:`KINDS`.
    value : float
        The value as given.
    unit : str or None, optional
        The unit it is given in (one of the kind's; None: the kind's own).
    ok : callable or None, optional
        ``ok(v) -> bool`` for a value ``v`` in ``unit``: the rule the value broke (None: the kind's
        range).

    Returns
    -------
    str
        The hint, or ``""`` when no reading is accepted.
    """
    k = KINDS[kind]
    sizes = k.sizes()
    given = unit if unit is not None else k.unit
    per = sizes[given]
    accept = ok if ok is not None else (lambda v: k.holds(v * per))
    if not (isinstance(value, int | float) and math.isfinite(value) and value != 0.0):
        return ""
    for u, size in sizes.items():
        if u == given:
            continue
        meant = value * size / per
        try:
            fits = bool(accept(meant))
        except (ArithmeticError, ValueError):
            fits = False
        if fits:
            return f"did you type {u}? ({_unit(value, u)} is {_unit(meant, given)})"
    return ""


def implausible(kind: str, value: float, unit: str | None = None) -> str | None:
    """What is wrong with ``value`` of ``kind``, or None when it is plausible.

    Parameters
    ----------
    kind : str
        A key of :data:`KINDS`.
    value : float
        The value.
    unit : str or None, optional
        The unit it is given in (None: the kind's own).

    Returns
    -------
    str or None
        E.g. ``"0.8 s is outside the range of PWM inverters [0, 2e-05] s: did you type us? (0.8 us
        is 8e-07 s)"``.
    """
    k = KINDS[kind]
    given = unit if unit is not None else k.unit
    per = k.sizes()[given]
    if k.holds(value * per):
        return None
    lo, hi = (float(f"{b / per:.6g}") for b in (k.low, k.high))
    hint = slip(kind, value, given)
    return (f"{_unit(value, given)} is outside the range of {k.of} [{lo:g}, {hi:g}] {given}".rstrip()
            + (f": {hint}" if hint else ""))


def check(source: str, key: str, value: float, kind: str, unit: str | None = None) -> float:
    """``value`` if it is plausible for ``kind``, else :class:`~linsense.errors.InputError`.

    Parameters
    ----------
    source : str
        The file, option or function the value came from.
    key : str
        Its key (or argument; ``""`` for an option named by ``source``).
    value : float
        The value.
    kind : str
        A key of :data:`KINDS`.
    unit : str or None, optional
        The unit it is given in (None: the kind's own).

    Returns
    -------
    float
        ``value``.

    Raises
    ------
    linsense.errors.InputError
        Naming ``source``, ``key``, the value, the range and the likely slip of unit.
    """
    msg = implausible(kind, value, unit)
    if msg is not None:
        raise InputError(source, key, msg)
    return value
