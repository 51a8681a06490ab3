"""`linsense simulate` streamed in chunks: its defaults (a Parquet trace, no
plot, no matplotlib), --decimate, the chunked trace equal to the in-memory one, metrics while the
run goes, the figure's envelopes that cannot alias, Result.to_dataframe, figures without pyplot."""

from __future__ import annotations

import io
import json
import subprocess
import sys

import numpy as np
import pandas as pd
import pytest

import linsense
from linsense.scenario.load import load_scenario, scenario_from_dict
from linsense.sim.build import build
from linsense.sim.stream import Reducer, simulate_streamed
from linsense.sim.trace import COLUMNS, TraceWriter, trace_csv

WALL = ("wall_s", "realtime_factor")


def sc(duration=0.1, decimate=1, step=1.0, **sections):
    d = {"motor": "ecce2010", "scenario": {"name": "s", "duration": duration},
         "control": {"mode": "sensorless_lut"},
         "reference": {"type": "step", "position_mm": step, "at": 0.02},
         "record": {"decimate": decimate}}
    for k, v in sections.items():
        d.setdefault(k, {}).update(v)
    return scenario_from_dict(d)


def _toml(path, duration=0.1, extra=""):
    # (the step at 0.02 s: the default 0.1 s is the run's end, where a step never acts)
    path.write_text(f'motor = "ecce2010"\n[scenario]\nname = "t"\nduration = {duration}\n'
                    f'[reference]\nposition_mm = 1.0\nat = 0.02\n{extra}')
    return path


def test_defaults_parquet_no_plot_no_matplotlib(tmp_path):
    """The default outputs, in a fresh process: trace.parquet, no sim.png, no CSV; matplotlib (and
    pandas, scipy, dask) never imported."""
    p = _toml(tmp_path / "s.toml")
    out = tmp_path / "out"
    code = ("import sys\nfrom linsense.cli import main\n"
            "try:\n    main(['simulate', sys.argv[1], '--out', sys.argv[2]])\nexcept SystemExit as e:\n"
            "    rc = e.code\n"
            "heavy = [m for m in ('matplotlib', 'pandas', 'scipy', 'dask') if m in sys.modules]\n"
            "print('RESULT', rc, ','.join(heavy) or '-')\n")
    r = subprocess.run([sys.executable, "-c", code, str(p), str(out)], capture_output=True, text=True,
                       timeout=120)
    line = [ln for ln in r.stdout.splitlines() if ln.startswith("RESULT")][0].split()
    assert line[1] == "0", r.stderr
    assert line[2] == "-", f"imported on the simulate path: {line[2]}"
    files = sorted(f.name for f in out.iterdir())
    assert files == [".linsense-set.json", "metrics.json", "timing.json", "trace.parquet"]
    tr = pd.read_parquet(out / "trace.parquet")
    assert list(tr.columns) == [c for c, _, _ in COLUMNS] and len(tr) == 1600


def test_no_module_switches_the_backend():
    code = ("import matplotlib\nmatplotlib.use('pdf')\n"
            "import linsense.report.figures, linsense.report.identify_figures, linsense.report.sim_figures\n"
            "import linsense.report.sweep_figures\nprint(matplotlib.get_backend())\n")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert r.stdout.strip() == "pdf", r.stderr


@pytest.mark.parametrize("bad", ["0", "-3", "1000001", "2.5", "many"])
def test_decimate_validated(run_cli, tmp_path, bad):
    p = _toml(tmp_path / "s.toml")
    r = run_cli("simulate", p, "--out", tmp_path / "out", "--decimate", bad)
    r.refused("--decimate")
    assert not (tmp_path / "out").exists()


