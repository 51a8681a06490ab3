"""Functions a reader can hold: the functions split by concern stay under the bound (no function
over 80 lines on the main path), each counted from its ``def`` to its last
line, docstring included."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src" / "linsense"

#: The most lines of a function on the main path.
MAX_LINES = 80

#: (module, function) of the main path held to MAX_LINES.
HELD = [
    ("sim/metrics.py", "compute_metrics"),
    ("scenario/load.py", "_check"),
    ("reproduce/pipeline.py", "_closed_loop"),
    ("report/verify_figures.py", "certificate_figure"),
    ("verify/case_runs.py", "judge"),
    ("fea/solver.py", "run_loads"),
    ("identify/process.py", "process_bench"),
    ("report/fea.py", "run_fea"),
    ("studies/calibrate.py", "calibration_scenario"),
    ("studies/calibrate.py", "calibrate"),
    ("tune/export.py", "c_header"),
    ("tune/design.py", "design"),
    ("tune/startup.py", "design_startup"),
    ("identify/bench.py", "read_bench_csv"),
    ("verify/certificate.py", "prepare"),
    ("identify/identification.py", "identify"),
    ("tune/export.py", "scenario_dict"),
    ("tune/design.py", "loops"),
    ("io.py", "csv_rows"),
    ("identify/bench.py", "emulate_bench"),
    ("report/sim_figures.py", "sim_figure"),
    ("reproduce/pipeline.py", "reproduce"),
    ("examples/__init__.py", "copy_to"),
    ("reproduce/claims.py", "claims"),
    ("fea/solver.py", "solve_nonlinear"),
    ("sim/stream.py", "simulate_streamed"),
    ("sim/checks.py", "check_units"),
    ("firmware/project.py", "firmware_files"),
]

#: The most lines of any function of the package, on the main path or not.
MAX_LINES_ANYWHERE = 120


def _lengths(module: str) -> dict[str, int]:
    """The longest definition of each function name in ``module``, lines."""
    tree = ast.parse((SRC / module).read_text(encoding="utf-8"))
    out: dict[str, int] = {}
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            out[node.name] = max(out.get(node.name, 0), node.end_lineno - node.lineno + 1)
    return out


@pytest.mark.parametrize(("module", "name"), HELD)
def test_held_function_is_short(module: str, name: str) -> None:
    lengths = _lengths(module)
    assert name in lengths, f"{module}: no function {name} (moved? update HELD)"
    assert lengths[name] <= MAX_LINES, (f"{module}:{name} has {lengths[name]} lines, over {MAX_LINES}: "
                                        "split it by concern")


def test_no_function_is_long_anywhere() -> None:
    long = {f"{path.relative_to(SRC)}:{name}": n for path in sorted(SRC.rglob("*.py"))
            if "__pycache__" not in path.parts
            for name, n in _lengths(str(path.relative_to(SRC))).items() if n > MAX_LINES_ANYWHERE}
    assert not long, f"functions over {MAX_LINES_ANYWHERE} lines (split them by concern): {long}"
