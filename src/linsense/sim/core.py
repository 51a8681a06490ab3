"""Low-level access to the C simulator (``csrc/sim/``, API ``ls_sim.h``): configure, run, collect arrays.

Everything per step happens in C; Python only fills the configuration structs, allocates the
numpy output arrays and hands pointers over. Higher layers (scenario files, metrics, the CLI)
are in :mod:`linsense.scenario`, :mod:`linsense.sim.simulation` and friends.
"""

from __future__ import annotations

import contextlib
import math
import signal
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from linsense._ctrl import ffi, lib
from linsense.errors import SimulationError
from linsense.scenario import sections as _sc
from linsense.sim.plant import fill_plant

FIDELITIES = {"average": lib.LS_SIM_AVERAGE, "switching": lib.LS_SIM_SWITCHING}
MOTIONS = {"free": lib.LS_SIM_FREE, "held": lib.LS_SIM_HELD, "prescribed": lib.LS_SIM_PRESCRIBED}
LOADS = {
    "constant": lib.LS_SIM_LOAD_CONSTANT,
    "step": lib.LS_SIM_LOAD_STEP,
    "incline": lib.LS_SIM_LOAD_INCLINE,
}
MODES = {
    "off": lib.LS_MODE_OFF,
    "sensored": lib.LS_MODE_SENSORED,
    "sensorless_lut": lib.LS_MODE_SENSORLESS_LUT,
    "sensorless_nolut": lib.LS_MODE_SENSORLESS_NOLUT,
    "calibration": lib.LS_MODE_CALIBRATION,
    "startup": lib.LS_MODE_STARTUP,
    "commission": lib.LS_MODE_COMMISSION,
}
#: Recorded signals: name -> values per sample.
SIGNALS = {
    "t": 1, "x": 1, "v": 1, "x_est": 1, "v_est": 1, "x_ref": 1, "theta_err": 1,
    "i_abc": 3, "i_dq": 2, "duty": 3, "force": 1, "err_sig": 1,
}
#: Block statistics (``ls_sim_out`` x_min ... i_abc_max): name -> values per sample. The min, max
#: and mean over the ``decimate`` periods each sample opens (docs/simulator.md, "Block statistics").
BLOCKS = {
    "x_min": 1, "x_max": 1, "x_mean": 1, "err_min": 1, "err_max": 1, "err_mean": 1,
    "i_abc_min": 3, "i_abc_max": 3,
}
#: PWM periods per call of the C loop in :func:`run_closed_loop_chunks` (rounded to whole blocks).
CHUNK = 2**18
#: Fault bits of the simulation itself (the drive's LS_FAULT_* bits are below 0x100).
SIM_FAULT_TRAVEL = int(lib.LS_SIM_FAULT_TRAVEL)
SIM_FAULT_DIVERGED = int(lib.LS_SIM_FAULT_DIVERGED)
SIM_FAULT_STOPPED = int(lib.LS_SIM_FAULT_STOPPED)


def _default(section, key: str):
    """The scenario file's default of ``[section] key`` (one source: linsense.scenario.sections, which
    reads the controller library's defaults from C)."""
    return section.model_fields[key].default


