"""Block statistics, runs in chunks and the metrics-only mode (memory per run does not
grow with the duration; decimated records cannot alias). docs/simulator.md, "Block statistics"."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from linsense import ctrl
from linsense.errors import InputError
from linsense.model.motor import load_motor
from linsense.scenario.load import as_scenario
from linsense.sim import core, simulation
from linsense.sim.build import build

EXAMPLES = Path(__file__).resolve().parents[1] / "src/linsense/examples" / "scenarios"


def _built(name_or_dict, **sections):
    sc = as_scenario(EXAMPLES / name_or_dict if isinstance(name_or_dict, str) else name_or_dict)
    return build(sc.replace(**sections) if sections else sc)


def _hold(duration: float, **extra) -> dict:
    d = {"motor": "ecce2010", "scenario": {"name": "hold", "duration": duration, "seed": 1},
         "control": {"mode": "sensorless_lut"}, "reference": {"type": "hold"}}
    d.update(extra)
    return d


def _blocks(a: np.ndarray, dec: int, fn) -> np.ndarray:
    """fn over consecutive blocks of ``dec`` samples (the last one may be short)."""
    return np.array([fn(a[j:j + dec], axis=0) for j in range(0, a.shape[0], dec)])


def test_blocks_are_min_max_mean_of_every_period():
    ref_b = _built("step3_lut.toml", scenario={"duration": 0.3})
    ref = core.run_closed_loop(ref_b.cfg, ref_b.drive.state, ref_b.n_steps, ref_b.commands)
    dec = 16
    b = _built("step3_lut.toml", scenario={"duration": 0.3}, record={"decimate": dec})
    r = core.run_closed_loop(b.cfg, b.drive.state, b.n_steps, b.commands, blocks=tuple(core.BLOCKS))
    a, p = r.arrays, ref.arrays
    assert a["t"].size == -(-ref.steps_done // dec)
    np.testing.assert_array_equal(a["x"], p["x"][::dec])
    for name, src in (("x", "x"), ("err", "theta_err"), ("i_abc", "i_abc")):
        np.testing.assert_array_equal(a[f"{name}_min"], _blocks(p[src], dec, np.min))
        np.testing.assert_array_equal(a[f"{name}_max"], _blocks(p[src], dec, np.max))
        if name != "i_abc":
            np.testing.assert_allclose(a[f"{name}_mean"], _blocks(p[src], dec, np.mean), rtol=0, atol=1e-15)


def test_decimate_1_blocks_are_the_samples():
    b = _built("step6_nolut.toml", scenario={"duration": 0.2})
    r = core.run_closed_loop(b.cfg, b.drive.state, b.n_steps, b.commands, blocks=tuple(core.BLOCKS))
    a = r.arrays
    for k in ("x_min", "x_max", "x_mean"):
        assert a[k].tobytes() == a["x"].tobytes()
    for k in ("err_min", "err_max", "err_mean"):
        assert a[k].tobytes() == a["theta_err"].tobytes()
    assert a["i_abc_min"].tobytes() == a["i_abc"].tobytes() == a["i_abc_max"].tobytes()


@pytest.mark.parametrize("name", sorted(p.name for p in EXAMPLES.glob("*.toml")))
def test_decimate_1_metrics_unchanged_by_blocks(name):
    """With decimate = 1 every metric from the block statistics is exactly the point one."""
    b = _built(name)
    raw = core.run_closed_loop(b.cfg, b.drive.state, b.n_steps, b.commands, blocks=tuple(core.BLOCKS))
    points = {k: v for k, v in raw.arrays.items() if k not in core.BLOCKS}
    assert simulation.run_metrics(b, raw) == simulation.run_metrics(b, raw, points)


def _collector():
    chunks = []
    return chunks, lambda a: chunks.append({k: v.copy() for k, v in a.items()})


def _concat(chunks):
    return {k: np.concatenate([c[k] for c in chunks]) for k in chunks[0]}


@pytest.mark.parametrize("fidelity,dec", [("average", 1), ("switching", 8)])
def test_chunks_are_bit_identical(fidelity, dec):
    # (1 s: the trajectory's second move starts at 0.9 s; a move after the end is refused)
    sec = dict(scenario={"duration": 1.0}, inverter={"fidelity": fidelity}, record={"decimate": dec})
    b1 = _built("fig13_trajectory.toml", **sec)
    blocks = tuple(core.BLOCKS) if dec > 1 else ()
    one = core.run_closed_loop(b1.cfg, b1.drive.state, b1.n_steps, b1.commands, blocks=blocks)
    b2 = _built("fig13_trajectory.toml", **sec)
    chunks, keep = _collector()
    end = core.run_closed_loop_chunks(b2.cfg, b2.drive.state, b2.n_steps, b2.commands, chunk=997,
                                      blocks=blocks, on_chunk=keep)
    assert len(chunks) > 3
    got = _concat(chunks)
    assert set(got) == set(one.arrays)
    for k, v in one.arrays.items():
        assert got[k].tobytes() == v.tobytes(), k
    for k in ("steps_done", "fault", "x_end", "v_end"):
        assert getattr(end, k) == getattr(one, k), k


def test_chunks_end_at_a_fault():
    """A travel fault in the middle of a chunk: the same samples, the tripping state last."""
    motor = load_motor("ecce2010")

    def go(chunked):
        drive = ctrl.Drive(ctrl.drive_default_cfg())
        drive.set_mode("sensored")
        cfg = core.sim_cfg(motor, core.PlantSetup(x0=0.010, x_min=0.0099, x_max=0.0101, decimate=4))
        cmds = [(0.0, 0.013, False)]
        blocks = tuple(core.BLOCKS)
        if not chunked:
            return core.run_closed_loop(cfg, drive.state, 8000, cmds, blocks=blocks)
        chunks, keep = _collector()
        end = core.run_closed_loop_chunks(cfg, drive.state, 8000, cmds, chunk=40, blocks=blocks,
                                          on_chunk=keep)
        end.arrays = _concat(chunks)
        return end
    one, ch = go(False), go(True)
    assert one.fault & core.SIM_FAULT_TRAVEL and one.steps_done < 8000
    assert (ch.steps_done, ch.fault) == (one.steps_done, one.fault)
    for k, v in one.arrays.items():
        assert ch.arrays[k].tobytes() == v.tobytes(), k
    a = one.arrays
    assert a["x_min"][-1] == a["x_max"][-1] == a["x"][-1] > 0.0101  # the tripping state: its own block


@pytest.mark.parametrize("extra, fault", [
    ({}, ""), ({"travel": {"max_mm": 1.0}}, "travel"),  # the simulator's trip: a block of its own
    ({"controller": {"kp_x": 5000.0}, "sensors": {"current_noise": 0.05}}, "overspeed"),  # the drive's
])
@pytest.mark.parametrize("dec", [1, 3, 16, 4801])
def test_the_record_is_the_decimating_c_loops(extra, fault, dec):
    """The record kept, made from every period in Python (the C loop records every period
    for the metrics), is bit for bit the C loop's own decimation: point samples, block statistics,
    the tripping state's block, and the chunks a trace file is written in."""
    d = {"motor": "ecce2010", "scenario": {"name": "r", "duration": 0.3, "seed": 1},
         "reference": {"type": "step", "position_mm": 3.0, "at": 0.05}, "record": {"decimate": dec}, **extra}
    sc = as_scenario(d)
    b = build(sc)
    blocks = tuple(core.BLOCKS) if dec > 1 else ()
    c_chunks, keep = _collector()
    core.run_closed_loop_chunks(b.cfg, b.drive.state, b.n_steps, b.commands, chunk=1000, blocks=blocks,
                                on_chunk=keep)
    from linsense.sim.stream import simulate_streamed

    chunks, keep = _collector()
    sr = simulate_streamed(build(sc, trace_in_memory=False), on_chunk=keep, chunk=1000)
    assert sr.metrics["fault"] == (fault or "none")
    assert [len(c["t"]) for c in chunks] == [len(c["t"]) for c in c_chunks]
    got, want = _concat(chunks), _concat(c_chunks)
    for k, v in want.items():
        assert got[k].tobytes() == v.tobytes(), k
    r = simulation.simulate(sc)
    for k, v in want.items():
        assert getattr(r, k).tobytes() == v.tobytes(), k


