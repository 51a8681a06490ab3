"""The docs site (mkdocs.yml).

The site is built strictly (warnings are errors) by ``make docs-build``, which ``make test`` runs
before pytest; the ``site`` fixture reuses that build when it is newer than every input (docs/,
mkdocs.yml, the package's sources and examples) and builds it again otherwise, so that these tests
never judge a stale site. Checked here: the site's base URL is the package's ``DOCS_URL``; every
README link into the site names a page (and anchor) that the build made; the generated parts are
there (the gallery's runs, the executed notebooks, an API page per package); then every page of
the site, and the report of ``linsense reproduce --quick``, opened in headless Chromium (Debian's
package, driven by playwright, which never downloads a browser of its own here): no console
error, no failed request, every internal link resolving (HTTP 200 and its anchor present), every
image loaded (``naturalWidth > 0``). Screenshots of the home page and of the report are kept in
build/site-screenshots/.
"""

from __future__ import annotations

import os
import re
import shutil
import socket
import subprocess
import sys
import time
import urllib.error
import urllib.request
from contextlib import contextmanager
from html.parser import HTMLParser
from pathlib import Path
from urllib.parse import unquote, urldefrag, urlparse

import pytest

import doclinks
from linsense.version import DOCS_URL

ROOT = Path(__file__).resolve().parents[1]
SITE = ROOT / "build" / "site"
#: written after a strict build succeeded (by ``make docs-build`` and by the ``site`` fixture)
STAMP = SITE / ".strict-ok"
SHOTS = ROOT / "build" / "site-screenshots"
PACKAGES = ("model", "analysis", "compensation", "scenario", "tune", "sim", "studies", "identify", "fea",
            "verify", "sweep", "firmware", "report", "reproduce")
#: the notebooks and the figures each draws (their outputs exist only in the built site)
NOTEBOOKS = {"lut_to_firmware": 2, "your_motor": 1, "identify_bench": 2}
FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync"]


def _needed(what: str, hint: str):
    """A tool the site needs is missing: a failure in CI (which installs it), else a skip."""
    if os.environ.get("CI"):
        pytest.fail(f"{what} not found: {hint}")
    pytest.skip(f"{what} not installed ({hint})")


def _inputs() -> list[Path]:
    files = [ROOT / "mkdocs.yml"]
    for d, pattern in ((ROOT / "docs", "*"), (ROOT / "src" / "linsense", "*")):
        if d.is_dir():
            files += [p for p in d.rglob(pattern) if p.is_file() and "__pycache__" not in p.parts]
    return files


def _fresh() -> bool:
    return STAMP.is_file() and STAMP.stat().st_mtime >= max(p.stat().st_mtime for p in _inputs())


def build_site() -> None:
    """``mkdocs build --strict`` into build/site (the command of ``make docs-build``), then the stamp."""
    env = {**os.environ, "NO_MKDOCS_2_WARNING": "1"}
    p = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict"], cwd=ROOT, env=env,
                       capture_output=True, text=True, timeout=900)
    assert p.returncode == 0, (p.stdout + p.stderr)[-4000:]
    STAMP.touch()


@pytest.fixture(scope="module")
def site() -> Path:
    try:
        import mkdocs  # noqa: F401
    except ImportError:
        _needed("mkdocs", "the docs extra: pip install -e '.[dev,docs]', as make install does")
    if not _fresh():
        build_site()
    return SITE


class _Ids(HTMLParser):
    def __init__(self):
        super().__init__()
        self.ids: set[str] = set()

    def handle_starttag(self, tag, attrs):
        for k, v in attrs:
            if k in ("id", "name") and v:
                self.ids.add(v)


def _ids(html: str) -> set[str]:
    p = _Ids()
    p.feed(html)
    return p.ids


def site_file(site: Path, url: str) -> Path:
    """The file of the built site that the address ``url`` (under DOCS_URL, no fragment) serves."""
    rel = url[len(DOCS_URL.rstrip("/")):].lstrip("/")
    path = site / rel
    return path / "index.html" if rel == "" or rel.endswith("/") or path.is_dir() else path


# ------------------------------------------------------------------------------- the site's build