@dataclass
class PlantSetup:
    """Everything of ``ls_sim_cfg`` that is not the motor (SI units); the defaults are the scenario
    file's (docs/simulator.md), converted to SI.

    Attributes
    ----------
    fidelity : str
        ``"average"`` or ``"switching"``.
    v_dc : float
        DC bus, V.
    f_pwm : float
        PWM frequency = control rate, Hz.
    dead_time : float
        s.
    i_gain : tuple of float
        Per-phase current-sensor gains, dimensionless.
    i_offset : tuple of float
        Per-phase current-sensor offsets, A.
    i_noise : float
        Current-sensor noise, A rms.
    adc_bits : int
        ADC resolution (0: ideal).
    adc_range : float
        ADC full scale, +- A.
    enc_counts : int
        Encoder counts per electrical period.
    seed : int
        Current-noise seed.
    motion : str
        ``"free"``, ``"held"`` or ``"prescribed"`` (not a scenario key).
    x0 : float
        Initial position, m.
    v0 : float
        Initial speed, m/s.
    x_min : float
        Lower travel limit, m.
    x_max : float
        Upper travel limit, m.
    load : str
        ``"constant"``, ``"step"`` or ``"incline"``.
    load_f0 : float
        Load force, N (opposes positive motion when > 0).
    load_f1 : float
        Load force after the step, N.
    load_t : float
        Time of the step, s.
    load_incline : float
        Incline, rad.
    decimate : int
        Record every n-th period.
    i_abort : float
        ``|phase current|`` treated as divergence, A.
    """

    fidelity: str = _default(_sc.InverterSection, "fidelity")  # "average" or "switching"
    v_dc: float = _default(_sc.InverterSection, "v_dc")  # V
    f_pwm: float = _default(_sc.InverterSection, "f_pwm")  # Hz, PWM = control rate
    dead_time: float = _default(_sc.InverterSection, "dead_time")  # s
    i_gain: tuple[float, float, float] = (1.0, 1.0, 1.0)    # -
    i_offset: tuple[float, float, float] = (0.0, 0.0, 0.0)  # A
    i_noise: float = _default(_sc.SensorsSection, "current_noise")  # A rms
    adc_bits: int = _default(_sc.SensorsSection, "adc_bits")  # 0: ideal
    adc_range: float = _default(_sc.SensorsSection, "adc_range")  # A, +- full scale
    enc_counts: int = _default(_sc.SensorsSection, "encoder_counts_per_period")  # counts per period
    seed: int = _default(_sc.ScenarioSection, "seed")
    motion: str = "free"             # "free", "held", "prescribed" (not a scenario key)
    x0: float = 1e-3 * _default(_sc.InitialSection, "position_mm")  # m
    v0: float = 0.0                  # m/s
    x_min: float = 1e-3 * _default(_sc.TravelSection, "min_mm")  # m, travel limits
    x_max: float = 1e-3 * _default(_sc.TravelSection, "max_mm")  # m
    load: str = _default(_sc.LoadSection, "type")  # "constant", "step", "incline"
    load_f0: float = _default(_sc.LoadSection, "force")  # N (opposes positive motion when > 0)
    load_f1: float = _default(_sc.LoadSection, "force_after")  # N, after the step
    load_t: float = _default(_sc.LoadSection, "time")  # s, time of the step
    load_incline: float = math.radians(_default(_sc.LoadSection, "incline_deg"))  # rad
    decimate: int = _default(_sc.RecordSection, "decimate")  # record every n-th period
    i_abort: float = _default(_sc.ProtectionSection, "i_abort")  # A, |phase current| treated as divergence


def plant_template(motor, lab: tuple | None = None):
    """An ``ls_sim_cfg`` (cffi) with only the motor part filled (:func:`fill_plant`).

    What :func:`sim_cfg` copies instead of filling it again (a sweep runs one motor thousands of
    times).

    Parameters
    ----------
    motor : Motor
        The motor.
    lab : tuple or None, optional
        Passed to :func:`fill_plant`.

    Returns
    -------
    cffi ``ls_sim_cfg *``
        The configuration.
    """
    c = ffi.new("ls_sim_cfg *")
    fill_plant(c, motor, lab=lab)
    return c


def sim_cfg(motor, setup: PlantSetup, lab: tuple | None = None, template=None):
    """A filled ``ls_sim_cfg`` (cffi) for ``motor`` and ``setup``; checked by the C side.

    Parameters
    ----------
    motor : Motor
        The motor.
    setup : PlantSetup
        Everything else of the plant.
    lab : tuple or None, optional
        Passed to :func:`fill_plant`.
    template : cffi ``ls_sim_cfg *`` or None, optional
        :func:`plant_template` of ``motor`` (copied; never changed).

    Returns
    -------
    cffi ``ls_sim_cfg *``
        The configuration.

    Raises
    ------
    linsense.errors.SimulationError
        When ``ls_sim_check`` refuses it.
    """
    c = ffi.new("ls_sim_cfg *")
    if template is None:
        fill_plant(c, motor, lab=lab)
    else:
        ffi.memmove(c, template, ffi.sizeof("ls_sim_cfg"))
    c.fidelity = FIDELITIES[setup.fidelity]
    c.motion = MOTIONS[setup.motion]
    c.load = LOADS[setup.load]
    for name in ("v_dc", "f_pwm", "dead_time", "i_noise", "adc_bits", "adc_range", "enc_counts", "seed",
                 "x0", "v0", "x_min", "x_max", "load_f0", "load_f1", "load_t", "load_incline", "decimate",
                 "i_abort"):
        setattr(c, name, getattr(setup, name))
    c.i_gain = list(setup.i_gain)
    c.i_offset = list(setup.i_offset)
    if lib.ls_sim_check(c) != lib.LS_OK:
        raise SimulationError(f"simulator configuration refused: {setup}")
    return c


