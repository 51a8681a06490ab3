"""The Python API of the commands: ``linsense.sim.simulate_to``, ``linsense.verify.tune_to``,
``linsense.sweep.sweep_to``, ``linsense.firmware.pil.closed_loop_to`` and
``linsense.firmware.verified_export.export_firmware`` write and return what ``linsense simulate``,
``tune``, ``sweep`` and ``simulate --pil`` write, byte for byte (timing aside); the command line is a
thin layer over them."""

from __future__ import annotations

from pathlib import Path

import pytest

import linsense.sim
from linsense.scenario.load import load_scenario


def _toml(path: Path, duration: float = 0.4) -> Path:
    path.write_text(f'motor = "ecce2010"\n[scenario]\nname = "t"\nduration = {duration}\n'
                    '[reference]\nposition_mm = 1.0\nat = 0.02\n')
    return path


@pytest.mark.parametrize("trace", ["csv", "none"])
def test_simulate_to_writes_what_the_cli_writes(run_cli, tmp_path, trace):
    """simulate_to from Python and ``linsense simulate`` give the same files (timing.json aside)."""
    p = _toml(tmp_path / "s.toml")
    r = run_cli("simulate", p, "--out", tmp_path / "cli", "--trace", trace, "--mat", "--decimate", 2)
    assert r.code == 0, r.err
    done = linsense.sim.simulate_to(tmp_path / "api", load_scenario(p), trace=trace, mat=True, decimate=2)
    names = sorted(f.name for f in (tmp_path / "cli").iterdir())
    assert names == sorted(f.name for f in (tmp_path / "api").iterdir())
    assert {f.name for f in done.files} == set(names) - {".linsense-set.json"}
    for name in names:
        if name not in ("timing.json", ".linsense-set.json"):
            assert (tmp_path / "cli" / name).read_bytes() == (tmp_path / "api" / name).read_bytes(), name
    assert done.metrics["samples"] == 6400 and "wall_s" in done.timing
    assert done.stable == done.metrics["stable"]


def test_simulate_to_draws_with_the_figure_given(tmp_path):
    """The figure is drawn by the function given (the simulator is below the figures)."""
    drawn = []
    linsense.sim.simulate_to(tmp_path / "o", load_scenario(_toml(tmp_path / "s.toml")), trace="none",
                             plot=lambda data, path: drawn.append((data, path)))
    assert len(drawn) == 1 and drawn[0][0] is not None and drawn[0][1].name == "sim.png"


def test_tune_makes_what_the_cli_writes(run_cli, tmp_path):
    """tune() from Python makes the scenario and the C header ``linsense tune`` writes, byte for
    byte, and says the same report."""
    from linsense.verify import TuneResult, tune

    r = run_cli("tune", "--motor", "small30", "--no-verify", "--out", tmp_path / "m.toml")
    assert r.code == 0, r.err
    said: list[str] = []
    res = tune("small30", verify=False, out=tmp_path / "m.toml", say=said.append)
    assert isinstance(res, TuneResult) and res.certificate is None and res.passed is None
    assert res.text == (tmp_path / "m.toml").read_text()
    assert said and all(line in r.err + r.out for line in said)
    assert res.summary()["motor"] == res.motor.name and res.scenario["motor"] == "small30"
    r = run_cli("tune", "--motor", "small30", "--format", "c", "--unverified", "--no-verify",
                "--out", tmp_path / "m.h")
    assert r.code == 0, r.err
    res = tune("small30", fmt="c", verify=False, unverified=True)
    assert res.unverified and not res.refused and res.text == (tmp_path / "m.h").read_text()
    refused = tune("small30", fmt="c", verify=False)
    assert refused.text is None and refused.refused == res.unverified


def test_tune_refuses_a_drive_datum_it_does_not_know(tmp_path):
    """No key silently ignored: a drive datum tune does not know is refused by name."""
    from linsense.errors import InputError
    from linsense.verify import tune

    with pytest.raises(InputError, match="not a drive datum"):
        tune("small30", verify=False, drive={"v_bus": 48.0})


