"""mkdocs hook: KaTeX served by the site itself (no CDN, no network when the site is read).

The pages write their equations as ``$...$`` and ``$$...$$``; ``pymdownx.arithmatex`` (generic
mode, ``mkdocs.yml``) wraps them in ``.arithmatex`` elements, and ``docs/assets/katex-render.js``
typesets them with KaTeX in the browser. KaTeX comes from the machine that builds the site: Debian's
``libjs-katex`` (``/usr/share/javascript/katex``, with the fonts of ``fonts-katex``; ``make
docs-tools`` installs it as root, ``KATEX_DIR`` names another copy of a KaTeX 0.16 distribution).
The hook copies its script, its style sheet and every font the style sheet names into the site
under ``assets/katex/``; without them the build stops, naming the package.
"""

from __future__ import annotations

import logging
import os
import re
from pathlib import Path

from mkdocs.exceptions import PluginError
from mkdocs.structure.files import File, Files

log = logging.getLogger("mkdocs.hooks.katex")

#: where Debian's libjs-katex puts KaTeX (the Makefile's KATEX_DIR overrides it)
DEFAULT_DIR = "/usr/share/javascript/katex"
#: the site's folder for KaTeX's files (mkdocs.yml's extra_javascript and extra_css name them)
DEST = "assets/katex"
FILES = ("katex.min.js", "katex.min.css")


def katex_dir() -> Path:
    """The KaTeX distribution to serve: ``$KATEX_DIR`` or Debian's."""
    return Path(os.environ.get("KATEX_DIR") or DEFAULT_DIR)


def assets(src: Path) -> dict[str, Path]:
    """The files to copy, by their path under :data:`DEST`: the script, the style sheet and every
    font that the style sheet names (``url(fonts/...)``)."""
    missing = [f for f in FILES if not (src / f).is_file()]
    if missing:
        raise PluginError(f"KaTeX not found: no {', '.join(missing)} in {src} (the docs site typesets its "
                          f"equations with it: install Debian's libjs-katex, which make docs-tools does as "
                          f"root, or set KATEX_DIR to a KaTeX 0.16 distribution)")
    out = {f: src / f for f in FILES}
    css = (src / "katex.min.css").read_text(encoding="utf-8")
    for url in sorted(set(re.findall(r"url\(\s*['\"]?([^'\")]+)['\"]?\s*\)", css))):
        path = src / url
        if not path.is_file():
            raise PluginError(f"KaTeX's style sheet names {url}, which {src} does not have "
                              f"(Debian: the package fonts-katex)")
        out[url] = path
    return out


def on_files(files: Files, config) -> Files:
    """Add KaTeX's files to the site (read through symbolic links: Debian's are links)."""
    found = assets(katex_dir())
    for rel, path in found.items():
        files.append(File.generated(config, f"{DEST}/{rel}", content=path.read_bytes()))
    log.info("katex: %d files from %s", len(found), katex_dir())
    return files
