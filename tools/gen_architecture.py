"""Draw docs/img/architecture.svg, the picture of docs/architecture.md, from the code it shows.

The picture is the layer stack of ``.importlinter`` (one row per layer, top to bottom, a box per
package with the first line of its docstring) and, over it, the two paths the page describes: a
scenario's (``linsense simulate``) and ``linsense tune``'s, each a numbered list of steps
(:data:`PATHS`). A step names a module and a function; the script refuses a step whose module or
function does not exist, or whose module no earlier step imports (the path would be drawn where
the code does not go). The SVG is written by hand (no plotting library), so
identical code gives identical bytes on every machine.

``tests/test_architecture_doc.py`` fails when the committed picture differs from what this script
writes. Usage: ``python tools/gen_architecture.py`` (rewrites it) or ``--check`` (exit 1 when it
would change).
"""

from __future__ import annotations

import ast
import configparser
import html
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
SRC = ROOT / "src"
PICTURE = ROOT / "docs" / "img" / "architecture.svg"

#: the two paths of docs/architecture.md: (module, function, what it does there)
PATHS = {
    "simulate": (
        ("linsense.cli.runs", "simulate", "the command: options -> simulate_to"),
        ("linsense.scenario.load", "load_scenario", "S.toml -> Scenario: schema, rules between keys"),
        ("linsense.sim.to_folder", "simulate_to", "the output set, the trace writer"),
        ("linsense.sim.build", "build", "motor, designed gains, checks, plant"),
        ("linsense.tune.drive_design", "design_drive", "the gains S leaves unset"),
        ("linsense.sim.drive_cfg", "fill", "S -> ls_drive_cfg, row by row"),
        ("linsense.tune.cfgmap", "ROWS", "the one scenario key -> C field map"),
        ("linsense.ctrl", "Drive", "ls_drive_init: the C library's checks"),
        ("linsense.sim.stream", "simulate_streamed", "the C time loop, chunk by chunk"),
        ("linsense.sim.metrics", "compute_metrics", "metrics from every PWM period"),
    ),
    "tune": (
        ("linsense.cli.tune", "tune", "the command: options -> verify.tune_to"),
        ("linsense.verify.tune_output", "tune_to", "the output, the certificate's files beside it"),
        ("linsense.verify.tuning", "tune", "design, scenario or header, certificate"),
        ("linsense.tune.drive_design", "design_drive", "the design, composed once"),
        ("linsense.tune.design", "design", "every gain, limit and trip"),
        ("linsense.tune.export", "scenario_dict", "DriveDesign.scenario_keys -> scenario"),
        ("linsense.verify.certificate", "verify", "the checks: holds, steps, moves, loads"),
        ("linsense.verify.case_runs", "run_cases", "each case a scenario, run in threads"),
        ("linsense.sim.core", "run_closed_loop", "the C time loop"),
    ),
}
COLOURS = {"simulate": "#c0392b", "tune": "#1f6fb2"}

WIDTH, ROW, GAP, LEFT, STACK_W, LABEL_W = 1180, 40, 6, 10, 720, 150


def layers(path: Path = ROOT / ".importlinter") -> list[list[str]]:
    """The layers of the contract, top first, each a list of its packages (``a | b``)."""
    cfg = configparser.ConfigParser()
    cfg.read(path)
    rows = cfg["importlinter:contract:layers"]["layers"].split("\n")
    return [[p.strip() for p in row.split("|")] for row in rows if row.strip()]


def module_file(name: str) -> Path:
    """The source file of a module or package of src/ (a package: its ``__init__.py``)."""
    base = SRC / Path(*name.split("."))
    for p in (base / "__init__.py", base.with_suffix(".py")):
        if p.exists():
            return p
    raise SystemExit(f"gen_architecture: no module {name} under src/")


def summary(name: str) -> str:
    """The first line of a module's docstring, shortened to what fits a box."""
    doc = ast.get_docstring(ast.parse(module_file(name).read_text())) or ""
    line = doc.strip().split("\n")[0].rstrip(".").replace("``", "")
    line = re.sub(r"^linsense(\.\w+)*: ", "", line)  # (the box names the package already)
    line = line if line.startswith("linsense") else line[:1].upper() + line[1:]
    return line if len(line) <= 62 else line[:59].rsplit(" ", 1)[0] + " ..."


def imports(name: str) -> set[str]:
    """Every module ``name`` imports (at top level or inside functions), as dotted names."""
    tree = ast.parse(module_file(name).read_text())
    pkg = name if module_file(name).name == "__init__.py" else name.rsplit(".", 1)[0]
    out: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parts = pkg.split(".")[: len(pkg.split(".")) - node.level + 1]
                base = ".".join(parts + ([base] if base else []))
            out.add(base)
            out.update(f"{base}.{a.name}" for a in node.names)
    return out


def defines(name: str, func: str) -> bool:
    """Whether module ``name`` defines (or imports under that name) ``func`` at top level."""
    tree = ast.parse(module_file(name).read_text())
    for node in tree.body:
        if isinstance(node, (ast.FunctionDef, ast.ClassDef)) and node.name == func:
            return True
        if isinstance(node, (ast.Assign, ast.AnnAssign)) and func in {
                t.id for t in (node.targets if isinstance(node, ast.Assign) else [node.target])
                if isinstance(t, ast.Name)}:
            return True
        if isinstance(node, (ast.Import, ast.ImportFrom)) and any((a.asname or a.name) == func
                                                                   for a in node.names):
            return True
    return False


