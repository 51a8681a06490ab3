"""One run in chunks: its metrics from every PWM period, its trace handed on chunk by chunk, never
whole in memory.

Every run of the simulator goes this way (:func:`simulate_streamed`; ``linsense simulate``,
:func:`linsense.sim.simulation.simulate` and :func:`~linsense.sim.simulation.metrics_only`; docs/simulator.md,
"Single runs in chunks"): the C loop runs in chunks of reused buffers
(:func:`linsense.sim.core.run_closed_loop_chunks`) at the full rate, one sample per PWM period,
whatever the run keeps. The metrics are computed from those samples (:class:`MetricSamples` keeps
only the ones a metric can depend on: memory does not grow with the duration), so that they do not
depend on what is stored (``--decimate 2048 --trace none`` said "stable" and a settling
time of 0 of a run that at the full rate was neither). What is stored, one sample every
``record.decimate`` periods with its block statistics, is made from the same samples
(:class:`Decimator`, bit for bit the C loop's own decimation) and handed to the trace writer and to
the figure's bins (:data:`PLOT_BINS` at most). Only an end window of more than
:data:`METRICS_CAP` periods is reduced to blocks of several periods, and the metrics say so
(``metrics_note``, ``block_s``).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from linsense._ctrl import ffi
from linsense.errors import InputError
from linsense.sim.build import Built
from linsense.sim.checks import sensor_triples
from linsense.sim.core import CHUNK, run_closed_loop_chunks
from linsense.sim.metrics import block_views, compute_metrics, finite_positions, transient_mask

#: PWM periods of the end window the metrics keep at most (beyond, consecutive periods are merged
#: into blocks, said in ``metrics_note``): 2**19, 33 s at 16 kHz; at most 13 MB
METRICS_CAP = 2**19
#: PWM periods per chunk of the C loop when it runs for the metrics alone or for a decimated trace
#: (every period recorded): 2**15, 1 MB of buffers for the metrics' signals, 5 MB for all
METRICS_CHUNK = 2**15
#: bins of the figure at most (each at least one injection period)
PLOT_BINS = 2000

#: (operation, sources in order of preference): the first source a chunk has is reduced
Spec = dict[str, tuple[str, tuple[str, ...]]]

#: the metrics of a run's every period (no merging): the samples themselves
POINT_SPEC: Spec = {"t": ("first", ("t",)), "x": ("last", ("x",)), "theta_err": ("first", ("theta_err",))}
#: the metrics from block envelopes (an end window beyond METRICS_CAP periods: merged samples); ``x``
#: is the last point value of each block (``final_position_mm`` is the last sample's), ``t`` the
#: block's start
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
            Output name to the batch's samples, in order (views are fine: what is kept is copied).
        """
        if not np.isfinite(part["t"]).all():
            self.compact = False
        # (a copy: a part may view the reused buffers of the C run)
        if self.tail is None:
            self.tail = {k: np.array(v) for k, v in part.items()}
        else:
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
    k_inj = max(1, math.ceil(f_pwm / f_inj / decimate - 1e-9)) if f_inj else 1
    red, sub = Reducer(k, PLOT_SPEC), Reducer(k_inj, _HF_SPEC)
    for a in arrays_chunks:
        red.add(a)
        sub.add(a)
    spi = f_pwm / f_inj / decimate if f_inj else None
    bins = red.finish()
    bins["i_hf"] = hf_envelope(sub.finish(), k_inj, k, len(bins["t"]))
    return PlotData(bins, metrics, name, f_pwm, decimate, k, spi)


#: the phase currents' envelope over each injection period (:func:`hf_envelope`)
_HF_SPEC: Spec = {"i_lo": PLOT_SPEC["i_lo"], "i_hi": PLOT_SPEC["i_hi"]}