def test_tune_certificate_as_the_cli_writes_it(run_cli, tmp_path):
    """The quick certificate's JSON from tune() is the one ``linsense tune --quick`` writes."""
    import json

    from linsense.verify import tune

    r = run_cli("tune", "--motor", "small30", "--quick", "--out", tmp_path / "q.toml")
    assert r.code in (0, 1), r.err
    written: list = []
    res = tune("small30", quick=True, out=tmp_path / "q.toml", ready=lambda x: written.append(x.certificate))
    assert written == [None]  # (a scenario is made before its certificate runs)
    doc = json.loads((tmp_path / "q.verification.json").read_text())
    ours = res.certificate_doc(str(tmp_path / "q.toml"))
    drop = ("wall_s", "runs")
    assert {k: v for k, v in ours.items() if k not in drop} == {k: v for k, v in doc.items() if k not in drop}
    assert res.passed == (r.code == 0)


@pytest.mark.parametrize(("module", "function", "most"), [
    ("cli/tune.py", "tune", 45), ("cli/runs.py", "simulate", 45), ("cli/runs.py", "sweep_cmd", 30),
    ("cli/runs.py", "_simulate_pil", 32), ("cli/models.py", "lut", 36),
    ("verify/tuning.py", "tune", 80), ("sim/to_folder.py", "simulate_to", 80)])
def test_the_commands_are_thin_over_their_api(module, function, most):
    """The commands parse, call the API and write; the API's functions stay readable (lines from
    ``def`` to the last line, docstring included)."""
    import ast

    path = Path(linsense.sim.__file__).parents[1] / module
    tree = ast.parse(path.read_text(encoding="utf-8"))
    (node,) = [n for n in tree.body if isinstance(n, ast.FunctionDef) and n.name == function]
    assert node.end_lineno - node.lineno + 1 <= most


def test_run_closed_loop_takes_a_runner(tmp_path):
    """run_closed_loop's time loop can be given (the processor in the loop gives the firmware's
    under QEMU): the same loop given gives the same run; a status refused names the runner."""
    import numpy as np
    from linsense._ctrl import lib

    from linsense.errors import SimulationError
    from linsense.sim.build import build
    from linsense.sim.core import run_closed_loop

    def fresh():
        return build(load_scenario(_toml(tmp_path / "s.toml", duration=0.05)))

    b = fresh()
    ref = run_closed_loop(b.cfg, b.drive.state, b.n_steps, b.commands)
    calls = []

    def runner(*args):
        calls.append(len(args))
        return lib.ls_sim_run(*args)

    b = fresh()
    got = run_closed_loop(b.cfg, b.drive.state, b.n_steps, b.commands, runner=runner)
    assert calls == [7] and got.steps_done == ref.steps_done
    for k in ref.arrays:
        assert np.array_equal(ref.arrays[k], got.arrays[k], equal_nan=True), k

    def refusing(*args):
        return lib.LS_OK + 1

    with pytest.raises(SimulationError, match="refusing refused its inputs"):
        run_closed_loop(b.cfg, b.drive.state, b.n_steps, b.commands, runner=refusing)


def test_export_firmware_writes_only_a_verified_drive(tmp_path):
    """``linsense.firmware.verified_export.export_firmware`` (what ``linsense firmware export``
    runs): a drive the quick certificate fails is not written, its failed checks returned; with
    ``unverified`` the same files are written and the configuration header says why."""
    from linsense.firmware.verified_export import export_firmware
    from linsense.model.motor import load_motor
    from linsense.tune.design import DriveData

    m, dd = load_motor("ecce2010"), DriveData(v_max=0.01)  # (0.4 s steps at 1 cm/s: not met)
    said: list[str] = []
    res = export_firmware(tmp_path / "fw", m, dd, motor_spec="ecce2010", say=said.append)
    assert not res.written and not (tmp_path / "fw").exists()
    assert res.reason.startswith("NOT verified") and "step" in res.reason
    assert res.certificate.passed is False and any("quick" in s for s in said)
    res = export_firmware(tmp_path / "fw", m, dd, motor_spec="ecce2010", unverified=True)
    header = (tmp_path / "fw" / "ls_cfg_ecce2010.h").read_text()
    assert res.written and "NOT VERIFIED" in header and (tmp_path / "fw" / "CMakeLists.txt").exists()