def test_api_reference_has_every_package():
    """The API reference has a page for each package of the layers (docs/hooks/api.py's PACKAGES):
    linsense.verify, which holds ``tune(motor, ...) -> TuneResult``, had none."""
    sys.path.insert(0, str(ROOT / "docs" / "hooks"))
    try:
        import api
    finally:
        sys.path.pop(0)
    src = ROOT / "src" / "linsense"
    packages = {p.name for p in src.iterdir() if (p / "__init__.py").is_file()} - {"cli", "examples"}
    assert set(api.PACKAGES) == packages and set(PACKAGES) == packages
    assert len(api.PACKAGES) == len(packages)


def test_site_url_is_the_packages_docs_url():
    text = (ROOT / "mkdocs.yml").read_text()
    (url,) = re.findall(r"^site_url:\s*(\S+)\s*$", text, re.M)
    assert url.rstrip("/") == DOCS_URL.rstrip("/")
    assert re.findall(r"^strict:\s*(\S+)\s*$", text, re.M) == ["true"]


def test_readme_links_into_the_site_resolve(site):
    """The README links the guides as Markdown pages of the repository (``docs/NAME.md#anchor``:
    they render where the repository is read, the site is not published): each names a
    page that the site built, and an anchor of it there, so that the same link holds in both."""
    links = [u for u in doclinks.links((ROOT / "README.md").read_text())
             if re.fullmatch(r"docs/[\w-]+\.md(#[\w-]+)?", u)]
    assert len(links) >= 10, links
    missing = []
    for link in links:
        path, frag = urldefrag(link)
        f = site / path.removeprefix("docs/").removesuffix(".md") / "index.html"
        if not f.is_file():
            missing.append(f"{link}: no {f.relative_to(site)}")
        elif frag and unquote(frag) not in _ids(f.read_text()):
            missing.append(f"{link}: no anchor #{frag} in {f.relative_to(site)}")
    assert not missing, missing
    assert not doclinks.placeholder_links((ROOT / "README.md").read_text())


def test_help_texts_link_pages_of_the_site(site):
    """Every ``docs(page[, anchor])`` of the package's sources (linsense.version.docs: the links of
    the help texts and messages) names a page, and anchor, that the build made."""
    calls = set()
    for f in (ROOT / "src" / "linsense").rglob("*.py"):
        calls |= set(re.findall(r"""\bdocs\(\s*["']([^"']*)["'](?:\s*,\s*["']([^"']*)["'])?\s*\)""",
                                f.read_text()))
    if not calls:
        pytest.skip("no help text links the docs site (linsense.version.docs is not called)")
    bad = []
    for page, anchor in sorted(calls):
        f = site_file(site, f"{DOCS_URL.rstrip('/')}/{page}/")
        if not f.is_file():
            bad.append(f"docs({page!r}): no {f.relative_to(site)}")
        elif anchor and anchor not in _ids(f.read_text()):
            bad.append(f"docs({page!r}, {anchor!r}): no such anchor")
    assert not bad, bad


def test_notebooks_are_stored_without_outputs():
    """The notebooks are executed when the site is built; the repository keeps their source only."""
    import json

    found = sorted((ROOT / "docs" / "notebooks").glob("*.ipynb"))
    assert [p.stem for p in found] == sorted(NOTEBOOKS)
    for path in found:
        nb = json.loads(path.read_text())
        code = [c for c in nb["cells"] if c["cell_type"] == "code"]
        assert code and all(c["outputs"] == [] and c["execution_count"] is None for c in code), path.name


def test_readme_picture_is_committed():
    imgs = re.findall(r"!\[[^\]]*\]\(([^)\s]+)", (ROOT / "README.md").read_text())
    assert imgs, "the README shows no picture"
    for src in imgs:
        if src.startswith(DOCS_URL):
            continue  # (checked against the built site by test_readme_links_into_the_site_resolve)
        assert (ROOT / src).is_file() and src.startswith("docs/img/"), src