def _outputs(n_rec: int, signals=None, blocks=()) -> tuple[dict[str, np.ndarray], object]:
    """Output arrays of ``n_rec`` samples (NaN until written) and the ``ls_sim_out`` pointing at
    them: the point ``signals`` (names of :data:`SIGNALS`; None: all) and the ``blocks`` (names of
    :data:`BLOCKS`); ``fault`` always."""
    width = {**SIGNALS, **BLOCKS}
    names = list(SIGNALS if signals is None else signals) + list(blocks)
    unknown = [k for k in names if k not in width]
    if unknown:
        raise ValueError(f"unknown recorded signal(s) {unknown}; known: {sorted(width)}")
    arrays = {k: np.full((n_rec, width[k]) if width[k] > 1 else n_rec, np.nan) for k in names}
    arrays["fault"] = np.zeros(n_rec, dtype=np.uint32)
    out = ffi.new("ls_sim_out *")
    for k, a in arrays.items():
        ctype = "uint32_t *" if k == "fault" else "double *"
        setattr(out, k, ffi.cast(ctype, ffi.from_buffer(a)))
    return arrays, out


@dataclass
class RawRun:
    """Arrays and end state of one C run (arrays cut to the samples written).

    Attributes
    ----------
    arrays : dict of str to ndarray
        Recorded signals by name (empty for a chunked run).
    steps_done : int
        PWM periods run.
    fault : int
        Fault bits at the end.
    x_end : float
        Final position, m.
    v_end : float
        Final speed, m/s.
    wall_s : float
        Wall time of the C run alone (outputs allocated before), s.
    extra : dict
        Anything else a caller keeps with the run (empty from this module's functions).
    """

    arrays: dict[str, np.ndarray]
    steps_done: int
    fault: int
    x_end: float
    v_end: float
    wall_s: float = math.nan  # s, wall time of the C run alone (outputs allocated before)
    extra: dict = field(default_factory=dict)


def _collect(arrays, res, wall_s: float) -> RawRun:
    n = int(res.n_rec)
    return RawRun({k: a[:n] for k, a in arrays.items()}, int(res.steps_done), int(res.fault),
                  float(res.x_end), float(res.v_end), wall_s)


@contextlib.contextmanager
def _sigint_held():
    """Hold SIGINT back in this thread (POSIX) for the duration; it is delivered at the end."""
    if not hasattr(signal, "pthread_sigmask"):
        yield
        return
    old = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


def _c_commands(commands):
    cmds = sorted(commands, key=lambda c: c[0])
    c_cmds = ffi.new("ls_sim_cmd[]", max(1, len(cmds)))
    for j, (t, x, move) in enumerate(cmds):
        c_cmds[j].t, c_cmds[j].x, c_cmds[j].move = float(t), float(x), int(bool(move))
    return c_cmds, len(cmds)


def _call_interruptible(call, stop) -> tuple[int, float]:
    """``call()`` (a C function that releases the GIL and polls ``stop[0]``), in a thread when this
    is the main thread, so that Ctrl-C reaches Python: the flag is set, the C loop stops at its next
    poll (milliseconds) and the interrupt is raised once it has let go of its buffers. Returns the
    status and the wall time (s) of the call alone."""
    status = []
    done = threading.Event()

    def work() -> None:  # (the wall time of the C run alone, not of the thread around it)
        try:
            t0 = time.perf_counter()
            status.append(call())
            status.append(time.perf_counter() - t0)
        finally:
            done.set()

    if threading.current_thread() is threading.main_thread():
        worker = threading.Thread(target=work, name="linsense-sim")
        started = False
        try:
            with _sigint_held():  # (an interrupt inside start() would leave the thread running)
                worker.start()
                started = True
            while not done.wait(0.05):
                pass
        except BaseException:
            stop[0] = 1
            # an interrupt raised inside start() (Python's interrupt_main is not held back by the
            # signal mask; a loaded machine can keep start() waiting for the new thread) may come
            # after the thread was spawned: it then runs, and stops at its first poll
            t_spawn = time.monotonic() + 2.0
            while not started and worker.ident is None and time.monotonic() < t_spawn:
                try:
                    time.sleep(0.01)
                except KeyboardInterrupt:
                    pass
            started = started or worker.ident is not None
            # the C loop holds pointers into the caller's buffers: wait for it to stop (an event,
            # not Thread.join, which an interrupt can leave believing the thread has ended)
            while started and not done.is_set():
                try:
                    done.wait(0.05)
                except KeyboardInterrupt:
                    pass
            # (then let the thread end: it only returns from work(), the C loop done; on a loaded
            # machine that can take longer than one join's wait)
            t_end = time.monotonic() + 10.0
            while started and worker.is_alive() and time.monotonic() < t_end:
                try:
                    worker.join(0.1)
                except KeyboardInterrupt:
                    pass
            raise
    else:
        work()
    return status[0], status[1]


