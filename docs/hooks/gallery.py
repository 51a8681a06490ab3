"""mkdocs hook: the gallery, every example scenario run at build time by the simulator.

For each ``*.toml`` of the example scenarios (``src/linsense/examples/scenarios/`` when the package
ships them, else ``examples/scenarios/``: whichever exists, resolved at build time) the hook runs
:func:`linsense.simulate`, draws the run with the project's own figure
(:func:`linsense.report.sim_figures.sim_figure_png`, what ``linsense simulate --plot`` writes as
``sim.png``) and writes a page with the figure, the metrics (``metrics.json`` without the
wall-clock keys) and the scenario file; the index shows a thumbnail of each figure (its title and
position panel, scaled down here: :func:`thumbnail`) beside its summary metrics. Pages and PNGs exist only in the built site: nothing is
written into ``docs/`` and nothing is cached between builds.

The navigation's ``Gallery`` entry (``gallery/index.md`` in ``mkdocs.yml``) is expanded here to the
index and one page per scenario, so that a new scenario file appears without editing ``mkdocs.yml``.
"""

from __future__ import annotations

import html
import logging
import time
from pathlib import Path

from mkdocs.structure.files import File, Files

log = logging.getLogger("mkdocs.hooks.gallery")

INDEX = "gallery/index.md"
#: the example scenarios' folder, relative to mkdocs.yml, by preference
CANDIDATES = ("src/linsense/examples/scenarios", "examples/scenarios")
#: the metrics the gallery's index shows per scenario (the page shows them all)
SUMMARY_KEYS = ("verdict", "max_abs_err_deg", "steady_max_err_deg", "bias_deg", "final_position_mm")


def scenario_dir(root: Path) -> Path:
    """The folder of the example scenarios: the first of :data:`CANDIDATES` under ``root`` that has
    scenario files."""
    for rel in CANDIDATES:
        d = root / rel
        if d.is_dir() and any(d.glob("*.toml")):
            return d
    raise FileNotFoundError(f"no example scenarios under {root} (looked in {', '.join(CANDIDATES)})")


def scenario_files(root: Path) -> list[Path]:
    """The example scenarios, sorted by name."""
    return sorted(scenario_dir(root).glob("*.toml"))


def _root(config) -> Path:
    return Path(config.config_file_path).resolve().parent


def on_config(config):
    """Expand the ``Gallery`` entry of the navigation to the index and one page per scenario."""
    pages = [INDEX] + [{f.stem: f"gallery/{f.stem}.md"} for f in scenario_files(_root(config))]

    def expand(items):
        for i, item in enumerate(items):
            if isinstance(item, dict):
                for title, value in item.items():
                    # (the entry, or the list it became when this config was expanded before)
                    if value == INDEX or (isinstance(value, list) and value[:1] == [INDEX]):
                        item[title] = pages
                        return True
                    if isinstance(value, list) and expand(value):
                        return True
            elif item == INDEX:
                items[i] = {"Gallery": pages}
                return True
        return False

    if not expand(config.nav or []):
        raise ValueError(f"mkdocs.yml: the nav has no {INDEX} entry for the gallery")
    return config


def _value(v) -> str:
    if isinstance(v, bool):
        return "yes" if v else "no"
    if v is None:
        return "-"
    if isinstance(v, float):
        return f"{v:.6g}"
    if isinstance(v, list):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    return str(v)


def _cell(v) -> str:
    # (a metrics table cell: no pipe, no newline, HTML escaped)
    return html.escape(_value(v)).replace("|", "&#124;").replace("\n", " ")


def _description(text: str) -> str:
    """The scenario file's leading comment lines, as a paragraph."""
    lines = []
    for line in text.splitlines():
        if not line.startswith("#"):
            break
        lines.append(line.lstrip("#").strip())
    return " ".join(x for x in lines if x)


#: the thumbnails' width in pixels (shown at half of it, docs/assets/linsense.css: sharp on a
#: high-density screen)
THUMB_WIDTH = 400


