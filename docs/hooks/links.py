"""mkdocs hook: a guide's mention of another page, ``docs/simulator.md``, made a link in the site.

The guides name each other by path in plain text ("see docs/theory.md, section 5"), which reads well
in a clone and in a terminal. In the site the hook turns each such mention outside code (fenced
blocks and inline code are left alone) into a link to that page, ``[docs/theory.md](theory.md)``,
relative to the page it is on; a mention of a page that does not exist is a warning (which fails
the strict build). The Markdown files are not changed.
"""

from __future__ import annotations

import logging
import posixpath
import re

log = logging.getLogger("mkdocs.hooks.links")

_FENCE = re.compile(r"^[ \t]*(```|~~~).*?^[ \t]*\1[ \t]*$", re.M | re.S)
_CODE = re.compile(r"(`+).+?\1", re.S)
# (not a link's text or target already: "[docs/x.md](...)", "](docs/x.md)")
_MENTION = re.compile(r"(?<![\[/\w`.-])(?<!\]\()docs/([a-z0-9_-]+)\.md\b(?!\]\()")


def _outside(text: str, pattern: re.Pattern, fn) -> str:
    """``fn`` applied to the parts of ``text`` that ``pattern`` does not match."""
    out, pos = [], 0
    for m in pattern.finditer(text):
        out += [fn(text[pos:m.start()]), m[0]]
        pos = m.end()
    return "".join(out + [fn(text[pos:])])


def on_page_markdown(markdown: str, page, config, files) -> str:
    """Link every ``docs/NAME.md`` of the page's prose to the page ``NAME.md``."""
    here = posixpath.dirname(page.file.src_uri)
    pages = {f.src_uri for f in files.documentation_pages()}

    def link(m: re.Match) -> str:
        target = f"{m[1]}.md"
        if target not in pages:
            log.warning("%s: %s names no page of the site", page.file.src_uri, m[0])
            return m[0]
        return f"[{m[0]}]({posixpath.relpath(target, here or '.')})"

    def prose(text: str) -> str:
        return _MENTION.sub(link, text)

    return _outside(markdown, _FENCE, lambda t: _outside(t, _CODE, prose))