def test_generated_parts_are_in_the_site(site):
    sys.path.insert(0, str(ROOT / "docs" / "hooks"))
    try:
        import gallery
    finally:
        sys.path.pop(0)
    scenarios = gallery.scenario_files(ROOT)
    assert scenarios
    index = (site / "gallery" / "index.html").read_text()
    for path in scenarios:
        page = (site / "gallery" / path.stem / "index.html").read_text()
        assert f'src="../{path.stem}.png"' in page, path.stem
        figure = (site / "gallery" / f"{path.stem}.png").stat().st_size
        assert figure > 10_000
        assert "max_abs_err_deg" in page and f"{path.stem}/" in index
        # the index's thumbnail of the figure (the index had none before this check)
        thumb = site / "gallery" / "thumbs" / f"{path.stem}.png"
        assert f'src="thumbs/{path.stem}.png"' in index and 2_000 < thumb.stat().st_size < figure, path.stem
    # the index's headers are the metrics' names, which wrap at an underscore only (docs/assets/linsense.css)
    assert "<code>max_<wbr>abs_<wbr>err_<wbr>deg</code>" in index
    for name, figures in NOTEBOOKS.items():
        page = (site / "notebooks" / name / "index.html").read_text()
        assert page.count("data:image/png;base64,") >= figures, name  # (executed: its outputs are there)
        assert "Traceback" not in page, name
    for pkg in PACKAGES:
        page = (site / "api" / pkg / "index.html").read_text()
        assert page.count('class="doc doc-heading"') >= 3, pkg  # (modules and members rendered)


def _display_equations(page: Path) -> int:
    """The ``$$ ... $$`` blocks of a Markdown page (outside its fenced code)."""
    text = re.sub(r"^[ \t]*```.*?^[ \t]*```", "", page.read_text(), flags=re.M | re.S)
    return len(re.findall(r"^[ \t]*\$\$[ \t]*$", text, re.M)) // 2


def test_the_site_serves_its_equations_itself(site):
    """The equations of docs/ (``$$...$$``, pymdownx.arithmatex) are in the pages as ``.arithmatex``
    elements, none left as raw ``$$`` in the HTML, and KaTeX's script, style sheet and fonts are
    files of the site (docs/hooks/katex.py): no page loads a script, style sheet or font from
    another host (the browser check below sees them typeset)."""
    pages = {p.stem: _display_equations(p) for p in (ROOT / "docs").glob("*.md")}
    assert pages["theory"] >= 20 and pages["identify"] >= 3, pages
    for name, n in pages.items():
        if not n:
            continue
        html = (site / name / "index.html").read_text()
        assert html.count('<div class="arithmatex">') == n, name
        outside = re.sub(r'<(div|span) class="arithmatex">.*?</\1>|<pre.*?</pre>|<code.*?</code>', "", html,
                         flags=re.S)
        assert "$$" not in outside, name
    katex = site / "assets" / "katex"
    assert (katex / "katex.min.js").stat().st_size > 100_000 and (katex / "katex.min.css").is_file()
    fonts = re.findall(r"url\(([^)]+)\)", (katex / "katex.min.css").read_text())
    assert fonts and all((katex / f).is_file() for f in fonts)
    for html_file in site.rglob("*.html"):
        html = html_file.read_text()
        remote = re.findall(r"""<(?:script|img|iframe)\b[^>]*\bsrc=["']((?:https?:)?//[^"']+)""", html)
        remote += re.findall(r"""<link\b[^>]*\bhref=["']((?:https?:)?//[^"']+)["'][^>]*>""", html)
        remote = [u for u in remote if not re.search(r"rel=.canonical", html.split(u)[0][-200:])]
        assert not remote, (html_file.relative_to(site), remote)


# -------------------------------------------------------------------------------- in the browser


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@contextmanager
def served(directory: Path):
    """``python -m http.server`` on a free port of localhost for ``directory``: its base URL."""
    port = _free_port()
    proc = subprocess.Popen([sys.executable, "-m", "http.server", str(port), "--bind", "127.0.0.1",
                             "--directory", str(directory)], stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)
    base = f"http://127.0.0.1:{port}/"
    try:
        for _ in range(200):
            try:
                urllib.request.urlopen(base, timeout=2).close()
                break
            except (urllib.error.URLError, ConnectionError):
                if proc.poll() is not None:
                    raise RuntimeError(f"http.server exited with {proc.returncode}") from None
                time.sleep(0.05)
        else:
            raise RuntimeError("http.server did not answer")
        yield base
    finally:
        proc.terminate()
        proc.wait(timeout=10)