def run_closed_loop(cfg, drive, n_steps: int, commands=(), *, signals=None, blocks=(),
                    runner: Callable | None = None) -> RawRun:
    """Run ``n_steps`` PWM periods of ``drive`` around the plant ``cfg``.

    Parameters
    ----------
    cfg : cffi ``ls_sim_cfg *``
        The plant (:func:`sim_cfg`).
    drive : cffi ``ls_drive *``
        An initialised drive with its mode set.
    n_steps : int
        PWM periods.
    commands : iterable of (float, float, bool), optional
        ``(t [s], x [m], move)``.
    signals : iterable of str or None, optional
        The point signals to record (names of :data:`SIGNALS`; None: all).
    blocks : iterable of str, optional
        The block statistics (names of :data:`BLOCKS`); ``fault`` is always recorded.
    runner : callable or None, optional
        The time loop: ``runner(cfg, drive, cmds, n_cmds, n_steps, out, res) -> status``, the
        arguments and the status of ``ls_sim_run`` (the default). The processor in the loop gives
        one whose drive runs on the Cortex-M4F under QEMU (:func:`linsense.firmware.pil.run_pil`).

    Returns
    -------
    RawRun
        The arrays and end state.

    Raises
    ------
    linsense.errors.SimulationError
        When the loop refuses its inputs (a status other than ``LS_OK``).
    """
    c_cmds, n_cmds = _c_commands(commands)
    n_rec = int(math.ceil(n_steps / cfg.decimate)) + 2
    arrays, out = _outputs(n_rec, signals, blocks)
    res = ffi.new("ls_sim_result *")
    stop = ffi.new("int32_t *", 0)
    out.stop = stop
    loop = lib.ls_sim_run if runner is None else runner
    st, wall = _call_interruptible(lambda: loop(cfg, drive, c_cmds, n_cmds, int(n_steps), out, res), stop)
    if st != lib.LS_OK:
        name = "ls_sim_run" if runner is None else getattr(runner, "__name__", "the loop")
        raise SimulationError(f"{name} refused its inputs (status {st})")
    return _collect(arrays, res, wall)