def test_calibrate_to_writes_what_the_cli_writes(run_cli, tmp_path):
    """``linsense.studies.calibration_folder.calibrate_to`` and ``linsense calibrate`` give the same
    files (timing.json aside), the figure drawn by the function given."""
    from linsense.report.figures import fig_calibration, save_png
    from linsense.studies.calibration_folder import calibrate_to

    r = run_cli("calibrate", "--motor", "ecce2010", "--positions", 8, "--fidelity", "average",
                "--out", tmp_path / "cli")
    assert r.code == 0, r.err
    done = calibrate_to(tmp_path / "api", "ecce2010", positions=8, fidelity="average",
                        figure=lambda cal, path: save_png(fig_calibration(cal, cal.motor), path))
    names = sorted(f.name for f in (tmp_path / "cli").iterdir())
    assert names == sorted(f.name for f in (tmp_path / "api").iterdir())
    assert {f.name for f in done.files} == set(names) - {".linsense-set.json"}
    for name in set(names) - {"timing.json", ".linsense-set.json"}:
        assert (tmp_path / "cli" / name).read_bytes() == (tmp_path / "api" / name).read_bytes(), name
    assert done.completed and done.metrics["points_done"] == 8 and "wall_s" in done.timing


def test_tune_to_writes_what_the_cli_writes(run_cli, tmp_path):
    """``linsense.verify.tune_to`` writes the scenario and its certificate's files as ``linsense tune
    --quick`` does (the JSON byte for byte but its wall time), the figure drawn by the function given;
    a certificate of another output is refused before anything runs, a stale one deleted."""
    import json

    from linsense.errors import InputError
    from linsense.report.verify_figures import write_certificate_figure
    from linsense.verify import tune_to

    (tmp_path / "cli").mkdir()
    r = run_cli("tune", "--motor", "small30", "--quick", "--out", tmp_path / "cli" / "q.toml")
    assert r.code in (0, 1), r.err
    res = tune_to(tmp_path / "api" / "q.toml", "small30", quick=True, figure=write_certificate_figure)
    assert [f.name for f in res.files] == ["q.toml", "q.verification.json", "q.verification.png"]
    assert res.passed == (r.code == 0)
    for name in ("q.toml", "q.verification.json"):
        cli, api = ((tmp_path / d / name).read_text() for d in ("cli", "api"))
        if name.endswith(".json"):
            cli, api = ({k: v for k, v in json.loads(t).items() if k != "wall_s"} for t in (cli, api))
        assert cli == api, name
    with pytest.raises(InputError, match="this is the certificate of q.toml"):
        tune_to(tmp_path / "api" / "q.h", "small30", fmt="c", verify=False, unverified=True)
    res = tune_to(tmp_path / "api" / "q.toml", "small30", verify=False)
    assert res.files == [tmp_path / "api" / "q.toml"]
    assert not (tmp_path / "api" / "q.verification.json").exists()


