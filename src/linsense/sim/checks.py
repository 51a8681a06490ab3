"""The checks of a scenario that the build makes before any work (:func:`linsense.sim.build.validate`):
each refusal names the scenario key, its value and the limit."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from linsense.ctrl import REAL, ffi, lib, observer_gains
from linsense.errors import InputError
from linsense.limits import MAX_STEPS, MAX_TRACE_BYTES, MAX_TRACE_FILE_BYTES
from linsense.scenario.load import Scenario
from linsense.sim.core import BLOCKS, SIGNALS


def check_positions(sc: Scenario, tau: float) -> None:
    """Refuse a position the drive cannot hold: beyond ``LS_POS_PERIOD_MAX`` pole pitches either
    side (``ls_pos``, docs/firmware.md), before it is converted to a count of periods.

    The start (``initial.position_mm``, and ``startup.guess_mm`` of a start-up) was an OverflowError
    traceback in the conversion, or a one-line ls_pos message naming no key; a reference there was
    silently refused by the drive's setter (the run held still and reported no fault).

    Parameters
    ----------
    sc : Scenario
        The scenario.
    tau : float
        m, the motor's pole pitch.

    Raises
    ------
    InputError
        Naming the key, its value and the range in mm on this motor.
    """
    s = sc.spec
    limit = int(lib.LS_POS_PERIOD_MAX)
    keys = [("initial.position_mm", s.initial.position_mm)]
    if s.control.mode == "startup":
        keys.append(("startup.guess_mm", s.startup.guess_mm))
    if s.reference.position_mm is not None:
        keys.append(("reference.position_mm", s.reference.position_mm))
    keys += [(f"reference.waypoints_mm[{i}]", w) for i, w in enumerate(s.reference.waypoints_mm or [])]
    for key, x_mm in keys:
        if not abs(x_mm * 1e-3 / tau) < limit:
            raise InputError(sc.source, key, f"{x_mm:g} mm is beyond the drive's position range of "
                             f"+-{limit:,} pole pitches (+-{limit * tau * 1e3:.6g} mm on this motor, "
                             "docs/firmware.md)")


def sensor_triples(sens) -> tuple[list, list]:
    """The current sensors' gains and offsets (``[sensors]``), one per phase.

    Parameters
    ----------
    sens : SensorsSection
        The ``[sensors]`` section.

    Returns
    -------
    gain : list of float
        Per-phase gains, dimensionless.
    offset : list of float
        Per-phase offsets, A.
    """
    gain = sens.current_gain if isinstance(sens.current_gain, list) else [sens.current_gain] * 3
    offs = sens.current_offset if isinstance(sens.current_offset, list) else [sens.current_offset] * 3
    return gain, offs


def check_sensors(source: str, gain: list, offset: list, noise: float, i_trip: float,
                  trip_given: bool = False) -> None:
    """Refuse current sensors the drive cannot run with.

    A gain of 0 or below (the current not measured, or a phase reversed), an offset or an rms noise
    at the over-current trip ``protection.i_max`` or beyond (the drive trips on the sensor alone, at
    t = 0; the message named protection.i_max where the file gave only the sensor).

    Parameters
    ----------
    source : str
        The scenario file, named in messages.
    gain : list of float
        Per-phase gains.
    offset : list of float
        Per-phase offsets, A.
    noise : float
        Current noise, A rms.
    i_trip : float
        Over-current trip, A.
    trip_given : bool, optional
        The file gives protection.i_max, which is then named, with the sensor's value as its limit.

    Raises
    ------
    linsense.errors.InputError
        Naming the sensor key (or protection.i_max) and the value.
    """
    for g in gain:
        if not g > 0.0:
            raise InputError(source, "sensors.current_gain", f"must be above 0 (0 measures no current, "
                             f"a negative gain reverses the phase), got {g!r}")
    for key, v, what in [("sensors.current_offset", max(abs(o) for o in offset), "offset"),
                         ("sensors.current_noise", noise, "rms noise")]:
        if v < i_trip:
            continue
        if trip_given:
            raise InputError(source, "protection.i_max", f"{i_trip:g} A is at or below {key} = {v:g} A: "
                             f"the drive would trip at t = 0 on the sensor's {what} alone; it must be above "
                             f"{v:g} A")
        raise InputError(source, key, f"{v!r} A reaches the over-current trip protection.i_max = "
                         f"{i_trip:g} A: the drive would trip at t = 0 on the {what} alone; it must be below "
                         f"{i_trip:g} A")


def run_steps(source: str, duration: float, fs: float) -> int:
    """The PWM periods of a run of ``duration`` s at ``fs`` Hz, range-checked before the conversion to
    an integer (a product beyond a float, ``scenario.duration = 1e308``, was an
    OverflowError traceback).

    Parameters
    ----------
    source : str
        The scenario's file, named in a refusal.
    duration, fs : float
        ``scenario.duration`` (s) and ``inverter.f_pwm`` (Hz), positive and finite.

    Returns
    -------
    int
        ``round(duration * fs)``, 1 .. :data:`~linsense.limits.MAX_STEPS`.

    Raises
    ------
    InputError
        Naming ``scenario.duration``, its value, the rate and the limit: beyond MAX_STEPS periods
        (or a product that overflows), or shorter than one period.
    """
    periods = duration * fs
    if not periods <= MAX_STEPS + 0.5:  # (also inf and NaN)
        count = (f"{periods:.3g} PWM periods" if math.isfinite(periods)
                 else "more PWM periods than a float holds")
        raise InputError(source, "scenario.duration",
                         f"{duration:g} s at {fs:g} Hz is {count}, beyond the limit "
                         f"of {MAX_STEPS:.3g} (duration x inverter.f_pwm, docs/limits.md)")
    n_steps = int(round(periods))
    if n_steps < 1:
        raise InputError(source, "scenario.duration", f"shorter than one PWM period, got {duration!r}")
    return n_steps


def check_run_size(source: str, n_steps: int, decimate: int, fs: float, trace_in_memory: bool = True) -> None:
    """Refuse a run whose trace in memory would not fit in :data:`~linsense.limits.MAX_TRACE_BYTES`.

    Refused before anything is allocated. A run streamed in chunks (``linsense simulate``) keeps no trace in
    memory.

    Parameters
    ----------
    source : str
        The scenario file, named in messages.
    n_steps : int
        PWM periods (:func:`run_steps`, which bounds them by :data:`~linsense.limits.MAX_STEPS`).
    decimate : int
        PWM periods per sample.
    fs : float
        PWM frequency, Hz.
    trace_in_memory : bool, optional
        Whether the trace is kept in memory (False: no check).

    Raises
    ------
    linsense.errors.InputError
        Naming ``record.decimate`` and the least that fits.
    """
    if not trace_in_memory:
        return
    # with decimate > 1 every sample also keeps its block statistics (linsense.sim.simulation.simulate)
    with_blocks = 8 * (sum(SIGNALS.values()) + sum(BLOCKS.values())) + 4
    per_sample = with_blocks if decimate > 1 else 8 * sum(SIGNALS.values()) + 4
    n_rec = math.ceil(n_steps / decimate) + 2
    if n_rec * per_sample > MAX_TRACE_BYTES:
        need = math.ceil(n_steps * with_blocks / MAX_TRACE_BYTES)
        gib = n_rec * per_sample / 2**30
        raise InputError(source, "record.decimate",
                         f"= {decimate} keeps {n_rec:.3g} samples of the {n_steps / fs:g} s run in memory "
                         f"({gib:.3g} GiB), beyond the limit of {MAX_TRACE_BYTES / 2**30:g} GiB: set "
                         f"record.decimate to at least {need} or shorten scenario.duration (docs/limits.md)")


def check_trace_file(b) -> None:
    """Refuse a streamed run whose trace file would exceed :data:`~linsense.limits.MAX_TRACE_FILE_BYTES`.

    At 144 B per sample; refused before it starts.

    Parameters
    ----------
    b : Built
        The built scenario.

    Raises
    ------
    linsense.errors.InputError
        Naming ``record.decimate`` and the least that fits.
    """
    from linsense.sim.trace import COLUMNS

    s = b.scenario.spec
    per_sample = 8 * len(COLUMNS)
    dec = int(b.cfg.decimate)
    n_rec = math.ceil(b.n_steps / dec)
    if n_rec * per_sample > MAX_TRACE_FILE_BYTES:
        need = math.ceil(b.n_steps * per_sample / MAX_TRACE_FILE_BYTES)
        gib = n_rec * per_sample / 2**30
        raise InputError(
            b.scenario.source, "record.decimate",
            f"= {dec} writes {n_rec:.3g} samples of the {s.scenario.duration:g} s run to the trace file "
            f"(about "
            f"{gib:.3g} GiB), beyond the limit of {MAX_TRACE_FILE_BYTES / 2**30:g} GiB: set record.decimate "
            f"(--decimate) to at least {need}, shorten scenario.duration or write no trace (--trace none) "
            "(docs/limits.md)")


def check_startup(sc: Scenario) -> None:
    """Refuse a start-up the drive cannot enter (``ls_drive_set_mode``, ``LS_MODE_STARTUP``): the
    injection must be on, and the quiet time and the settling must cover the injection's ramp as the
    drive runs it, with the designed amplitude and ramp rate (the scenario's own check sees the
    file's or the default values; the designed ones were refused by the C library only when the mode
    was set). Compared as the library does, in ``LS_REAL``.

    Parameters
    ----------
    sc : Scenario
        The designed scenario.

    Raises
    ------
    InputError
        Naming ``injection.amplitude``, or ``startup.t_quiet`` / ``startup.t_settle`` with the ramp's
        duration.
    """
    s = sc.spec
    if s.control.mode != "startup":
        return
    inj, su = s.injection, s.startup
    amp, rate = REAL.type(inj.amplitude), REAL.type(inj.ramp_rate)
    if not amp > 0.0:
        raise InputError(sc.source, "injection.amplitude", f"the start-up detects with the injection: must "
                         f"be above 0, got {inj.amplitude!r}")
    for k in ("t_quiet", "t_settle"):
        t = getattr(su, k)
        if not REAL.type(t) * rate >= amp:
            raise InputError(sc.source, f"startup.{k}", f"must cover the injection's ramp as the drive runs "
                             f"it, injection.amplitude / ramp_rate = {inj.amplitude:g} V / {inj.ramp_rate:g} "
                             f"V/s = {inj.amplitude / inj.ramp_rate:g} s, got {t:g}")


def check_initial_load(sc: Scenario, f_load: float) -> None:
    """Refuse a start in equilibrium (``initial.load_balanced``) with a load force ``f_load`` (N,
    :func:`linsense.sim.build.initial_load`) beyond what the drive's ``LS_REAL`` holds:
    ``ls_drive_set_load`` refuses a non-finite force (it was a ConfigError naming no key, raised
    after the plant, the tables and the drive were made).

    Parameters
    ----------
    sc : Scenario
        The scenario.
    f_load : float
        The load force at t = 0, N.

    Raises
    ------
    InputError
        Naming the load key that sets the force at t = 0 (``load.force``, or ``load.force_after`` for
        a step at t <= 0).
    """
    s = sc.spec
    if not s.initial.load_balanced or math.isfinite(float(ffi.cast("LS_REAL", f_load))):
        return
    ld = s.load
    key = "load.force_after" if ld.type == "step" and ld.time <= 0.0 else "load.force"
    raise InputError(sc.source, key, f"{f_load:g} N at t = 0 (initial.load_balanced = true) is beyond the "
                     f"largest force the drive holds, {float(np.finfo(REAL).max):.6g} N (ls_drive_set_load)")


def run_events(sc: Scenario, moves) -> list[tuple[str, float, str, bool]]:
    """Every timed event of a scenario: what acts at a time of the run, with the key that sets it.

    The one list the run's end is checked against (:func:`check_events`): the step (``reference.at``)
    or the start of each move of a trajectory (``reference.at`` for the first, the waypoint's key for
    the others: they follow the moves before them and ``reference.dwell``), a step load
    (``load.time``, above 0), the end of a start-up at the earliest, and the timed keys the file
    gives: the end of the transient window after the last step or move (``metrics.settle_s``), the
    start of the error windows (``metrics.convergence_s``) and the observer-loss trip's delay
    (``protection.err_time``).

    Parameters
    ----------
    sc : Scenario
        The designed scenario.
    moves : list of (float, float, float, float)
        Its planned moves ``(t0, t1, x0, x1)`` (:func:`linsense.sim.build.reference_commands`).

    Returns
    -------
    list of (str, float, str, bool)
        ``(key, time in s, what acts then, whether the time is the key's own value)``, in the
        scenario's order; a time that is not a key's own is in the text, ``{t}``, with what it
        means for the run.
    """
    s = sc.spec
    ref, ld = s.reference, s.load
    events = []
    if ref.type == "step":
        events.append(("reference.at", ref.at, "the step", True))
    for i, (t0, *_rest) in enumerate(moves if ref.type == "trajectory" else ()):
        if i == 0:
            events.append(("reference.at", t0, "the first move", True))
        else:
            what = ("the move to it starts at {t} s (after the moves before it and reference.dwell = "
                    f"{ref.dwell:g} s) and would never act")
            events.append((f"reference.waypoints_mm[{i}]", t0, what, False))
    if ld.type == "step" and ld.time > 0.0:
        events.append(("load.time", ld.time, "the load step", True))
    if s.control.mode == "startup":
        su = s.startup
        end = su.t_lock + su.t_quiet + 2 * su.pairs * (su.t_rest + su.t_pulse) + su.t_settle
        events.append(("startup", end, "the start-up ends at {t} s at the earliest (t_lock + t_quiet + 2 "
                       "pairs (t_rest + t_pulse) + t_settle): the position control after it would never act",
                       False))
    if "settle_s" in s.metrics.model_fields_set:  # (given long enough, no steady sample is left)
        ends = [ref.at] if ref.type == "step" else []
        if ref.type == "trajectory":
            ends = [t1 for _t0, t1, *_x in moves]
        if ends:
            events.append(("metrics.settle_s", max(ends) + s.metrics.settle_s, "the transient window after "
                           "the last step or move ends at {t} s: the steady metrics after it would read "
                           "nothing", False))
    if "convergence_s" in s.metrics.model_fields_set:
        events.append(("metrics.convergence_s", s.metrics.convergence_s, "the start of the error windows",
                       True))
    if "err_time" in s.protection.model_fields_set:
        events.append(("protection.err_time", s.protection.err_time, "the observer-loss trip (the error "
                       "beyond protection.err_max for this long)", True))
    return events


def check_events(sc: Scenario, n_steps: int, moves, user_keys: set[str]) -> None:
    """Refuse an event of :func:`run_events` that the run ends before: it would never act.

    The C loop acts on an event at the first period that starts at or after its time, so an event
    after the start of the last period (``(n_steps - 1) / f_pwm``) is never seen (a load
    step at 5 s in a 0.6 s run gave "stable"). A step load to the force it steps from never acts
    either (``load.force_after`` left at its default 0 beside ``load.force = 0``).

    Parameters
    ----------
    sc : Scenario
        The designed scenario.
    n_steps : int
        The run's PWM periods (:func:`run_steps`).
    moves : list of (float, float, float, float)
        Its planned moves.
    user_keys : set of str
        The dotted keys the file gives (an event at its default time is said to be the default).

    Raises
    ------
    InputError
        Naming the event's key, its time and the run's duration (``load.force_after`` for a step of
        nothing).
    """
    s = sc.spec
    ld = s.load
    if ld.type == "step" and ld.force_after == ld.force:  # (a step of nothing: it never acts either)
        default = "" if "load.force_after" in user_keys else " (the default)"
        raise InputError(sc.source, "load.force_after", f"{ld.force_after!r} N{default} equals load.force = "
                         f"{ld.force!r} N: the load step at load.time would change nothing; give the force "
                         "after the step")
    t_last = (n_steps - 1) / s.inverter.f_pwm  # (s, the start of the last period)
    for key, t, what, own in run_events(sc, moves):
        if t > t_last:
            default = "" if key in user_keys else " (the default)"
            what = f"{t!r} s{default}: {what} would never act" if own else what.format(t=f"{t:.6g}")
            raise InputError(sc.source, key, f"{what}: the run ends at scenario.duration = "
                             f"{s.scenario.duration:g} s (its last period starts at {t_last:.9g} s); make it "
                             "earlier or the run longer")


def slowest_loop(sc: Scenario, mass: float) -> tuple[str, str, float]:
    """The slowest loop of a drive that can sustain a cycle, the key that sets it and its bandwidth.

    The one derivation of the shortest end window (:func:`check_final_window`). The loops counted:
    the speed loop (``speed_bandwidth_hz``, or ``speed_kp / (2 pi m)``) under a P position loop, the
    PD position loop itself (``sqrt(kp_x / m) / (2 pi)``), and the HF observer in the sensorless
    modes (``observer.bandwidth_hz``, or ``k1 / (2 pi)`` over 3 for ``mech``, 2 for ``pll``). A P
    position loop is first order around the speed loop: a cycle of the cascade is at least as fast
    as the speed loop's; the current loop is far faster than all of them.

    Parameters
    ----------
    sc : Scenario
        The designed scenario.
    mass : float
        kg, the plant's moving mass.

    Returns
    -------
    tuple of (str, str, float)
        ``(loop, key, bandwidth in Hz)``.
    """
    s = sc.spec
    c, o = s.controller, s.observer
    loops = []
    if c.position_type == "pd":
        loops.append(("the PD position loop", "controller.kp_x", math.sqrt(c.kp_x / mass) / (2.0 * math.pi)))
    elif c.speed_kp is not None:
        loops.append(("the speed loop", "controller.speed_kp", c.speed_kp / mass / (2.0 * math.pi)))
    else:
        loops.append(("the speed loop", "controller.speed_bandwidth_hz", c.speed_bandwidth_hz))
    if s.control.mode != "sensored":
        if o.k1 is not None:
            k1_per_hz = observer_gains(1.0, o.type == "mech")[0]  # (k1 grows with the bandwidth)
            loops.append(("the observer", "observer.k1", o.k1 / k1_per_hz))
        else:
            loops.append(("the observer", "observer.bandwidth_hz", o.bandwidth_hz))
    return min(loops, key=lambda lp: lp[2])


def check_final_window(sc: Scenario, mass: float, user_keys: set[str]) -> None:
    """Refuse an end window too short to see a cycle of the drive's slowest loop (:func:`slowest_loop`).

    The end window must hold half the loop's period at least (a peak and a trough of its cycle): a
    shorter one sees a part of the cycle as a still mover (``final_window_s = 1e-9`` gave
    "stable" and a limit cycle of 0 where the default window showed 17 deg).

    Parameters
    ----------
    sc : Scenario
        The designed scenario.
    mass : float
        kg, the plant's moving mass.
    user_keys : set of str
        The dotted keys the file gives (a default window is said to be the default).

    Raises
    ------
    InputError
        Naming ``metrics.final_window_s``, its value, the loop and the least window.
    """
    loop, key, f = slowest_loop(sc, mass)
    least = 0.5 / f
    w = sc.spec.metrics.final_window_s
    if w >= least:
        return
    window = "metrics.final_window_s"
    if window not in user_keys and key in user_keys:  # (the file gives the loop, not the window)
        raise InputError(sc.source, key, f"{f:.4g} Hz makes {loop} too slow for the end window: a cycle "
                         f"of it ({1.0 / f:.3g} s period) needs half its period, at least {least:.3g} s, and "
                         f"{window} is {w!r} s (the default): give {window} = {least:.3g} or more")
    default = "" if window in user_keys else " (the default)"
    raise InputError(sc.source, window, f"{w!r} s{default} is too short to see a cycle of {loop} ({key} = "
                     f"{f:.4g} Hz, a {1.0 / f:.3g} s period): the end window must hold half its period, at "
                     f"least {least:.3g} s")


def _value_at(spec, key: str):
    node = spec
    for part in key.split("."):
        node = getattr(node, part)
    return node


#: what the controller believes (``[controller.model]``) at most this factor off the motor's own value:
#: a parameter mismatch is tens of %; a value 1000 times off is another unit (mH typed as H, g as kg)
MODEL_FACTOR_MAX = 10.0


def check_units(sc: Scenario, tau: float, user_keys: set[str], believed: dict[str, float]) -> None:
    """Refuse a value the file gives in another unit than its key's: a key of a kind of
    the table of plausible values (:func:`linsense.scenario.keys.unit_kinds`) outside its range
    (``controller.model.L_d = 10`` H, ``protection.err_max = 30`` rad, ``controller.v_max = 200``
    m/s), or a frequency or electrical speed that breaks the relation a slip of 2 pi between Hz and
    rad/s breaks: the demodulator's low-pass below the injection it demodulates, the observer below
    that low-pass, the current loop at most f_pwm / 10, the speed clamp and trip above the drive's top
    speed; what the controller believes (``[controller.model]``) within :data:`MODEL_FACTOR_MAX` of
    the motor's own value; the travel's span a plausible stroke (1 mm at least). Each refusal names
    the slip of unit that brings the value in.

    Only the keys the file gives are checked (the designed ones are the design's); after the C
    library's own limits (a value beyond what it takes at all is refused there, naming its limit).

    Parameters
    ----------
    sc : Scenario
        The designed scenario.
    tau : float
        m, the motor's pole pitch.
    user_keys : set of str
        The dotted keys the file gives.
    believed : dict
        The motor's own value of each ``controller.model`` key (``controller.model.L_d``: its mean
        L_d, H; ``R_s``, ``mass``, ``force_constant``, ``psi_pm``).

    Raises
    ------
    InputError
        Naming the key, its value, the range or the relation, and the likely slip of unit.
    """
    from linsense.plausible import check
    from linsense.scenario.keys import unit_kinds

    s = sc.spec
    kinds = unit_kinds()
    for key, kind in kinds.items():
        value = _value_at(s, key) if key in user_keys else None
        if isinstance(value, int | float) and not isinstance(value, bool):
            check(sc.source, key, value, kind)
    _check_believed(sc, kinds, user_keys, believed)
    _check_stroke(sc, user_keys)
    _check_relations(sc, kinds, tau, user_keys)


def _check_believed(sc: Scenario, kinds: dict[str, str], user_keys: set[str],
                    believed: dict[str, float]) -> None:
    """Refuse a ``controller.model`` value the file gives more than :data:`MODEL_FACTOR_MAX` times off
    the motor's own (``believed``), naming the likely slip of unit (:func:`check_units`)."""
    from linsense.plausible import KINDS, slip

    for key, own in believed.items():
        value = _value_at(sc.spec, key)
        if key not in user_keys or value is None or not own > 0.0:
            continue

        def near(v: float, own: float = own) -> bool:
            return own / MODEL_FACTOR_MAX <= v <= own * MODEL_FACTOR_MAX

        if not near(value):
            hint = slip(kinds[key], value, ok=near) if key in kinds else ""
            unit = KINDS[kinds[key]].unit if key in kinds else "Wb"
            raise InputError(sc.source, key, f"{value:g} {unit} is more than {MODEL_FACTOR_MAX:g} times off "
                             f"the motor's {own:.4g} {unit} (what the controller believes is off by tens of "
                             "% in a parameter mismatch)" + (f"; {hint}" if hint else ""))


def _check_stroke(sc: Scenario, user_keys: set[str]) -> None:
    """Refuse a travel the file gives whose span is no plausible stroke (:func:`check_units`)."""
    from linsense.plausible import KINDS, implausible

    tr = sc.spec.travel
    given = [k for k in ("travel.max_mm", "travel.min_mm") if k in user_keys]
    # (0.1 typed for 100 mm: "fault travel" at 0.06 s; a travel beyond any stroke is "unbounded")
    short = given and tr.max_mm - tr.min_mm < KINDS["stroke"].low * 1e3
    stroke = implausible("stroke", tr.max_mm - tr.min_mm, "mm") if short else None
    if stroke is not None:
        raise InputError(sc.source, given[0],
                         f"the travel [{tr.min_mm:g}, {tr.max_mm:g}] mm: its span {stroke}")


def _check_relations(sc: Scenario, kinds: dict[str, str], tau: float, user_keys: set[str]) -> None:
    """Refuse a frequency or electrical speed the file gives that breaks its relation to another
    (:func:`check_units`), naming the likely slip of unit."""
    from linsense.plausible import KINDS, implausible, slip

    s = sc.spec
    for key, holds, rule in _relations(s, tau):
        value = _value_at(s, key)
        if key in user_keys and not holds(value):
            # (no unit to blame for a plausible speed: 3 m/s is no 3 mm/s typed)
            plain = kinds[key] == "speed" and implausible("speed", value) is None
            hint = "" if plain else slip(kinds[key], value, ok=holds)
            unit = KINDS[kinds[key]].unit
            raise InputError(sc.source, key,
                             f"{value:g} {unit} must be {rule}" + (f"; {hint}" if hint else ""))


def _relations(s, tau: float) -> list[tuple[str, Callable[[float], bool], str]]:
    """The relations :func:`check_units` holds the file's values to: (key, must hold, what it must be
    and why), from the scenario's values ``s`` (its spec) and the pole pitch ``tau`` (m)."""
    f_pwm = s.inverter.f_pwm
    f_inj = f_pwm / 2.0 if s.injection.shape == "square" else s.injection.frequency
    lpf, v_max = s.observer.demod_lpf_hz, s.controller.v_max
    w_top = 2.0 * math.pi * v_max / tau
    v_lin, i_max = s.inverter.v_dc / math.sqrt(3.0), s.controller.i_max
    v_clamp = s.observer.omega_max * tau / (2.0 * math.pi)  # m/s
    speed = (f"the electrical speed of controller.v_max = {v_max:g} m/s, 2 pi v_max / pole pitch = "
             f"{w_top:.4g} rad/s")
    return [
        ("observer.demod_lpf_hz", lambda v: v < f_inj,
         f"below the injection frequency, {f_inj:g} Hz (the low-pass keeps the demodulated error and removes "
         "the products' ripple at twice the injection)"),
        ("observer.bandwidth_hz", lambda v: v < lpf,
         f"below the demodulator's low-pass observer.demod_lpf_hz = {lpf:g} Hz, whose output it follows"),
        ("controller.current_bandwidth_hz", lambda v: v <= f_pwm / 10.0,
         f"at most f_pwm / 10 = {f_pwm / 10.0:g} Hz (a current loop sampled once per PWM period, with a "
         "period's delay, has no phase margin left far beyond)"),
        ("observer.omega_max", lambda v: v > w_top,
         f"above {speed} (the estimate would be clamped below the speeds the drive commands)"),
        ("protection.omega_max", lambda v: v > w_top,
         f"above {speed} (the over-speed trip would fire at speeds the drive commands)"),
        ("startup.v_pulse", lambda v: v < v_lin,
         f"below the bus's linear range V_dc / sqrt(3) = {v_lin:.4g} V (a larger pulse is clipped by the "
         "modulator)"),
        ("calibration.dither_a", lambda v: v < i_max,
         f"below controller.i_max = {i_max:g} A (the dither rides on the current reference, clamped there)"),
        ("inverter.dtc_current_band", lambda v: v < i_max,
         f"below controller.i_max = {i_max:g} A (a band beyond the current reference leaves the "
         "compensation a slope, no sign)"),
        ("observer.handover_v_lo", lambda v: not s.observer.emf or v < v_clamp,
         f"below the speed of the observer's clamp, observer.omega_max = {s.observer.omega_max:.4g} rad/s, "
         f"{v_clamp:.3g} m/s (the estimate never reaches a band above it: the EMF estimate would never "
         "take over)"),
        ("observer.hf_delay_s", lambda v: v * f_inj <= 10.0,
         f"at most ten injection periods, {10.0 / f_inj:g} s (the HF path's delay is about one)"),
    ]