def run_closed_loop_chunks(cfg, drive, n_steps: int, commands=(), *, on_chunk, chunk: int = CHUNK,
                           signals=None, blocks=()) -> RawRun:
    """The run of :func:`run_closed_loop` in chunks that reuse one set of output buffers.

    Chunks of about ``chunk`` PWM periods (rounded up to whole blocks of ``cfg.decimate``), so memory
    does not grow with the duration. The samples are bit for bit those of one
    :func:`run_closed_loop`.

    Parameters
    ----------
    cfg : cffi ``ls_sim_cfg *``
        The plant.
    drive : cffi ``ls_drive *``
        An initialised drive with its mode set.
    n_steps : int
        PWM periods.
    commands : iterable of (float, float, bool), optional
        ``(t [s], x [m], move)``.
    on_chunk : callable
        ``on_chunk(arrays)`` receives each chunk's samples (``{name: array}``, views into the
        buffers, valid until it returns: copy or write them out) in order.
    chunk : int, optional
        PWM periods per chunk.
    signals : iterable of str or None, optional
        The point signals to record (None: all).
    blocks : iterable of str, optional
        The block statistics.

    Returns
    -------
    RawRun
        The end state with empty ``arrays``; ``wall_s`` is the time spent in C alone.

    Raises
    ------
    linsense.errors.SimulationError
        When ``ls_sim_begin`` or ``ls_sim_continue`` refuses.
    """
    c_cmds, n_cmds = _c_commands(commands)
    dec = int(cfg.decimate)
    per_call = max(1, -(-int(chunk) // dec)) * dec
    arrays, out = _outputs(per_call // dec + 2, signals, blocks)
    res = ffi.new("ls_sim_result *")
    state = ffi.new("ls_sim_state *")
    stop = ffi.new("int32_t *", 0)
    out.stop = stop
    if lib.ls_sim_begin(cfg, state) != lib.LS_OK:
        raise SimulationError("ls_sim_begin refused the configuration")
    wall, done = 0.0, 0
    while done < n_steps and not state.ended:
        n = min(per_call, int(n_steps) - done)
        st, w = _call_interruptible(
            lambda n=n: lib.ls_sim_continue(cfg, drive, c_cmds, n_cmds, state, n, out, res), stop)
        wall += w
        if st != lib.LS_OK:
            raise SimulationError(f"ls_sim_continue refused its inputs (status {st})")
        done += n
        k = int(res.n_rec)
        if k:
            on_chunk({name: a[:k] for name, a in arrays.items()})
    return RawRun({}, int(res.steps_done), int(res.fault), float(res.x_end), float(res.v_end), wall)


def run_open_loop(cfg, seg_t: np.ndarray, seg_v: np.ndarray) -> RawRun:
    """Apply pole voltages ``seg_v`` for durations ``seg_t`` to the plant.

    Parameters
    ----------
    cfg : cffi ``ls_sim_cfg *``
        The plant.
    seg_t : ndarray, shape (n,)
        Durations, s.
    seg_v : ndarray, shape (n, 3)
        Pole voltages, V.

    Returns
    -------
    RawRun
        ``n + 1`` samples at the segment boundaries (``duty`` holds the applied voltages).

    Raises
    ------
    linsense.errors.SimulationError
        Mismatched segments, or ``ls_sim_open_loop`` refuses.
    """
    seg_t = np.ascontiguousarray(seg_t, dtype=float)
    seg_v = np.ascontiguousarray(seg_v, dtype=float).reshape(-1, 3)
    if seg_t.shape[0] != seg_v.shape[0]:
        raise SimulationError("seg_t and seg_v must have the same number of segments")
    arrays, out = _outputs(seg_t.size + 1)
    res = ffi.new("ls_sim_result *")
    t0 = time.perf_counter()
    st = lib.ls_sim_open_loop(cfg, ffi.cast("double *", ffi.from_buffer(seg_t)),
                              ffi.cast("double *", ffi.from_buffer(seg_v)), seg_t.size, out, res)
    wall = time.perf_counter() - t0
    if st != lib.LS_OK:
        raise SimulationError(f"ls_sim_open_loop refused its inputs (status {st})")
    return _collect(arrays, res, wall)


def plant_eval(cfg, theta: float) -> dict[str, np.ndarray]:
    """The C plant's maps at ``theta``.

    Parameters
    ----------
    cfg : cffi ``ls_sim_cfg *``
        The plant.
    theta : float
        Electrical position, rad.

    Returns
    -------
    dict of str to ndarray
        ``L_ab`` (aa, bb, ab; H), ``dL_ab`` (H/rad), ``lambda_pm`` (alpha-beta, Wb) and
        ``dlambda_pm`` (Wb/rad).
    """
    lab, dlab = ffi.new("double[3]"), ffi.new("double[3]")
    lpm, dlpm = ffi.new("double[2]"), ffi.new("double[2]")
    lib.ls_sim_plant_eval(cfg, float(theta), lab, dlab, lpm, dlpm)
    return {"L_ab": np.array(list(lab)), "dL_ab": np.array(list(dlab)),
            "lambda_pm": np.array(list(lpm)), "dlambda_pm": np.array(list(dlpm))}


def plant_force(cfg, theta: float, i_ab) -> float:
    """The C plant's force at ``theta`` for alpha-beta currents ``i_ab``.

    Parameters
    ----------
    cfg : cffi ``ls_sim_cfg *``
        The plant.
    theta : float
        Electrical position, rad.
    i_ab : sequence of float
        Alpha-beta currents, A.

    Returns
    -------
    float
        N.
    """
    i = ffi.new("double[2]", [float(i_ab[0]), float(i_ab[1])])
    return float(lib.ls_sim_force(cfg, float(theta), i))

