"""The self-contained HTML report of ``linsense reproduce`` (jinja2; figures embedded as data URIs,
no script, no network): one page with the paper's claims, the figures and the scenarios used."""

from __future__ import annotations

import base64
import math

from linsense._extras import require


def _fmt(v, nd: int = 2) -> str:
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "n/a"
    return f"{v:.{nd}f}"


def _absmax(values) -> float | None:
    vals = [abs(v) for v in values if v is not None and math.isfinite(v)]
    return max(vals) if vals else None


def render_report(metrics: dict, figures: dict[str, bytes], scenarios: dict) -> str:
    """The HTML page of a reproduction (``out/report.html``).

    Parameters
    ----------
    metrics : dict
        The reproduction's metrics (metrics.json's structure).
    figures : dict of str to bytes
        Relative path to PNG bytes, embedded.
    scenarios : dict
        Figure to variant to Scenario, linked as ``scenarios/<figure>_<variant>.toml``.

    Returns
    -------
    str
        The page.
    """
    from linsense.version import __version__

    require("jinja2", extra="report", feature="the HTML report")
    from jinja2 import Environment, PackageLoader, StrictUndefined
    from markupsafe import Markup, escape  # (jinja2's own dependency)

    def img(name: str, caption: str) -> Markup:
        data = figures.get(name)
        if data is None:  # (a figure the motor has not: Fig. 5 needs the parametric model)
            return Markup("")
        b64 = base64.b64encode(data).decode("ascii")
        return Markup(f'<figure><img src="data:image/png;base64,{b64}" alt="{escape(caption)}">'
                      f'<figcaption>{escape(caption)} <a href="{escape(name)}">PNG</a></figcaption></figure>')

    env = Environment(loader=PackageLoader("linsense.report", "templates"), autoescape=True,
                      undefined=StrictUndefined, trim_blocks=False)
    tpl = env.get_template("report.html.j2")
    held = sum(bool(c["holds"]) for c in metrics["claims"])
    held_beyond = sum(bool(c["holds"]) for c in metrics["claims_beyond"])
    return tpl.render(m=metrics, scenarios=scenarios, img=img, fmt=_fmt, absmax=_absmax, held=held,
                      held_beyond=held_beyond, version=__version__)