def test_no_aliasing_of_the_hf_current():
    """The 1 kHz injection sampled every 16 periods at 16 kHz (exactly its period): the point samples
    see an almost constant current, the block min/max its whole envelope."""
    b1 = build(as_scenario(_hold(0.3)))
    ref = core.run_closed_loop(b1.cfg, b1.drive.state, b1.n_steps, b1.commands)
    b = build(as_scenario(_hold(0.3, record={"decimate": 16})))
    a = core.run_closed_loop(b.cfg, b.drive.state, b.n_steps, b.commands, blocks=tuple(core.BLOCKS)).arrays
    late = a["t"] > 0.1
    pt = a["i_abc"][late, 0]
    env = a["i_abc_max"][late, 0] - a["i_abc_min"][late, 0]
    hf_pp = np.ptp(ref.arrays["i_abc"][ref.arrays["t"] > 0.1, 0])
    assert np.ptp(pt) < 0.2 * hf_pp  # aliased to (nearly) a constant
    assert np.min(env) > 0.8 * hf_pp  # every block shows the whole HF swing


def test_metrics_only_memory_does_not_grow(monkeypatch):
    # (on the switching inverter: the average model's dead-time approximation cycles by 0.6 deg at
    # this position with the default 8 Hz speed loop; the switching model holds within 0.002 deg)
    sw = {"inverter": {"fidelity": "switching"}}
    short = simulation.simulate(_hold(10.0, **sw), record="metrics")
    long = simulation.simulate(_hold(100.0, **sw), record="metrics")
    assert short.t.size == long.t.size <= simulation.METRICS_SAMPLES
    assert long.metrics["steps"] == 1_600_000
    # the record's blocks (its scenario says them); the metrics read every period
    assert long.scenario.spec.record.decimate == -(-1_600_000 // simulation.METRICS_SAMPLES)
    assert long.metrics["block_s"] == 1 / 16000 and long.metrics["samples"] == 1_600_000
    assert long.stable and long.x_min is not None and long.i_abc_max.shape == (long.t.size, 3)


@pytest.mark.parametrize("scenario", ["step3_lut.toml", "hold"])
def test_metrics_only_matches_the_full_trace(monkeypatch, scenario):
    """Metrics-only (a record of blocks of 64 periods, 4 ms) against the full trace: the same metrics,
    bit for bit (earlier versions read them within a block: a settling time of 0 within the first)."""
    sc = _hold(2.0) if scenario == "hold" else EXAMPLES / scenario
    full = simulation.simulate(sc).metrics
    monkeypatch.setattr(simulation, "METRICS_SAMPLES", 500)
    mo = simulation.simulate(sc, record="metrics")
    assert mo.scenario.spec.record.decimate == 64 and mo.t.size == 500
    wall = ("wall_s", "realtime_factor")
    assert {k: v for k, v in mo.metrics.items() if k not in wall} == \
           {k: v for k, v in full.items() if k not in wall}
    assert {k: v for k, v in simulation.metrics_only(sc).items() if k not in wall} == \
           {k: v for k, v in full.items() if k not in wall}


def test_record_mode_checked():
    with pytest.raises(InputError, match="simulate: record: must be one of .trace., .metrics., got"):
        simulation.simulate(_hold(0.01), record="everything")


def test_a_long_decimation_holds_one_block_at_most():
    """The record of decimate = 10^6 made from every period holds one block's running statistics,
    not its periods (a block of 10^6 periods of every signal is 140 MB)."""
    import tracemalloc

    from linsense.sim.stream import simulate_streamed

    b = build(as_scenario(_hold(20.0, record={"decimate": 1_000_000})), trace_in_memory=False)
    got = []
    tracemalloc.start()
    try:
        simulate_streamed(b, on_chunk=lambda a: got.append(len(a["t"])))
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert got == [1] and peak < 15e6, (got, peak)