def hf_envelope(sub: dict[str, np.ndarray], k_sub: int, k_bin: int, n_bins: int) -> np.ndarray:
    """The HF current's half peak-to-peak per figure bin, A, ``(n_bins, 3)``.

    From the envelope of each injection period (``sub``: ``i_lo``/``i_hi`` of groups of ``k_sub``
    samples), less the fundamental's change across it (a quarter of its middle's change over the two
    neighbouring periods), the mean over the periods of each bin (``k_bin`` samples). A bin's own
    envelope, over many injection periods, holds the fundamental's swing at speed: a drive whose
    injection had faded out showed 0.8-4 A of "HF current" there.

    Parameters
    ----------
    sub : dict of str to ndarray
        ``i_lo``, ``i_hi`` per injection period, A, ``(n, 3)``.
    k_sub, k_bin : int
        Samples per injection period and per bin.
    n_bins : int
        Bins.

    Returns
    -------
    ndarray
        A.
    """
    lo, hi = np.asarray(sub["i_lo"], dtype=float), np.asarray(sub["i_hi"], dtype=float)
    if lo.shape[0] == 0:
        return np.zeros((n_bins, 3))
    mid = 0.5 * (lo + hi)
    change = np.abs(np.gradient(mid, axis=0)) if mid.shape[0] > 1 else np.zeros_like(mid)
    hf = np.maximum(0.5 * (hi - lo) - 0.5 * change, 0.0)  # (gradient: half the neighbours' difference)
    which = np.minimum((np.arange(hf.shape[0]) * k_sub) // k_bin, n_bins - 1)
    count = np.maximum(np.bincount(which, minlength=n_bins), 1)
    sums = [np.bincount(which, weights=hf[:, j], minlength=n_bins) for j in range(3)]
    return np.stack(sums, axis=1) / count[:, None]


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


#: what the metrics read: the point signals of every period (linsense.sim.metrics)
METRICS_SIGNALS = ("t", "x", "theta_err")
#: the block statistics of a decimated record (the C loop's names, linsense.sim.core.BLOCKS)
METRICS_BLOCKS = ("x_min", "x_max", "x_mean", "err_min", "err_max", "err_mean")

#: what the average inverter model cannot be trusted for (docs/simulator.md, "Fidelity")
AVERAGE_NOTE = ("average inverter: the dead time's effect on the HF estimate is approximated (edge "
                "currents predicted linearly, with the PWM ripple's dead zone); its steady bias can "
                "differ from the switching model's by up to about 1 deg and it can show or miss limit "
                "cycles below about 0.2 mm: check bias and limit-cycle claims with fidelity = switching")

#: fault at t = 0 -> the scenario key most likely responsible
_FAULT_KEYS = {"undervoltage": "inverter.v_dc", "overvoltage": "inverter.v_dc",
               "overcurrent": "protection.i_max", "encoder": "sensors.encoder_counts_per_period",
               "config": "control"}

#: the block statistics of a decimated record: name -> (the signal of every period they reduce,
#: the reduction), as the C loop records them (ls_sim.c, ls_sim_record.c)
DECIMATED_BLOCKS = {"x_min": ("x", "min"), "x_max": ("x", "max"), "x_mean": ("x", "mean"),
                    "err_min": ("theta_err", "min"), "err_max": ("theta_err", "max"),
                    "err_mean": ("theta_err", "mean"),
                    "i_abc_min": ("i_abc", "min"), "i_abc_max": ("i_abc", "max")}


def full_rate(cfg):
    """A copy of the plant's ``ls_sim_cfg`` that records every PWM period (``decimate = 1``).

    Parameters
    ----------
    cfg : cffi ``ls_sim_cfg *``
        The plant's configuration (not changed).

    Returns
    -------
    cffi ``ls_sim_cfg *``
        The copy.
    """
    c = ffi.new("ls_sim_cfg *")
    ffi.memmove(c, cfg, ffi.sizeof("ls_sim_cfg"))
    c.decimate = 1
    return c


class Batcher:
    """Batches of ``size`` samples handed on, the last at :meth:`flush` (with the tripping state).

    The sizes of the C loop's own decimated chunks, so that a trace file written chunk by chunk
    (Parquet: one row group per batch) is the one the decimating C loop wrote: whole chunks of
    ``size`` samples, the last one shorter, or longer by the state that tripped a fault.

    Parameters
    ----------
    size : int
        Samples per batch, at least 1.
    sink : callable
        Gets each batch (``{name: array}``).
    """

    def __init__(self, size: int, sink: Callable) -> None:
        self.size, self.sink = max(1, int(size)), sink
        self.parts: list[dict[str, np.ndarray]] = []
        self.n = 0
        self.handed = 0

    def add(self, part: dict[str, np.ndarray]) -> None:
        """Take some samples (kept as they are: a Reducer's own arrays).

        Parameters
        ----------
        part : dict of str to ndarray
            Name to the samples.
        """
        self.parts.append(part)
        self.n += len(part["t"])
        while self.n > self.size + 1:  # (a whole batch, and more than a tripping state after it)
            self._cut()

    def flush(self, tripped: bool = False) -> None:
        """Hand on what is left.

        Parameters
        ----------
        tripped : bool, optional
            The last sample is the state that tripped a fault (it goes with the last batch).
        """
        if self.n > self.size and not tripped:
            self._cut()
        if self.n:
            self._hand({k: np.concatenate([p[k] for p in self.parts]) for k in self.parts[0]})
        self.parts, self.n = [], 0

    def _cut(self) -> None:
        whole = {k: np.concatenate([p[k] for p in self.parts]) for k in self.parts[0]}
        self._hand({k: v[:self.size] for k, v in whole.items()})
        rest = {k: v[self.size:] for k, v in whole.items()}
        self.parts, self.n = [rest], len(rest["t"])

    def _hand(self, batch: dict[str, np.ndarray]) -> None:
        self.handed += len(batch["t"])
        self.sink(batch)


class _Block:
    """A block of a decimated record in progress: its first period's values and the running block
    statistics of its periods so far (the C loop's: ``x < lo ? x : lo``, NaN where the first value
    is; the sum in period order), never the periods themselves."""

    def __init__(self, rows: dict[str, np.ndarray]) -> None:
        self.first = {k: np.array(v[:1]) for k, v in rows.items()}
        self.n = 0
        self.acc: dict[str, np.ndarray] = {}
        self.add(rows)

    def add(self, rows: dict[str, np.ndarray]) -> None:
        m = len(rows["t"])
        if not m:
            return
        for name, (src, op) in DECIMATED_BLOCKS.items():
            v = rows[src]
            if op == "mean":  # (the sum in period order from the first value, as the C loop adds)
                seq = v if name not in self.acc else np.concatenate([self.acc[name], v])
                self.acc[name] = np.cumsum(seq, axis=0)[-1:]
                continue
            fn = np.fmin if op == "min" else np.fmax
            part = fn.reduce(v, axis=0, keepdims=True)
            self.acc[name] = part if name not in self.acc else fn(self.acc[name], part)
        self.n += m

    def close(self) -> dict[str, np.ndarray]:
        out = dict(self.first)
        for name, (src, op) in DECIMATED_BLOCKS.items():
            v = self.acc[name]
            if op == "mean":
                v = v if self.n == 1 else v / float(self.n)
            out[name] = np.where(np.isnan(self.first[src]), self.first[src], v)  # (C: a NaN first stays)
        return out


class Decimator:
    """The record of a run with ``record.decimate = dec`` made from its samples of every period, bit
    for bit the C loop's own: every ``dec``-th period's point signals and the block statistics of
    the ``dec`` periods it opens (:data:`DECIMATED_BLOCKS`), the state that tripped a fault a block
    of its own (the one sample whose duties are NaN, the last of the run). Holds one block's
    statistics at most, whatever ``dec``.

    Parameters
    ----------
    dec : int
        PWM periods per stored sample.
    sink : callable
        Gets the stored samples, in batches (``{name: array}``).
    """

    def __init__(self, dec: int, sink: Callable) -> None:
        self.dec, self.sink = int(dec), sink
        self.block: _Block | None = None
        self.held: dict[str, np.ndarray] | None = None  # (the last sample so far: it may be the trip)

    def _whole(self, a: dict[str, np.ndarray], m: int) -> dict[str, np.ndarray]:
        """``m`` whole blocks of ``a`` (``m * dec`` periods), reduced at once."""
        d = self.dec
        out = {k: np.array(v[:m * d:d]) for k, v in a.items()}
        for name, (src, op) in DECIMATED_BLOCKS.items():
            g = a[src][:m * d].reshape(m, d, *a[src].shape[1:])
            if op == "mean":
                total = np.cumsum(g, axis=1)[:, -1]
                v = total if d == 1 else total / float(d)
            else:
                v = (np.fmin if op == "min" else np.fmax).reduce(g, axis=1)
            out[name] = np.where(np.isnan(g[:, 0]), g[:, 0], v)  # (C: a NaN first stays)
        return out

    def _feed(self, a: dict[str, np.ndarray]) -> None:
        n, i = len(a["t"]), 0
        if self.block is not None:
            i = min(self.dec - self.block.n, n)
            self.block.add({k: v[:i] for k, v in a.items()})
            if self.block.n == self.dec:
                self.sink(self.block.close())
                self.block = None
        m = (n - i) // self.dec
        if m:
            self.sink(self._whole({k: v[i:] for k, v in a.items()}, m))
            i += m * self.dec
        if i < n:
            self.block = _Block({k: v[i:] for k, v in a.items()})

    def add(self, arrays: dict[str, np.ndarray]) -> None:
        """Take a chunk of samples of every period (views are fine).

        Parameters
        ----------
        arrays : dict of str to ndarray
            Signal name to the chunk's samples.
        """
        if not len(arrays["t"]):
            return
        if self.held is not None:
            self._feed(self.held)
        self._feed({k: v[:-1] for k, v in arrays.items()})
        self.held = {k: np.array(v[-1:]) for k, v in arrays.items()}

    def finish(self) -> bool:
        """Hand on the rest: the last block as it is, and the state that tripped on its own.

        Returns
        -------
        bool
            Whether the run ended on a tripping state (its last sample).
        """
        held, self.held = self.held, None
        tripped = held is not None and bool(np.isnan(held["duty"][-1, 0]))  # (its duties are NaN)
        if held is not None and not tripped:
            self._feed(held)
        if self.block is not None:
            self.sink(self.block.close())
            self.block = None
        if tripped:
            self.sink(_Block(held).close())
        return tripped


def metrics_block(spec, cap: int = METRICS_CAP) -> int:
    """PWM periods per sample the metrics are computed on: 1 (every period), unless the end window
    holds more than ``cap`` periods (then blocks of several, said in the metrics' ``metrics_note``).

    Parameters
    ----------
    spec : ScenarioFile
        The scenario.
    cap : int, optional
        Periods of the end window the metrics keep at most.

    Returns
    -------
    int
        Periods per block.
    """
    window = min(spec.metrics.final_window_s, spec.scenario.duration) * spec.inverter.f_pwm
    return max(1, math.ceil(window / max(1, int(cap))))


def run_metrics(b: Built, raw, arrays: dict | None = None) -> dict:
    """The metrics of a run of a built scenario.

    The bounds are in electrical degrees of the plant motor's pole pitch.

    Parameters
    ----------
    b : Built
        The built scenario.
    raw : RawRun
        Its run.
    arrays : dict or None, optional
        The samples (default the run's own; with block statistics among them, from those).

    Returns
    -------
    dict
        The metrics (:func:`linsense.sim.metrics.compute_metrics`).
    """
    s = b.scenario.spec
    x_target = b.commands[-1][1] if b.commands else b.setup.x0
    observer_active = s.control.mode != "sensored" or s.control.inject_sensored
    pitch = b.motor.pole_pitch  # (the plant's: the controller's model has the same)
    ld = s.load
    return compute_metrics(
        raw.arrays if arrays is None else arrays, fault=raw.fault, steps_done=raw.steps_done,
        f_pwm=s.inverter.f_pwm, moves=b.moves, wall_s=raw.wall_s,  # the C run alone
        observer_active=observer_active, convergence_s=s.metrics.convergence_s,
        settle_s=s.metrics.settle_s, pole_pitch=pitch, **s.metrics.bounds_deg(pitch),
        final_window_s=s.metrics.final_window_s, x_target=x_target, x_start=b.setup.x0,
        load_step_s=ld.time if ld.type == "step" and ld.time > 0.0 else None,
    )


def _load_at_zero(b, first: str) -> None:
    """A travel trip at the first step under a load beyond anything the drive makes (``K_f i_max``):
    the load is named (it said only "the configuration cannot run")."""
    s = b.scenario.spec
    ld = s.load
    if first != "travel" or ld.type not in ("constant", "step", "incline"):
        return
    key, f = "load.force", ld.force
    if ld.type == "step" and ld.time <= 0.0:
        key, f = "load.force_after", ld.force_after  # (the load from t = 0)
    f_max = b.motor.force_constant * float(s.controller.i_max)
    if abs(f) > f_max:
        raise InputError(b.scenario.source, key, f"{f:g} N against the {f_max:.4g} N the drive makes at "
                         f"controller.i_max (K_f i_max): the mover leaves the travel in the first period")


def finish_metrics(b: Built, raw, m: dict, block: int) -> None:
    """Complete the metrics of a run in place.

    Refuses a drive that trips at t = 0; says a calibration run is one (verdict ``calibration``, not
    judged as a hold); adds the fidelity note, names and ``block_s``.

    Parameters
    ----------
    b : Built
        The built scenario.
    raw : RawRun
        Its run.
    m : dict
        The metrics, completed in place.
    block : int
        PWM periods per sample the metrics were computed on, the resolution of their times.

    Raises
    ------
    linsense.errors.InputError
        The drive trips at its very first step (naming the key at fault).
    """
    sc = b.scenario
    s = sc.spec
    if raw.fault and raw.steps_done <= 1:
        # a trip at the very first step is the configuration's doing, not the closed loop's
        first = m["fault"].split("+")[0]  # the first fault named (several can trip together)
        sens = s.sensors
        offset = max(abs(o) for o in sensor_triples(sens)[1])
        on_sensor = first == "overcurrent" and (sens.current_noise or offset)
        if on_sensor and "protection.i_max" not in b.user_keys:
            # (the file gives the sensor, not the trip: name what it gives)
            key = "sensors.current_noise" if sens.current_noise else "sensors.current_offset"
            raise InputError(sc.source, key, f"the drive trips at t = 0 (overcurrent) on the current "
                             f"sensor: {sens.current_noise:g} A rms of noise and {offset:g} A of offset "
                             f"against the over-current trip protection.i_max = {s.protection.i_max:.3g} A "
                             "(designed)")
        _load_at_zero(b, first)
        raise InputError(sc.source, _FAULT_KEYS.get(first, ""),
                         f"the drive trips at t = 0 ({m['fault']}): the configuration cannot run")
    if s.control.mode == "calibration" and not raw.fault:
        # (the drive moves itself through its points: a hold's verdict would judge a calibration)
        done = "done" if raw.steps_done < b.n_steps else "not done by the run's end"
        m.update(stable=False, accurate=False, verdict="calibration",
                 unstable_reason=f"a calibration run (control.mode = \"calibration\", {done}): the drive "
                 "moves itself through its points, which the metrics of a hold do not judge; linsense "
                 "calibrate does")
    if s.inverter.fidelity == "average" and s.inverter.dead_time > 0:
        m["fidelity_note"] = AVERAGE_NOTE
    m["scenario"] = sc.name
    m["mode"] = s.control.mode
    m["fidelity"] = s.inverter.fidelity
    m["motor"] = b.motor.name
    m["block_s"] = round(float(block / s.inverter.f_pwm), 9)


def simulate_streamed(b: Built, *, on_chunk: Callable | None = None, plot: bool = False, chunk: int = CHUNK,
                      metrics_cap: int = METRICS_CAP, decimate: int | None = None,
                      blocks: bool | None = None) -> StreamedRun:
    """Run the built scenario in chunks: its metrics from every period, its record handed on.

    ``b`` is built with :func:`linsense.sim.build.build`. The C loop records every PWM period; the
    metrics are accumulated from those samples as the module's doc says, whatever is stored; the
    stored record (one sample every ``decimate`` periods with its block statistics, made from the
    same samples as the decimating C loop makes it) goes to ``on_chunk`` and, with ``plot``, into
    the figure's bins.

    Parameters
    ----------
    b : Built
        The built scenario.
    on_chunk : callable or None, optional
        ``on_chunk(arrays)`` gets each chunk of the stored record (every point signal, and the block
        statistics when ``decimate > 1``; views valid until it returns), in the chunks the C loop
        records it in with ``chunk``.
    plot : bool, optional
        Also the figure's bins.
    chunk : int, optional
        PWM periods per chunk.
    metrics_cap : int, optional
        Most periods of the end window the metrics keep (blocks beyond, :func:`metrics_block`).
    decimate : int or None, optional
        PWM periods per stored sample (default the scenario's ``record.decimate``).
    blocks : bool or None, optional
        Store the block statistics (default: when ``decimate > 1``).

    Returns
    -------
    StreamedRun
        Metrics, fault bits, samples stored and the figure's data.

    Raises
    ------
    linsense.errors.InputError
        As :func:`linsense.sim.simulation.simulate` when the drive trips at t = 0.
    """
    s = b.scenario.spec
    dec = int(b.setup.decimate if decimate is None else decimate)
    k = metrics_block(s, metrics_cap)
    spec = BLOCK_SPEC if k > 1 else POINT_SPEC
    keep = _metric_samples(b)
    mred = Reducer(k, spec, sink=keep.add)
    n_in = [0]

    def read(arrays: dict[str, np.ndarray]) -> None:  # (every period: the samples themselves, no copy)
        n_in[0] += len(arrays["t"])
        keep.add({name: arrays[name] for name in POINT_SPEC})
    f_inj = injection_hz(b)
    kp = plot_bin(-(-int(b.n_steps) // dec), dec, s.inverter.f_pwm, f_inj)
    pred = Reducer(kp, PLOT_SPEC) if plot else None
    chunk = min(int(chunk), int(b.n_steps))  # (a short run needs no buffers of a whole chunk)
    route = _Route(_store_to(on_chunk, pred), dec, chunk, blocks)
    metrics_add = mred.add if k > 1 else read

    def take(arrays: dict[str, np.ndarray]) -> None:
        metrics_add(arrays)
        route.add(arrays)

    raw = run_closed_loop_chunks(full_rate(b.cfg), b.drive.state, b.n_steps, b.commands, on_chunk=take,
                                 chunk=route.c_chunk, signals=route.signals)
    n_read = int(mred.n_in) if k > 1 else n_in[0]
    stored = route.finish(n_read)
    mred.finish(split_last=bool(raw.fault))
    m = run_metrics(b, raw, keep.arrays(spec))
    finish_metrics(b, raw, m, k)
    m["samples"] = n_read
    if k > 1:
        m["metrics_note"] = _block_note(s.metrics.final_window_s, metrics_cap, k, m["block_s"])
    pd_ = None
    if pred is not None:
        pd_ = PlotData(pred.finish(), m, b.scenario.name, s.inverter.f_pwm, dec, kp,
                       s.inverter.f_pwm / f_inj / dec if f_inj else None)
    return StreamedRun(m, int(raw.fault), stored, pd_)


def _block_note(window_s: float, cap: int, k: int, block_s: float) -> str:
    """The metrics' note when they are computed on blocks of ``k`` periods (``block_s`` s): the end
    window (``window_s`` s) holds more than ``cap`` PWM periods."""
    return (f"the end window (metrics.final_window_s = {window_s:g} s) holds more than "
            f"{int(cap):,} PWM periods: the metrics are computed on blocks of {k} "
            f"periods ({block_s:g} s, their min, max and mean), their times to one "
            "block")


def _metric_samples(b: Built) -> MetricSamples:
    """The metrics' samples of the built scenario, with the parameters :func:`run_metrics` takes."""
    s, pitch = b.scenario.spec, b.motor.pole_pitch
    return MetricSamples(moves=b.moves, convergence_s=s.metrics.convergence_s, settle_s=s.metrics.settle_s,
                         final_window_s=s.metrics.final_window_s,
                         settling_band_deg=s.metrics.bounds_deg(pitch)["settling_band_deg"], pole_pitch=pitch,
                         x_target=b.commands[-1][1] if b.commands else b.setup.x0)


def _store_to(on_chunk: Callable | None, pred: Reducer | None) -> Callable | None:
    """Where a chunk of the stored record goes: ``on_chunk``, then the figure's bins (None: nowhere)."""
    if on_chunk is None and pred is None:
        return None

    def store(arrays: dict[str, np.ndarray]) -> None:
        if on_chunk is not None:
            on_chunk(arrays)
        if pred is not None:
            pred.add(arrays)
    return store


class _Route:
    """The stored record's path from the C loop's chunks to ``store``.

    Three paths: none (``store`` None, metrics only: the C loop records the signals they read, in
    smaller chunks); as recorded (every period stored, no block statistics: the chunks themselves);
    or made here (every period from C, one sample every ``dec`` with its block statistics, handed on
    in the C loop's decimated chunks).
    """

    def __init__(self, store: Callable | None, dec: int, chunk: int, blocks: bool | None) -> None:
        self.store, self.signals = store, None
        self.sample: Decimator | None = None
        self.batches: Batcher | None = None
        if store is None:
            self.signals, self.c_chunk = METRICS_SIGNALS, min(chunk, METRICS_CHUNK)
        elif dec == 1 and not blocks:
            self.c_chunk = chunk
        else:
            self.batches = Batcher(max(1, -(-chunk // dec)), store)
            self.sample = Decimator(dec, self.batches.add)
            self.c_chunk = min(chunk, METRICS_CHUNK)

    def add(self, arrays: dict[str, np.ndarray]) -> None:
        """Hand on a chunk of the C loop's record."""
        if self.sample is not None:
            self.sample.add(arrays)
        elif self.store is not None:
            self.store(arrays)

    def finish(self, n_read: int) -> int:
        """Hand on what is left; the samples stored (``n_read``, every period read, when not made here)."""
        if self.sample is None:
            return n_read
        self.batches.flush(self.sample.finish())
        return self.batches.handed
