"""Sizes: every size a user types is checked against its limit before
anything is allocated, and Ctrl-C ends a long run within a second with nothing written."""

from __future__ import annotations

import _thread
import threading
import time
import tracemalloc

import pytest

LONG = """motor = "ecce2010"
[scenario]
duration = 3000.0
[control]
mode = "sensorless_lut"
[reference]
type = "hold"
[record]
decimate = 1000
"""


@pytest.mark.parametrize("what", ["points", "harmonic order", "duration x rate", "recorded samples"])
def test_sizes_are_checked_before_allocating(run_cli, tmp_path, what):
    """Each refused size costs almost no memory: the limit is checked before anything is allocated."""
    if what == "points":
        args = ["model", "--motor", "ecce2010", "--points", "50000000000", "--out", tmp_path / "m.csv"]
    elif what == "harmonic order":
        text = open_preset().replace("dM0 = -0.47e-3", "dM0 = -0.47e-3\nL2000000000 = 1e-6")
        (tmp_path / "m.toml").write_text(text)
        args = ["model", "--motor", tmp_path / "m.toml", "--out", tmp_path / "m.csv"]
    else:
        duration = "1e7" if what == "duration x rate" else "2e4"
        (tmp_path / "s.toml").write_text(LONG.replace("duration = 3000.0", f"duration = {duration}")
                                         .replace("decimate = 1000", "decimate = 1"))
        args = ["simulate", tmp_path / "s.toml", "--out", tmp_path / "out", "--no-plot"]
    tracemalloc.start()
    try:
        r = run_cli(*args)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert r.code == 2, r.err
    assert "limit" in r.err, r.err
    assert peak < 50e6, f"{peak / 1e6:.0f} MB allocated before refusing"


def open_preset() -> str:
    from importlib import resources

    return (resources.files("linsense.model") / "presets" / "ecce2010.toml").read_text()


def test_ctrl_c_stops_a_long_run_within_a_second(tmp_path):
    """An interrupt (as Ctrl-C delivers it to the main thread) stops the C loop at its next poll."""
    from linsense.sim.simulation import simulate

    (tmp_path / "s.toml").write_text(LONG)
    sent = []

    def interrupt_when_running() -> None:
        t_end = time.monotonic() + 60.0
        while time.monotonic() < t_end:
            if any(t.name == "linsense-sim" for t in threading.enumerate()):
                time.sleep(0.2)  # well inside the 3000 s run (about 10 s of computing)
                sent.append(time.monotonic())
                _thread.interrupt_main()
                return
            time.sleep(0.01)

    helper = threading.Thread(target=interrupt_when_running)
    helper.start()
    with pytest.raises(KeyboardInterrupt):
        simulate(tmp_path / "s.toml")
    stopped = time.monotonic()
    helper.join()
    assert sent, "the simulation thread never started"
    assert stopped - sent[0] < 1.0
    assert not any(t.name == "linsense-sim" for t in threading.enumerate())


def test_an_interrupt_inside_the_threads_start_still_waits_for_it(tmp_path, monkeypatch):
    """An interrupt that lands while ``Thread.start`` waits for the new thread (a loaded machine
    kept it waiting there: a fresh clone's run saw the thread alive after the interrupt) finds the
    thread spawned all the same: the run waits for its C loop to stop before raising."""
    from linsense.sim.simulation import simulate

    (tmp_path / "s.toml").write_text(LONG)
    start = threading.Thread.start

    def interrupted_start(self) -> None:
        start(self)
        if self.name == "linsense-sim":
            raise KeyboardInterrupt

    monkeypatch.setattr(threading.Thread, "start", interrupted_start)
    with pytest.raises(KeyboardInterrupt):
        simulate(tmp_path / "s.toml")
    assert not any(t.name == "linsense-sim" for t in threading.enumerate())


def test_ctrl_c_on_the_command_line(run_cli, tmp_path, monkeypatch):
    """The CLI answers an interrupt with one line and exit 130, and writes nothing."""
    import linsense.sim.stream

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(linsense.sim.stream, "simulate_streamed", interrupted)
    (tmp_path / "s.toml").write_text(LONG)
    r = run_cli("simulate", tmp_path / "s.toml", "--out", tmp_path / "out")
    assert r.code == 130
    assert r.err.strip() == "linsense: interrupted"
    assert not (tmp_path / "out").exists()
