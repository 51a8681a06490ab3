"""The links of the project's Markdown (README.md, docs/*.md), read as the places that render them
do: a link is ``[text](target)`` or ``![alt](target)`` outside code (fenced blocks, inline code); an
anchor is a heading's slug, as GitHub makes it (where the repository is read) and as the docs
site's toc makes it (mkdocs, Python-Markdown's ``slugify``), or an explicit ``id="..."``.

Used by tests/hostile/test_hostile_first_hour.py (every relative link names a file and heading
that exist, none goes to a placeholder domain) and tests/test_site.py.
"""

from __future__ import annotations

import re
import unicodedata
from pathlib import Path
from urllib.parse import unquote, urlparse

ROOT = Path(__file__).resolve().parents[1]

#: the pages of docs/ that the site's hooks generate at build time (docs/hooks/gallery.py,
#: docs/hooks/api.py): a link into them is checked by the strict site build, not here
GENERATED = ("gallery/", "api/")

#: hosts reserved for examples and tests (RFC 2606): a link there resolves nowhere
PLACEHOLDER = re.compile(r"(^|\.)(example\.(org|com|net)|example|test|invalid)$", re.I)

_FENCE = re.compile(r"^[ \t]*(```|~~~).*?^[ \t]*\1[ \t]*$", re.M | re.S)
_INDENTED = re.compile(r"(?:(?<=\n\n)|\A)(?:(?: {4}|\t).*(?:\n|\Z))+")
_CODE = re.compile(r"(`+).+?\1", re.S)
_LINK = re.compile(r"!?\[(?:[^\[\]]|\[[^\]]*\])*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
_AUTOLINK = re.compile(r"<(https?://[^>\s]+)>|(?<![(<\"'])\bhttps?://[^\s)<>\]\"'`]+")
_HEADING = re.compile(r"^(#{1,6})[ \t]+(.+?)[ \t#]*$", re.M)
_ID = re.compile(r"""\bid=["']([^"']+)["']""")


def prose(text: str) -> str:
    """``text`` without its code: fenced and indented blocks and inline code blanked out."""
    text = _FENCE.sub("", text)
    text = _INDENTED.sub("", text)
    return _CODE.sub("", text)


def links(text: str) -> list[str]:
    """Every link target of the Markdown ``text`` outside code, in order: ``[..](target)``,
    ``![..](target)``, ``<https://...>`` and bare addresses."""
    body = prose(text)
    found = [m[1] for m in _LINK.finditer(body)]
    found += [m[1] or m[0] for m in _AUTOLINK.finditer(_LINK.sub("", body))]
    return found


def placeholder_links(text: str) -> list[str]:
    """The links of ``text`` (code included: a command line's address is read too) whose host is a
    reserved example name."""
    urls = [m[1] or m[0] for m in _AUTOLINK.finditer(text)] + links(text)
    return sorted({u for u in urls if urlparse(u).hostname and PLACEHOLDER.search(urlparse(u).hostname)})


def _heading_text(raw: str) -> str:
    """A heading's text as rendered: link text kept, code's backticks and emphasis marks dropped,
    an attribute list (``{#id}``) removed."""
    raw = re.sub(r"\s*\{[^}]*\}\s*$", "", raw)
    raw = re.sub(r"!?\[([^\]]*)\]\([^)]*\)", r"\1", raw)
    raw = raw.replace("`", "")
    return re.sub(r"(\*{1,3})(.+?)\1", r"\2", raw)


def slug_github(title: str) -> str:
    """GitHub's anchor of a heading: lower case, every character but letters, digits, ``_``, ``-``
    and spaces dropped, each space a hyphen."""
    s = title.strip().lower()
    s = "".join(c for c in s if c.isalnum() or c in "_- ")
    return s.replace(" ", "-")


def slug_mkdocs(title: str) -> str:
    """The docs site's anchor (Python-Markdown's ``toc.slugify``): ASCII, ``[^\\w\\s-]`` dropped,
    runs of spaces and hyphens one hyphen."""
    s = unicodedata.normalize("NFKD", title).encode("ascii", "ignore").decode("ascii")
    s = re.sub(r"[^\w\s-]", "", s).strip().lower()
    return re.sub(r"[-\s]+", "-", s)


def anchors(text: str) -> tuple[set[str], set[str]]:
    """The anchors of a Markdown page: (GitHub's, the site's), each with the explicit ids."""
    ids = set(_ID.findall(prose(text)))
    gh: set[str] = set(ids)
    mk: set[str] = set(ids)
    seen_gh: dict[str, int] = {}
    seen_mk: dict[str, int] = {}
    for m in _HEADING.finditer(_FENCE.sub("", text)):
        explicit = re.search(r"\{[^}]*#([\w-]+)[^}]*\}\s*$", m[2])
        title = _heading_text(m[2])
        for slug, seen, out, sep in ((slug_github(title), seen_gh, gh, "-"),
                                     (slug_mkdocs(title), seen_mk, mk, "_")):
            n = seen.get(slug, 0)
            seen[slug] = n + 1
            out.add(slug if n == 0 else f"{slug}{sep}{n}")
        if explicit:
            mk.add(explicit[1])
    return gh, mk


def broken_links(page: Path, root: Path = ROOT) -> list[str]:
    """The relative links of the Markdown file ``page`` that name no file of the repository, or a
    heading its target does not have (under GitHub's slugs and the site's alike). Links into the
    pages the site generates (:data:`GENERATED`) are left to the site's strict build."""
    text = page.read_text(encoding="utf-8")
    bad = []
    docs = root / "docs"
    for link in links(text):
        url = urlparse(link)
        if url.scheme or link.startswith("//") or url.netloc:
            continue
        path, frag = unquote(url.path), unquote(url.fragment)
        if not path:
            target = page
        else:
            target = (page.parent / path).resolve()
            if target.is_relative_to(docs) and target.relative_to(docs).as_posix().startswith(GENERATED):
                continue
            if not target.is_relative_to(root.resolve()):
                bad.append(f"{page.name}: {link}: outside the repository")
                continue
            if not target.exists():
                bad.append(f"{page.name}: {link}: no such file")
                continue
        if frag:
            if target.suffix != ".md":
                bad.append(f"{page.name}: {link}: an anchor into a file that is not Markdown")
                continue
            gh, mk = anchors(target.read_text(encoding="utf-8"))
            missing = [who for who, ids in (("GitHub", gh), ("the site", mk)) if frag not in ids]
            if missing:
                bad.append(f"{page.name}: {link}: no heading #{frag} in {target.name} "
                           f"(for {' and '.join(missing)})")
    return bad


def markdown_pages(root: Path = ROOT) -> list[Path]:
    """README.md and every Markdown page of docs/ (the site's hooks excluded)."""
    return [root / "README.md"] + sorted(p for p in (root / "docs").rglob("*.md") if "hooks" not in p.parts)