def test_sweep_to_writes_what_the_cli_writes(run_cli, tmp_path):
    """``linsense.sweep.sweep_to`` writes the results, the summary and the study's figure as
    ``linsense sweep`` does, and counts the runs as its ``--json`` says them."""
    import json

    from linsense.report.sweep_figures import write_sweep_figure
    from linsense.sweep import sweep_to

    base = _toml(tmp_path / "s.toml", duration=0.1)
    spec = tmp_path / "w.toml"
    spec.write_text(f'[sweep]\nname = "w"\nscenario = "{base}"\nstudy = "stability-map"\nsampling = "grid"\n'
                    '[[axis]]\nkey = "reference.position_mm"\nvalues = [0.5, 1.0]\n'
                    '[[axis]]\nkey = "observer.bandwidth_hz"\nvalues = [30.0]\n')
    r = run_cli("sweep", spec, "--out", tmp_path / "cli", "--no-progress", "--json")
    assert r.code == 0, r.err
    done = sweep_to(tmp_path / "api", spec, figure=write_sweep_figure)
    assert [f.name for f in done.files] == ["results.parquet", "summary.txt", "stability-map.png"]
    for f in done.files:
        assert (tmp_path / "cli" / f.name).read_bytes() == f.read_bytes(), f.name
    doc = json.loads(r.out)
    assert (doc["stable"], doc["not_stable"], doc["refused"], doc["failed_runs"], doc["summary"]) == (
        done.stable, done.not_stable, done.refused, done.failed_runs, done.summary)
    assert not sweep_to(tmp_path / "api2", spec).files[2:]  # (no figure given: none drawn)


@pytest.mark.parametrize("f_inj", [1.0, 0.5, 2e7, -3.0, float("nan"), 5e-324])
def test_lut_f_inj_refused_by_the_table(run_cli, tmp_path, f_inj):
    """``lut --f-inj`` is refused by the table's own check (``table_frequency``, which ``build_lut``
    runs): the command only names the option."""
    from linsense.compensation.lut import build_lut, table_frequency
    from linsense.errors import InputError
    from linsense.model.motor import load_motor

    r = run_cli("lut", "--motor", "ecce2010", "--f-inj", repr(f_inj), "--out", tmp_path / "l.csv")
    with pytest.raises(InputError) as api:
        build_lut(load_motor("ecce2010"), 16, f_inj)
    assert r.code == 2 and r.err.strip() == f"linsense: error: --f-inj: {api.value.message}"
    with pytest.raises(InputError) as direct:
        table_frequency(f_inj, "--f-inj", "")
    assert direct.value.message == api.value.message


def test_pil_closed_is_a_thin_wrapper():
    """tools/pil_closed.py calls the package's loop (``linsense.firmware.pil.run_pil``): it runs no
    loop, builds nothing and compares nothing of its own."""
    import ast

    path = Path(linsense.sim.__file__).parents[3] / "tools" / "pil_closed.py"
    if not path.is_file():
        pytest.skip("not a source tree")
    text = path.read_text(encoding="utf-8")
    tree = ast.parse(text)
    assert [n.name for n in tree.body if isinstance(n, ast.FunctionDef)] == ["main"]
    assert len(text.splitlines()) <= 40 and "run_pil" in text
    for word in ("run_closed_loop", "build_replay", "qemu", "mkfifo"):
        assert word not in text, word


def _pil_ready() -> bool:
    import shutil

    from linsense.firmware.pil import TOOLS, source_tree

    return source_tree() is not None and all(shutil.which(t) for t in TOOLS)


@pytest.mark.slow
@pytest.mark.skipif(not _pil_ready(), reason="needs a source tree, the ARM compiler and QEMU (make tools)")
def test_closed_loop_to_writes_what_the_cli_writes(run_cli, tmp_path):
    """``linsense.firmware.pil.closed_loop_to`` and ``linsense simulate --pil`` write the same
    metrics.json and pil.json; the firmware's run is the host build's, bit for bit."""
    from linsense.firmware.pil import closed_loop_to

    p = _toml(tmp_path / "s.toml", duration=0.05)
    r = run_cli("simulate", p, "--pil", "--out", tmp_path / "cli")
    assert r.code == 0, r.err
    done = closed_loop_to(tmp_path / "api", p)
    assert done.record["pass"] and done.record["identical_steps"]
    assert sorted(f.name for f in done.files) == ["metrics.json", "pil.json", "timing.json"]
    for name in ("metrics.json", "pil.json"):
        assert (tmp_path / "cli" / name).read_bytes() == (tmp_path / "api" / name).read_bytes(), name