def test_decimate_and_plot(run_cli, tmp_path):
    p = _toml(tmp_path / "s.toml")
    out = tmp_path / "out"
    r = run_cli("simulate", p, "--out", out, "--decimate", 4, "--plot", "--trace", "csv")
    assert r.code == 0, r.err
    assert (out / "sim.png").read_bytes()[:4] == b"\x89PNG" and not (out / "trace.parquet").exists()
    ref = linsense.simulate(load_scenario(p).replace(record={"decimate": 4}))
    assert (out / "trace.csv").read_text() == trace_csv(ref)
    m = json.loads((out / "metrics.json").read_text())
    # (the metrics read every period whatever the record keeps)
    assert m["block_s"] == 1 / 16000 and m["samples"] == 1600 and ref.t.size == 400
    assert m == {k: v for k, v in ref.metrics.items() if k not in WALL}


def test_mat_refused_beyond_its_limit(run_cli, tmp_path):
    p = _toml(tmp_path / "s.toml", duration=100.0)
    r = run_cli("simulate", p, "--out", tmp_path / "out", "--mat")
    r.refused("--mat", "1,000,000", "--decimate 2")
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("decimate", [1, 3])
def test_chunks_equal_the_in_memory_run(decimate):
    """The trace written in many chunks (Parquet and CSV) has the rows of one in-memory run, and the
    metrics accumulated while it goes are the in-memory run's."""
    s = sc(0.15, decimate)
    ref = linsense.simulate(s)
    bufs = {"parquet": io.BytesIO(), "csv": io.BytesIO()}
    writers = {fmt: TraceWriter(f, fmt) for fmt, f in bufs.items()}

    def on_chunk(arrays):
        for w in writers.values():
            w.write(arrays)

    sr = simulate_streamed(build(s, trace_in_memory=False), on_chunk=on_chunk, chunk=1000)
    for w in writers.values():
        w.close()
    assert writers["csv"].rows == ref.t.size and sr.samples == ref.t.size
    pd.testing.assert_frame_equal(pd.read_parquet(io.BytesIO(bufs["parquet"].getvalue())), ref.to_dataframe())
    assert bufs["csv"].getvalue().decode() == trace_csv(ref)
    assert {k: v for k, v in sr.metrics.items() if k not in WALL} == \
           {k: v for k, v in ref.metrics.items() if k not in WALL}


def test_merged_metrics_of_a_long_run():
    """Beyond the cap, samples are merged into blocks: the peaks and the final position stay those of
    every sample; times get the resolution of a block."""
    s = sc(0.3)
    ref = linsense.simulate(s).metrics
    m = simulate_streamed(build(s, trace_in_memory=False), chunk=777, metrics_cap=500).metrics
    assert m["block_s"] == 10 / 16000 and m["samples"] == 4800
    for k in ("stable", "max_abs_err_deg", "final_position_mm", "fault"):
        assert m[k] == ref[k], k
    assert m["bias_deg"] == pytest.approx(ref["bias_deg"], abs=0.02)


def test_reducer_groups_across_chunks():
    x = np.arange(23.0)
    r = Reducer(5, {"lo": ("min", ("x",)), "hi": ("max", ("x",)), "m": ("mean", ("x",)),
                    "first": ("first", ("x",)), "last": ("last", ("x",))})
    buf = np.empty(4)
    for i in range(0, 23, 4):  # views into one reused buffer, as the C run hands them
        part = x[i:i + 4]
        buf[:part.size] = part
        r.add({"x": buf[:part.size]})
    out = r.finish(split_last=True)
    np.testing.assert_array_equal(out["lo"], [0, 5, 10, 15, 20, 22])
    np.testing.assert_array_equal(out["hi"], [4, 9, 14, 19, 21, 22])
    np.testing.assert_array_equal(out["first"], [0, 5, 10, 15, 20, 22])
    np.testing.assert_array_equal(out["last"], [4, 9, 14, 19, 21, 22])
    np.testing.assert_array_equal(out["m"], [2, 7, 12, 17, 20.5, 22])