def thumbnail(png: bytes, top: float, width: int = THUMB_WIDTH) -> bytes:
    """The index's thumbnail of a run's figure ``png``: its upper ``top`` fraction (the title and the
    position panel: the five panels of the whole figure are unreadable that small), scaled down to
    ``width`` pixels."""
    from io import BytesIO

    from PIL import Image

    with Image.open(BytesIO(png)) as im:
        im = im.convert("RGB")
        im = im.crop((0, 0, im.width, max(1, round(im.height * min(1.0, top)))))
        im.thumbnail((width, width), Image.Resampling.LANCZOS)
        out = BytesIO()
        im.save(out, format="PNG", optimize=True)
    return out.getvalue()


def _header(key: str) -> str:
    """A metric's name as a column header: code, which may wrap after an underscore (never inside a
    word: docs/assets/linsense.css keeps the words whole)."""
    return "<code>" + html.escape(key).replace("_", "_<wbr>") + "</code>"


def render(path: Path, rel: str) -> tuple[str, bytes, dict, bytes]:
    """Run the scenario at ``path``: its page (Markdown), its figure (PNG), its metrics and the
    figure's thumbnail (PNG)."""
    import linsense
    from linsense.io import split_timing
    from linsense.report.figures import png_bytes
    from linsense.report.sim_figures import DPI, sim_figure

    result = linsense.simulate(str(path))
    fig = sim_figure(result)  # (what sim_figure_png draws: its panels' places are known here)
    png = png_bytes(fig, DPI)
    # the figure above the first panel's tick labels: the title and the position
    thumb = thumbnail(png, 1.0 - fig.axes[0].get_position().y0 + 0.025)
    metrics, _timing = split_timing(result.metrics)
    name = path.stem
    text = path.read_text()
    rows = "\n".join(f"| `{k}` | {_cell(v)} |" for k, v in metrics.items())
    page = f"""# {name}

{_description(text)}

![The run of {name}: position, estimation error, currents, HF current, force]({name}.png)

The run above was made while the site was built, by `linsense.simulate` on the scenario file below,
and drawn by `linsense.report.sim_figures.sim_figure`: what `linsense simulate {rel} --out DIR --plot`
writes as `sim.png`. The metrics are defined in [the simulator's guide](../simulator.md).

## Metrics

| metric | value |
|---|---|
{rows}

## The scenario file

```toml
{text.rstrip()}
```
"""
    return page, png, metrics, thumb


def on_files(files: Files, config) -> Files:
    """Run every scenario and add its page and figure, and the gallery's index, to the site."""
    root = _root(config)
    paths = scenario_files(root)
    t0, c0 = time.perf_counter(), time.process_time()
    index_rows = []
    for path in paths:
        # (the command a reader types: a scenario the package ships is named, a file of the clone is a path)
        packaged = "src/linsense/" in path.relative_to(root).as_posix()
        rel = path.stem if packaged else path.relative_to(root).as_posix()
        page, png, metrics, thumb = render(path, rel)
        files.append(File.generated(config, f"gallery/{path.stem}.md", content=page))
        files.append(File.generated(config, f"gallery/{path.stem}.png", content=png))
        files.append(File.generated(config, f"gallery/thumbs/{path.stem}.png", content=thumb))
        cells = " | ".join(_cell(metrics.get(k)) for k in SUMMARY_KEYS)
        img = f"![The position in the run of {path.stem}](thumbs/{path.stem}.png){{ .gallery-thumb }}"
        index_rows.append(f"| [{img} {path.stem}]({path.stem}.md) | {cells} |")
    head = " | ".join(_header(k) for k in SUMMARY_KEYS)
    index = f"""# Gallery

Every example scenario (`{paths[0].parent.relative_to(root).as_posix()}/`), run by the simulator while
this site was built, each with its figure (click a thumbnail) and its metrics. Run one yourself with
`linsense simulate FILE.toml --out DIR --plot` (the [simulator's guide](../simulator.md) describes the
scenario keys, the outputs and the metrics).

| scenario | {head} |
|---|{"---|" * len(SUMMARY_KEYS)}
{chr(10).join(index_rows)}
"""
    files.append(File.generated(config, INDEX, content=index))
    log.info("gallery: %d scenarios run in %.1f s (%.1f s CPU)", len(paths), time.perf_counter() - t0,
             time.process_time() - c0)
    return files
