"""mkdocs hook: the notebooks' links to the guides, made links of the site.

The notebooks (docs/notebooks/*.ipynb, rendered and executed by mkdocs-jupyter) link the guides as
files, ``[the theory](../theory.md)``, which works where a notebook is read as a file (Jupyter, a
repository browser). mkdocs-jupyter leaves those links as they are, so in the site they would point
to ``notebooks/theory.md``, which does not exist. This hook rewrites each link to a Markdown file of
the docs into the URL of its page, relative to the notebook's page; a link to a file that is not
a page of the site is reported as a warning (which fails the strict build).
"""

from __future__ import annotations

import logging
import posixpath
import re

log = logging.getLogger("mkdocs.hooks.notebooks")

_HREF = re.compile(r'href="(?![a-z][a-z0-9+.-]*:|#|/)([^"#]+\.md)(#[^"]*)?"')


def on_post_page(output: str, page, config) -> str:
    """Rewrite the ``.md`` links of a notebook's page."""
    src = page.file.src_uri
    if not src.endswith(".ipynb"):
        return output

    def fix(m: re.Match) -> str:
        target = posixpath.normpath(posixpath.join(posixpath.dirname(src), m[1]))
        f = _files.get_file_from_path(target) if _files is not None else None
        if f is None or not f.is_documentation_page():
            log.warning("%s: the link %r names no page of the site", src, m[1])
            return m[0]
        return f'href="{f.url_relative_to(page.file)}{m[2] or ""}"'

    return _HREF.sub(fix, output)


_files = None


def on_files(files, config):
    """Remember the site's files (the pages the links are resolved against)."""
    global _files
    _files = files
    return files