def test_plotted_hf_envelope_does_not_alias():
    """Recorded every 16 periods at 16 kHz, the 1 kHz injection is sampled at exactly its period: the
    point samples hardly move, but the figure's HF envelope (from every period) is the one of the
    run recorded every period."""
    from linsense.report.sim_figures import result_plot_data

    every = result_plot_data(linsense.simulate(sc(0.2, 1, step=0.0)))
    dec = simulate_streamed(build(sc(0.2, 16, step=0.0), trace_in_memory=False), plot=True, chunk=1600)
    amp = {k: np.median(0.5 * (d.bins["i_hi"] - d.bins["i_lo"])[10:], axis=0)
           for k, d in (("every", every), ("dec", dec.plot))}
    assert np.all(amp["every"] > 0.3)  # the HF current, about 0.4-0.5 A in each phase
    np.testing.assert_allclose(amp["dec"], amp["every"], rtol=0.02)
    # what the point samples alone would have drawn: an aliased, nearly flat current
    pts = linsense.simulate(sc(0.2, 16, step=0.0)).i_abc[50:]
    assert np.all(0.5 * (pts.max(axis=0) - pts.min(axis=0)) < 0.2 * amp["every"])
    # the fundamental (middle of the envelope) agrees as well
    mid = {k: np.median(0.5 * (d.bins["i_hi"] + d.bins["i_lo"])[10:], axis=0)
           for k, d in (("every", every), ("dec", dec.plot))}
    np.testing.assert_allclose(mid["dec"], mid["every"], atol=0.02)


def test_to_dataframe_and_figure():
    from matplotlib.figure import Figure

    from linsense.report.sim_figures import sim_figure

    r = linsense.simulate(sc(0.05, 4))
    df = r.to_dataframe()
    assert list(df.columns) == [c for c, _, _ in COLUMNS] and len(df) == r.t.size == 200
    np.testing.assert_array_equal(df["i_b_A"], r.i_abc[:, 1])
    np.testing.assert_array_equal(df["t_s"], r.t)
    full = r.to_dataframe(blocks=True)
    assert {"x_min_m", "err_mean_rad", "i_a_min_A", "i_c_max_A"} <= set(full.columns)
    np.testing.assert_array_equal(full["i_c_max_A"], r.i_abc_max[:, 2])
    assert isinstance(sim_figure(r), Figure)


def test_the_hf_panel_is_per_injection_period_without_the_fundamental():
    """A bin of many injection periods holds the fundamental's swing at speed: the figure's panel is
    the envelope of each injection period less the fundamental's change across it (a drive whose
    injection had faded out showed 0.8-4 A of "HF current" there): a 2 A, 80 Hz fundamental alone
    reads under 0.05 A (the bins' own envelope: 2 A); a 1 A, 1 kHz carrier on a 20 Hz one 0.84-0.96 A.
    (Where the fundamental's slope rivals the carrier's, min and max cannot tell them apart: 0.4 A
    on the 80 Hz one reads 0.14-0.19 A; docs/simulator.md.)"""
    from linsense.sim.stream import Reducer, hf_envelope

    f_pwm, f_inj, k_bin = 16000.0, 1000.0, 16 * 15  # (bins of 15 injection periods)
    t = np.arange(int(0.3 * f_pwm)) / f_pwm
    for f_e, carrier, lo_hi in ((80.0, 0.0, (0.0, 0.05)), (20.0, 1.0, (0.8, 1.05))):
        hf = carrier * np.sin(2 * np.pi * f_inj * t)
        i = np.stack([2.0 * np.sin(2 * np.pi * f_e * t - k * 2.0944) + hf for k in range(3)], axis=1)
        sub = Reducer(16, {"i_lo": ("min", ("i_abc",)), "i_hi": ("max", ("i_abc",))})
        sub.add({"i_abc": i})
        got = hf_envelope(sub.finish(), 16, k_bin, len(t) // k_bin)
        assert lo_hi[0] <= got[1:-1].min() and got[1:-1].max() <= lo_hi[1], (carrier, got.min(), got.max())
    whole = 0.5 * (i.reshape(-1, k_bin, 3).max(axis=1) - i.reshape(-1, k_bin, 3).min(axis=1))
    assert whole.max() > 1.5  # (the bin's own envelope: the fundamental's swing)