def check_paths() -> None:
    """Refuse a step that is not in the code: no such function, or no earlier step that imports it."""
    for path, steps in PATHS.items():
        for i, (mod, func, _) in enumerate(steps):
            if not defines(mod, func):
                raise SystemExit(f"gen_architecture: {path} step {i + 1}: {mod} has no {func}")
            callers = [m for m, _, _ in steps[:i]]
            if i and not any(mod in imports(m) or f"{mod}.{func}" in imports(m) for m in callers):
                raise SystemExit(f"gen_architecture: {path} step {i + 1}: {mod} is imported by no step "
                                 "before it")


def package_of(module: str, rows: list[list[str]]) -> str:
    """The contract's package (or module) that holds ``module``."""
    names = [p for row in rows for p in row]
    best = [p for p in names if module == p or module.startswith(p + ".")]
    if not best:
        raise SystemExit(f"gen_architecture: {module} is in no layer of .importlinter")
    return max(best, key=len)


def _text(x: float, y: float, s: str, size: int = 12, anchor: str = "start", weight: str = "normal",
          fill: str = "#222") -> str:
    return (f'<text x="{x:.1f}" y="{y:.1f}" font-size="{size}" text-anchor="{anchor}" '
            f'font-weight="{weight}" fill="{fill}">{html.escape(s)}</text>')


def render() -> str:
    """The SVG text of the picture."""
    check_paths()
    rows = layers()
    top = 50
    height = top + len(rows) * (ROW + GAP) + 30
    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{WIDTH}" height="{height}" '
           f'viewBox="0 0 {WIDTH} {height}" font-family="DejaVu Sans, Helvetica, Arial, sans-serif">',
           f'<rect width="{WIDTH}" height="{height}" fill="white"/>',
           _text(LEFT, 22, "linsense: the layers (.importlinter, top imports down) and two paths", 15,
                 weight="bold"),
           _text(LEFT, 40, "each box: a package and the first line of its docstring; numbered dots: "
                 "the steps of a path (right)", 11, fill="#555")]
    centre: dict[str, tuple[float, float, float]] = {}  # package: (left, middle height, width)
    for r, row in enumerate(rows):
        y = top + r * (ROW + GAP)
        w = STACK_W / len(row)
        for k, pkg in enumerate(row):
            x = LEFT + k * w
            out.append(f'<rect x="{x + 2:.1f}" y="{y:.1f}" width="{w - 4:.1f}" height="{ROW}" rx="5" '
                       f'fill="#f3f1ea" stroke="#8a8577"/>')
            label = pkg.removeprefix("linsense.") if pkg != "linsense.__main__" else "__main__"
            out.append(_text(x + 8, y + 16, label, 12, weight="bold"))
            note = summary(pkg)
            room = int((w - 16) / 6.2)
            out.append(_text(x + 8, y + 32, note if len(note) <= room else note[: room - 4].rsplit(" ", 1)[0]
                             + " ...", 10, fill="#555"))
            centre[pkg] = (x, y + ROW / 2, w)
    legend_x = LEFT + STACK_W + 20
    ly = top
    for p, (path, steps) in enumerate(PATHS.items()):
        colour = COLOURS[path]
        dots = []
        for i, (mod, _func, _) in enumerate(steps):
            x0, cy, w = centre[package_of(mod, rows)]
            k = sum(package_of(m, rows) == package_of(mod, rows) for m, _, _ in steps[:i])
            # (the first path's dots from the box's right edge leftwards, the second's from its middle
            # rightwards: two paths through one box do not cover each other)
            dots.append((x0 + w - 16 - 22 * k if p == 0 else x0 + 0.5 * w + 22 * k, cy))
        pts = " ".join(f"{x:.1f},{y:.1f}" for x, y in dots)
        out.append(f'<polyline points="{pts}" fill="none" stroke="{colour}" stroke-width="2" '
                   f'stroke-opacity="0.7"/>')
        for i, (x, y) in enumerate(dots):
            out.append(f'<circle cx="{x:.1f}" cy="{y:.1f}" r="8" fill="{colour}"/>')
            out.append(_text(x, y + 4, str(i + 1), 10, anchor="middle", weight="bold", fill="white"))
        out.append(_text(legend_x, ly + 14, f"linsense {path}", 13, weight="bold", fill=colour))
        ly += 22
        for i, (mod, func, what) in enumerate(steps):
            out.append(_text(legend_x, ly + 12, f"{i + 1}. {mod.removeprefix('linsense.')}.{func}", 11,
                             weight="bold"))
            out.append(_text(legend_x + 14, ly + 26, what, 10, fill="#555"))
            ly += 32
        ly += 16
    out.append("</svg>")
    return "\n".join(out) + "\n"


def main(argv: list[str]) -> int:
    svg = render()
    if "--check" in argv:
        if not PICTURE.exists() or PICTURE.read_text() != svg:
            print(f"{PICTURE.relative_to(ROOT)} is out of date: run python tools/gen_architecture.py",
                  file=sys.stderr)
            return 1
        return 0
    PICTURE.parent.mkdir(parents=True, exist_ok=True)
    PICTURE.write_text(svg)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