@pytest.fixture(scope="module")
def report_run(tmp_path_factory):
    """``linsense reproduce --quick`` (about 11 s of CPU), started when the browser check of the site
    begins so that it runs meanwhile: (process, its output folder)."""
    out = tmp_path_factory.mktemp("report") / "out"
    proc = subprocess.Popen([sys.executable, "-m", "linsense", "reproduce", "--quick", "--out", str(out)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    yield proc, out
    if proc.poll() is None:
        proc.kill()
        proc.wait()


@pytest.fixture(scope="module")
def browser(tmp_path_factory):
    """A headless Chromium (Debian's) with a fresh profile, driven by playwright."""
    exe = shutil.which("chromium") or shutil.which("chromium-browser")
    if exe is None:
        _needed("chromium", "the Debian package chromium: .ci/run and make tools install it as root")
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        _needed("playwright", "the docs extra: pip install -e '.[dev,docs]', as make install does")
    pw = sync_playwright().start()
    ctx = pw.chromium.launch_persistent_context(
        str(tmp_path_factory.mktemp("chromium-profile")), executable_path=exe, headless=True,
        args=FLAGS[1:], viewport={"width": WIDTH, "height": 900})
    try:
        yield ctx
    finally:
        ctx.close()
        pw.stop()


#: the width at which the pages are checked for horizontal overflow (code blocks were cut
#: off at 1400 px before this check)
WIDTH = 1400

#: run in each page once it has loaded (tests/site_layout.js): what overflows horizontally (the page,
#: a code block, a table, an equation: scrollWidth beyond clientWidth), every word of a heading or
#: table header that the layout broke across two lines, and the equations: typeset by KaTeX or raw
LAYOUT_JS = "\n".join(ln for ln in (ROOT / "tests" / "site_layout.js").read_text().splitlines()
                      if not ln.startswith("//"))


class Visit:
    """What one page showed in the browser."""

    def __init__(self, url: str):
        self.url = url
        self.problems: list[str] = []
        self.links: list[str] = []
        self.ids: set[str] = set()
        self.images: list[tuple[str, bool, int]] = []
        self.layout: dict = {}


def visit(ctx, url: str, screenshot: Path | None = None, full_page: bool = True) -> Visit:
    """Open ``url`` in a new tab, wait until the network is idle and collect the console errors, the
    failed requests and responses, the links, the ids and the images."""
    v = Visit(url)
    page = ctx.new_page()
    page.on("console", lambda m: v.problems.append(f"console {m.type}: {m.text} ({m.location.get('url')})")
            if m.type == "error" else None)
    page.on("pageerror", lambda e: v.problems.append(f"script error: {e}"))
    page.on("requestfailed", lambda r: v.problems.append(f"request failed: {r.url} ({r.failure})"))
    page.on("response", lambda r: v.problems.append(f"HTTP {r.status}: {r.url}") if r.status >= 400 else None)
    try:
        resp = page.goto(url, wait_until="networkidle", timeout=60_000)
        if not url.startswith("file:") and (resp is None or resp.status != 200):
            v.problems.append(f"HTTP {resp.status if resp else 'no response'}: {url}")
        v.links = page.eval_on_selector_all("a[href]", "els => els.map(e => e.href)")
        v.ids = set(page.evaluate("() => Array.from(document.querySelectorAll('[id],[name]'))"
                                  ".map(e => e.id || e.getAttribute('name'))"))
        # every image: scrolled into view first, so that a lazy one loads too
        page.evaluate("() => window.scrollTo(0, document.body.scrollHeight)")
        page.wait_for_function("() => Array.from(document.images).every(i => i.complete)", timeout=30_000)
        v.images = [tuple(x) for x in page.eval_on_selector_all(
            "img", "els => els.map(e => [e.currentSrc || e.src, e.complete, e.naturalWidth])")]
        v.problems += [f"image not rendered: {src[:100]}" for src, done, w in v.images
                       if not (done and w > 0)]
        page.evaluate("() => window.scrollTo(0, 0)")
        v.layout = page.evaluate(LAYOUT_JS)
        v.problems += [f"overflows at {WIDTH} px: {x}" for x in v.layout["overflow"]]
        v.problems += [f"a word broken across lines: {x}" for x in v.layout["broken"]]
        v.problems += [f"equation not typeset: {x}" for x in v.layout["raw"]]
        if v.layout["dollars"]:
            v.problems.append(f"{v.layout['dollars']} raw equation delimiters ($$, \\[, \\() in the text")
        if screenshot is not None:
            page.evaluate("() => window.scrollTo(0, 0)")
            screenshot.parent.mkdir(parents=True, exist_ok=True)
            page.screenshot(path=str(screenshot), full_page=full_page)
    finally:
        page.close()
    return v


def _status(url: str) -> int:
    try:
        with urllib.request.urlopen(url, timeout=10) as r:
            return r.status
    except urllib.error.HTTPError as e:
        return e.code


def crawl(ctx, start: str, screenshot: Path | None = None) -> tuple[dict[str, Visit], list[str]]:
    """Every page reachable from ``start`` by links under it, each opened by :func:`visit`; then
    every internal link checked: HTTP 200, and its anchor present in the page it points to.
    Returns the visits and the problems."""
    visits: dict[str, Visit] = {}
    queue = [start]
    statuses: dict[str, int] = {}
    while queue:
        url = queue.pop(0)
        if url in visits:
            continue
        visits[url] = visit(ctx, url, screenshot if url == start else None)
        for link in visits[url].links:
            target, _ = urldefrag(link)
            if not target.startswith(start):
                continue  # (another site: never requested, the network is closed)
            path = urlparse(target).path
            if path.endswith("/") or path.endswith(".html"):
                if target not in visits:
                    queue.append(target)
            elif target not in statuses:
                statuses[target] = _status(target)
    problems = [f"{u}: {p}" for u, v in visits.items() for p in v.problems]
    problems += [f"link to {u}: HTTP {s}" for u, s in statuses.items() if s != 200]
    for u, v in visits.items():
        for link in v.links:
            target, frag = urldefrag(link)
            if not target.startswith(start) or not frag:
                continue
            ids = visits[target].ids if target in visits else set()
            if unquote(frag) not in ids:
                problems.append(f"{u}: link to {link}: no anchor #{frag} there")
    return visits, problems


@pytest.mark.slow
def test_every_page_of_the_site_in_chromium(site, browser, report_run):
    """Every page at 1400 px (:data:`WIDTH`): no console error, failed request, broken link or
    anchor, image not rendered; nothing overflowing horizontally (the page, a code block, a table,
    an equation), no word of a heading or table header broken across two lines, every equation
    typeset and no raw ``$$`` left (:data:`LAYOUT_JS`)."""
    with served(site) as base:
        visits, problems = crawl(browser, base, screenshot=SHOTS / "home.png")
    assert not problems, "\n".join(problems[:40])
    pages = {urlparse(u).path for u in visits}
    for must in ["/", "/theory/", "/cli/", "/gallery/", "/api/", *(f"/api/{p}/" for p in PACKAGES),
                 *(f"/notebooks/{n}/" for n in NOTEBOOKS)]:
        assert must in pages, must
    # every page the build made was reached by links from the home page, and so checked
    built = {"/" + p.parent.relative_to(site).as_posix() + "/" for p in site.rglob("index.html")}
    assert {p.replace("/./", "/") for p in built} == pages
    figures = [src for v in visits.values() for src, _, w in v.images if "/gallery/" in src and w > 0]
    pngs = list((site / "gallery").glob("*.png")) + list((site / "gallery").glob("thumbs/*.png"))
    assert len(set(figures)) == len(pngs)  # (every figure and thumbnail shown)
    assert (SHOTS / "home.png").stat().st_size > 20_000
    # the equations typeset by KaTeX, every one (LAYOUT_JS; before this check, plain text in code blocks)
    for name in ("theory", "identify", "fea"):
        layout = visits[f"{base}{name}/"].layout
        blocks = _display_equations(ROOT / "docs" / f"{name}.md")
        assert layout["typeset"] == layout["equations"] >= blocks > 0, (name, layout)


@pytest.mark.slow
def test_the_report_in_chromium(browser, report_run):
    """The report as its reader opens it, a file (out/report.html of ``make demo``; here the quick
    run's): no console error or failed request, every image rendered, every link to a file beside
    it (figures, scenarios) naming one, every anchor present."""
    proc, out = report_run
    _, stderr = proc.communicate(timeout=600)
    assert proc.returncode == 0, stderr[-3000:]
    page = out / "report.html"
    html = page.read_text()
    v = visit(browser, page.as_uri(), screenshot=SHOTS / "report.png", full_page=False)
    assert not v.problems, v.problems
    files = [urldefrag(link)[0] for link in v.links if link.startswith("file:")]
    assert len(files) >= 10  # (the report links its scenarios and figures)
    assert [f for f in files if not Path(unquote(urlparse(f).path)).is_file()] == []
    for link in v.links:
        target, frag = urldefrag(link)
        if target == page.as_uri() and frag:
            assert unquote(frag) in v.ids, link
    assert len(v.images) == html.count("<img") >= 14
    assert (SHOTS / "report.png").stat().st_size > 20_000
