"""One run streamed in chunks: the trace handed on chunk by chunk, never whole in memory.

``linsense simulate`` runs this way (docs/simulator.md, "Single runs in chunks"): the C loop runs
in chunks of reused buffers (:func:`linsense.sim.core.run_closed_loop_chunks`); each chunk goes to
the trace writer and into two :class:`Reducer` objects, one keeping what the metrics need (the
point values, and the block statistics when ``decimate > 1``; merged into blocks of several
samples when the run has more than :data:`METRICS_CAP` samples), one the binned envelopes the
figure draws (:data:`PLOT_BINS` bins at most). Memory does not grow with the duration.

With up to :data:`METRICS_CAP` samples the metrics are exactly those of
:func:`linsense.sim.run.simulate` on the same scenario; beyond, they are computed from the block
envelopes as in a metrics-only run (times to one block, ``metrics["block_s"]``). Of those samples
only the ones a metric can depend on are kept (:class:`MetricSamples`); a run without a trace and
without a figure (``linsense simulate --trace none``) records only the signals the metrics read,
in chunks of :data:`METRICS_CHUNK` periods: its memory stays flat at any duration, its metrics are
those of the same run with a trace.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from linsense.sim.build import Built
from linsense.sim.core import BLOCKS, CHUNK, run_closed_loop_chunks
from linsense.sim.metrics import block_views, finite_positions, transient_mask
from linsense.sim.run import METRICS_BLOCKS, METRICS_SIGNALS, finish_metrics, run_metrics

#: samples the metrics keep at most (beyond, consecutive samples are merged into blocks): 2**19,
#: 33 s at 16 kHz with ``decimate = 1``; at most 40 MB
METRICS_CAP = 2**19
#: PWM periods per chunk of a run that hands no chunk on (metrics only): 2**15, 1 MB of buffers
METRICS_CHUNK = 2**15
#: bins of the figure at most (each at least one injection period)
PLOT_BINS = 2000

#: (operation, sources in order of preference): the first source a chunk has is reduced
Spec = dict[str, tuple[str, tuple[str, ...]]]

#: the metrics of a run with point values only (decimate 1, no merging): the samples themselves
POINT_SPEC: Spec = {"t": ("first", ("t",)), "x": ("last", ("x",)), "theta_err": ("first", ("theta_err",))}
#: the metrics from block envelopes (``decimate > 1`` or merged samples); ``x`` is the last point
#: value of each block (``final_position_mm`` is the last sample's), ``t`` the block's start
BLOCK_SPEC: Spec = {
    **POINT_SPEC,
    "x_min": ("min", ("x_min", "x")), "x_max": ("max", ("x_max", "x")), "x_mean": ("mean", ("x_mean", "x")),
    "err_min": ("min", ("err_min", "theta_err")), "err_max": ("max", ("err_max", "theta_err")),
    "err_mean": ("mean", ("err_mean", "theta_err")),
}
#: the figure's bins (:func:`linsense.report.sim_figures.sim_figure`)
PLOT_SPEC: Spec = {
    "t": ("mean", ("t",)), "x_ref": ("mean", ("x_ref",)), "x_est": ("mean", ("x_est",)),
    "x_lo": ("min", ("x_min", "x")), "x_hi": ("max", ("x_max", "x")), "x_mean": ("mean", ("x_mean", "x")),
    "err_lo": ("min", ("err_min", "theta_err")), "err_hi": ("max", ("err_max", "theta_err")),
    "err_mean": ("mean", ("err_mean", "theta_err")),
    "i_lo": ("min", ("i_abc_min", "i_abc")), "i_hi": ("max", ("i_abc_max", "i_abc")),
    "force": ("mean", ("force",)),
}


def _nanmean(a: np.ndarray, axis: int) -> np.ndarray:
    ok = np.isfinite(a)
    n = ok.sum(axis=axis)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(n > 0, np.where(ok, a, 0.0).sum(axis=axis) / np.maximum(n, 1), np.nan)


_OPS = {
    "first": lambda g: g[:, 0].copy(),  # (a copy: g views the reused buffers of the C run)
    "last": lambda g: g[:, -1].copy(),
    "min": lambda g: np.fmin.reduce(g, axis=1),  # NaN only where the whole group is NaN
    "max": lambda g: np.fmax.reduce(g, axis=1),
    "mean": lambda g: _nanmean(g, 1),
}


class Reducer:
    """Groups of ``k`` consecutive samples of a streamed trace reduced to one sample each.

    ``spec``: output name -> (operation, sources): ``first``, ``last``, ``min``, ``max`` or ``mean``
    (NaN ignored) of the first source the chunks have (e.g. ``x_min`` when the run records block
    statistics, else the point value ``x``). Feed chunks with :meth:`add` (views are fine: what
    is kept is copied), then :meth:`finish`. ``k = 1`` keeps every sample (min of one = itself).
    ``sink`` receives the reduced samples instead of them being kept.

    Parameters
    ----------
    k : int
        Samples per group, at least 1.
    spec : dict
        Output name to ``(operation, sources)``.
    sink : callable or None, optional
        Given each batch of reduced samples (``{output name: array}``, in order) instead of keeping
        them (:meth:`finish` then returns nothing).

    Raises
    ------
    ValueError
        When ``k`` is below 1.
    """

    def __init__(self, k: int, spec: Spec, sink: Callable | None = None) -> None:
        if k < 1:
            raise ValueError(f"k must be >= 1, got {k}")
        self.k, self.spec, self.sink = int(k), spec, sink
        self.src: dict[str, str] | None = None
        self.pending: dict[str, np.ndarray] = {}
        self.parts: list[dict[str, np.ndarray]] = []
        self.n_in = 0

    def _reduce(self, arrays: dict[str, np.ndarray], k: int) -> None:
        n = len(next(iter(arrays.values())))
        m = n // k
        if m:
            part = {}
            for out, (op, _) in self.spec.items():
                a = arrays[self.src[out]]
                part[out] = _OPS[op](a[: m * k].reshape(m, k, *a.shape[1:]))
            if self.sink is not None:
                self.sink(part)
            else:
                self.parts.append(part)

    def add(self, arrays: dict[str, np.ndarray]) -> None:
        """Feed a chunk of samples.

        Parameters
        ----------
        arrays : dict of str to ndarray
            Signal name to the chunk's samples (views are fine).

        Raises
        ------
        ValueError
            When the first chunk has none of an output's sources.
        """
        if self.src is None:
            self.src = {}
            for out, (_, sources) in self.spec.items():
                have = [s for s in sources if s in arrays]
                if not have:
                    raise ValueError(f"no source for {out!r} among {sorted(arrays)}")
                self.src[out] = have[0]
        names = set(self.src.values())
        n = len(arrays[next(iter(names))])
        self.n_in += n
        if self.pending:
            arrays = {s: np.concatenate([self.pending[s], arrays[s]]) for s in names}
            n = len(arrays[next(iter(names))])
        m = n // self.k
        self._reduce({s: arrays[s][: m * self.k] for s in names}, self.k)
        self.pending = {s: np.array(arrays[s][m * self.k:]) for s in names}

    def finish(self, split_last: bool = False) -> dict[str, np.ndarray] | None:
        """The reduced arrays; an unfinished last group is reduced as it is.

        Parameters
        ----------
        split_last : bool, optional
            The last sample (the state that tripped a fault) becomes a group of its own.

        Returns
        -------
        dict of str to ndarray or None
            Output name to the reduced samples (empty arrays when nothing was fed); None with a
            ``sink``: the rest handed to it.
        """
        rest = self.pending
        n = len(next(iter(rest.values()))) if rest else 0
        if n:
            if split_last and n > 1:
                self._reduce({s: a[:-1] for s, a in rest.items()}, n - 1)
                self._reduce({s: a[-1:] for s, a in rest.items()}, 1)
            else:
                self._reduce(rest, n)
        self.pending = {}
        if self.sink is not None:
            return None
        if not self.parts:
            return {out: np.empty(0) for out in self.spec}
        return {out: np.concatenate([p[out] for p in self.parts]) for out in self.spec}


def _concat(a: dict[str, np.ndarray] | None, b: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    return b if a is None else {k: np.concatenate([a[k], b[k]]) for k in b}


class MetricSamples:
    """The reduced samples of a streamed run that its metrics can still depend on, in order: memory
    that does not grow with the duration, metrics that are those of every sample.

    Fed with the batches of reduced samples (the :data:`POINT_SPEC` or :data:`BLOCK_SPEC` outputs of
    a :class:`Reducer`, as its ``sink``), it keeps every sample of the last ``final_window_s`` (the
    end window's means: bias, offset) and, of the samples before, only those that decide a metric
    of :func:`linsense.sim.metrics.compute_metrics`: the largest estimation error (over the run,
    and in the transient and steady parts after ``convergence_s``), the first sample with a
    non-finite position and the last with a finite one, and from the last move's start the extreme
    in the move's direction (overshoot), the closest approach to the target (reached), the first
    sample, and the last sample outside the settling band with the next one (settling time). Every
    other sample before the end window enters the metrics only through a maximum or a minimum that
    one of those holds, so :meth:`arrays` (a subsequence of the samples) gives the metrics of all of
    them, bit for bit. A non-finite time (never from the C core) keeps every sample from then on.

    Parameters
    ----------
    moves : iterable of (float, float, float, float)
        The planned moves ``(t0, t1, x0, x1)``, s and m.
    convergence_s : float
        ``metrics.convergence_s``, s.
    settle_s : float
        ``metrics.settle_s``, s.
    final_window_s : float
        The end window, s.
    settling_band_deg : float
        The settling band, electrical deg.
    pole_pitch : float
        m.
    x_target : float
        The final target without a move, m.
    """

    def __init__(self, *, moves, convergence_s: float, settle_s: float, final_window_s: float,
                 settling_band_deg: float, pole_pitch: float, x_target: float) -> None:
        self.moves = list(moves)
        self.convergence_s, self.settle_s = convergence_s, settle_s
        self.window = max(0.0, float(final_window_s))
        # (the band in m and the settling target as compute_metrics computes them, to the last bit)
        self.band = settling_band_deg / (360.0 / pole_pitch)
        self.x_to = self.moves[-1][3] if self.moves else x_target
        self.t_last = self.moves[-1][0] if self.moves else 0.0
        self.kept: dict[str, np.ndarray] | None = None
        self.tail: dict[str, np.ndarray] | None = None
        self.compact = True

    def add(self, part: dict[str, np.ndarray]) -> None:
        """Take a batch of reduced samples (a :class:`Reducer`'s ``sink``).

        Parameters
        ----------
        part : dict of str to ndarray
            Output name to the batch's samples, in order.
        """
        if not np.isfinite(part["t"]).all():
            self.compact = False
        self.tail = _concat(self.tail, part)
        t = self.tail["t"]
        if not self.compact or t.size < 3:
            return
        # samples before the end window whatever the run's end: the end window starts at or after
        # t_end - window, t_end (the last sample, or the one before it after a fault) >= t[-2]
        e = int(t.searchsorted(t[-2] - self.window))
        if e:
            cand = _concat(self.kept, {k: a[:e] for k, a in self.tail.items()})
            idx = self._deciding(cand)
            self.kept = {k: a[idx] for k, a in cand.items()}
            self.tail = {k: a[e:].copy() for k, a in self.tail.items()}

    def _deciding(self, a: dict[str, np.ndarray]) -> np.ndarray:
        """The indices of the samples of ``a`` that decide a metric (see the class), ascending."""
        t = a["t"]
        x, x_lo, x_hi, _, e_lo, e_hi = block_views(a)  # (the views of compute_metrics)
        keep = np.zeros(t.size, dtype=bool)

        def extreme(v: np.ndarray, where: np.ndarray, pick) -> None:
            idx = np.flatnonzero(where)
            if idx.size:
                keep[idx[pick(v[idx])]] = True

        err = np.maximum(np.abs(e_lo), np.abs(e_hi))
        ok = np.isfinite(err)
        after = t >= self.convergence_s
        tr = transient_mask(t, self.moves, self.settle_s)
        extreme(err, ok, np.argmax)
        extreme(err, ok & after & tr, np.argmax)
        extreme(err, ok & after & ~tr, np.argmax)
        x_fin = finite_positions(x, x_lo, x_hi)
        idx = np.flatnonzero(~x_fin)
        if idx.size:
            keep[idx[0]] = True
        idx = np.flatnonzero(x_fin)
        if idx.size:
            keep[idx[-1]] = True
        idx = np.flatnonzero(x_fin & (t >= self.t_last))
        if idx.size:
            keep[idx[0]] = True
            if self.moves:
                _, _, x_from, x_to = self.moves[-1]
                direction = np.sign(x_to - x_from)
                if direction != 0:
                    x_far = x_hi if direction > 0 else x_lo
                    keep[idx[np.argmax(direction * (x_far[idx] - x_to))]] = True
                if x_lo is not x_hi:
                    gap = np.maximum(np.maximum(x_lo[idx] - x_to, x_to - x_hi[idx]), 0.0)
                else:
                    gap = np.abs(x[idx] - x_to)
                keep[idx[np.argmin(gap)]] = True
            dev = np.abs(x_lo[idx] - self.x_to)
            if x_lo is not x_hi:
                dev = np.maximum(dev, np.abs(x_hi[idx] - self.x_to))
            out = np.flatnonzero(dev > self.band)
            if out.size:
                keep[idx[out[-1]:out[-1] + 2]] = True
        return np.flatnonzero(keep)

    def arrays(self, names) -> dict[str, np.ndarray]:
        """The samples kept.

        Parameters
        ----------
        names : iterable of str
            The output names, for the empty arrays when no sample came.

        Returns
        -------
        dict of str to ndarray
            Output name to the samples kept, in order.
        """
        if self.tail is None:
            return {k: np.empty(0) for k in names}
        return _concat(self.kept, self.tail)


def plot_bin(n_rec: int, decimate: int, f_pwm: float, f_inj: float | None) -> int:
    """Samples per figure bin.

    At least one injection period (so the envelope holds the whole HF swing) and at most
    :data:`PLOT_BINS` bins; a whole number of injection periods when one is a whole number of
    samples.

    Parameters
    ----------
    n_rec : int
        Recorded samples.
    decimate : int
        PWM periods per sample.
    f_pwm : float
        PWM frequency, Hz.
    f_inj : float or None
        Injection frequency, Hz (None: no injection).

    Returns
    -------
    int
        Samples per bin.
    """
    per_inj = f_pwm / f_inj / decimate if f_inj else 1.0
    k = max(math.ceil(per_inj - 1e-9), math.ceil(n_rec / PLOT_BINS), 1)
    q = round(per_inj)
    if q >= 1 and abs(per_inj - q) < 1e-9:
        k = -(-k // q) * q
    return k


@dataclass
class PlotData:
    """What :func:`linsense.report.sim_figures.sim_figure` draws.

    The samples per injection period of the trace decide whether the force is drawn (only when the
    samples resolve the injection).

    Attributes
    ----------
    bins : dict of str to ndarray
        The bins of :data:`PLOT_SPEC`: ``t`` the bins' mean time, ``*_lo``/``*_hi`` envelopes,
        ``*_mean``/``x_ref``/``x_est``/``force`` means; ``i_lo``/``i_hi`` (n, 3).
    metrics : dict
        The run's metrics.
    name : str
        The scenario's name.
    f_pwm : float
        PWM frequency, Hz.
    decimate : int
        PWM periods per recorded sample.
    bin_samples : int
        Samples per bin.
    samples_per_injection : float or None
        Samples per injection period (None: no injection).
    """

    bins: dict[str, np.ndarray]
    metrics: dict
    name: str
    f_pwm: float
    decimate: int
    bin_samples: int
    samples_per_injection: float | None

    @property
    def bin_s(self) -> float:
        """The length of a bin (s)."""
        return self.bin_samples * self.decimate / self.f_pwm


def plot_data(arrays_chunks, *, n_rec: int, decimate: int, f_pwm: float, f_inj: float | None, metrics: dict,
              name: str) -> PlotData:
    """:class:`PlotData` from an iterable of chunks of ``n_rec`` samples.

    Parameters
    ----------
    arrays_chunks : iterable of dict
        Chunks, ``{name: array}``.
    n_rec : int
        Samples in all.
    decimate : int
        PWM periods per sample.
    f_pwm : float
        PWM frequency, Hz.
    f_inj : float or None
        Injection frequency, Hz.
    metrics : dict
        The run's metrics.
    name : str
        The scenario's name.

    Returns
    -------
    PlotData
        The figure's data.
    """
    k = plot_bin(n_rec, decimate, f_pwm, f_inj)
    red = Reducer(k, PLOT_SPEC)
    for a in arrays_chunks:
        red.add(a)
    spi = f_pwm / f_inj / decimate if f_inj else None
    return PlotData(red.finish(), metrics, name, f_pwm, decimate, k, spi)


@dataclass
class StreamedRun:
    """The end of a streamed run.

    Attributes
    ----------
    metrics : dict
        The run's metrics.
    fault_bits : int
        Fault bits at the end.
    samples : int
        Trace samples written.
    plot : PlotData or None
        The figure's data (when asked).
    """

    metrics: dict
    fault_bits: int
    samples: int
    plot: PlotData | None = None


def injection_hz(b: Built) -> float | None:
    """The injection frequency of the built scenario (None without injection).

    Parameters
    ----------
    b : Built
        The built scenario.

    Returns
    -------
    float or None
        Hz.
    """
    inj = b.scenario.spec.injection
    return float(inj.frequency) if inj.frequency and inj.amplitude else None


def simulate_streamed(b: Built, *, on_chunk: Callable | None = None, plot: bool = False, chunk: int = CHUNK,
                      metrics_cap: int = METRICS_CAP) -> StreamedRun:
    """Run the built scenario in chunks, with its metrics accumulated as the run goes.

    ``b`` is built with :func:`linsense.sim.build.build` and ``trace_in_memory=False``; the
    metrics are accumulated as the module's doc says, and with ``plot`` the figure's bins.

    Parameters
    ----------
    b : Built
        The built scenario.
    on_chunk : callable or None, optional
        ``on_chunk(arrays)`` gets each chunk's samples (every point signal, and the block statistics
        when ``decimate > 1``; views valid until it returns).
    plot : bool, optional
        Also the figure's bins.
    chunk : int, optional
        PWM periods per chunk.
    metrics_cap : int, optional
        Most samples the metrics are computed on (groups reduced beyond).

    Returns
    -------
    StreamedRun
        Metrics, fault bits, samples and the figure's data.

    Raises
    ------
    linsense.errors.InputError
        As :func:`linsense.sim.run.simulate` when the drive trips at t = 0.
    """
    s = b.scenario.spec
    dec = int(b.cfg.decimate)
    n_rec = -(-int(b.n_steps) // dec)
    k = max(1, -(-n_rec // int(metrics_cap)))
    spec = BLOCK_SPEC if (k > 1 or dec > 1) else POINT_SPEC
    pitch = b.motor.pole_pitch  # (the metrics' parameters: linsense.sim.run.run_metrics)
    keep = MetricSamples(moves=b.moves, convergence_s=s.metrics.convergence_s, settle_s=s.metrics.settle_s,
                         final_window_s=s.metrics.final_window_s,
                         settling_band_deg=s.metrics.bounds_deg(pitch)["settling_band_deg"], pole_pitch=pitch,
                         x_target=b.commands[-1][1] if b.commands else b.setup.x0)
    mred = Reducer(k, spec, sink=keep.add)
    f_inj = injection_hz(b)
    kp = plot_bin(n_rec, dec, s.inverter.f_pwm, f_inj)
    pred = Reducer(kp, PLOT_SPEC) if plot else None
    signals, blocks = None, (tuple(BLOCKS) if dec > 1 else ())
    if on_chunk is None and not plot:  # (metrics only: what they read, in smaller chunks)
        signals, blocks = METRICS_SIGNALS, (METRICS_BLOCKS if dec > 1 else ())
        chunk = min(int(chunk), METRICS_CHUNK)

    def take(arrays: dict[str, np.ndarray]) -> None:
        if on_chunk is not None:
            on_chunk(arrays)
        mred.add(arrays)
        if pred is not None:
            pred.add(arrays)

    chunk = min(int(chunk), int(b.n_steps))  # (a short run needs no buffers of a whole chunk)
    raw = run_closed_loop_chunks(b.cfg, b.drive.state, b.n_steps, b.commands, on_chunk=take, chunk=chunk,
                                 signals=signals, blocks=blocks)
    mred.finish(split_last=bool(raw.fault))
    m = run_metrics(b, raw, keep.arrays(spec))
    finish_metrics(b, raw, m, k * dec)
    m["samples"] = int(mred.n_in)
    pd_ = None
    if pred is not None:
        pd_ = PlotData(pred.finish(), m, b.scenario.name, s.inverter.f_pwm, dec, kp,
                       s.inverter.f_pwm / f_inj / dec if f_inj else None)
    return StreamedRun(m, int(raw.fault), int(mred.n_in), pd_)
