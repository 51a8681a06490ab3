"""linsense's version, in the lowest layer so that any module can name it (``linsense.__version__``
re-exports it; the package itself imports from the layers above)."""

__version__ = "0.1.0"

#: the documentation site's address once it is published (mkdocs, built from docs/*.md:
#: ``docs/simulator.md`` becomes ``{DOCS_URL}/simulator/``; mkdocs.yml's ``site_url``). A placeholder
#: (a reserved example domain) until then: change it here and set :data:`SITE_PUBLISHED`.
DOCS_URL = "https://linsense.example.org"

#: whether :data:`DOCS_URL` serves the site: until it does, help texts and messages name the guide's
#: Markdown page in the source tree (``docs/simulator.md``, which the repository renders and ``make
#: docs`` serves), not an address that resolves nowhere
SITE_PUBLISHED = False


def docs(page: str, anchor: str = "") -> str:
    """Where a page of the documentation is read: the site's address once :data:`SITE_PUBLISHED`,
    else the guide's Markdown file in the source tree.

    Parameters
    ----------
    page : str
        The page, e.g. ``"simulator"`` for docs/simulator.md.
    anchor : str, optional
        A ``#anchor`` in it.

    Returns
    -------
    str
        The URL, or ``docs/PAGE.md[#anchor]``.
    """
    tail = f"#{anchor}" if anchor else ""
    if SITE_PUBLISHED:
        return f"{DOCS_URL}/{page}/{tail}"
    return f"docs/{page}.md{tail}"
