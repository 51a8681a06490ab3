"""linsense's version, in the lowest layer so that any module can name it (``linsense.__version__``
re-exports it; the package itself imports from the layers above)."""

__version__ = "0.1.0"

#: the documentation site's address (mkdocs, built from docs/*.md: ``docs/simulator.md`` is
#: ``{DOCS_URL}/simulator/``); every help text links here. A placeholder (a reserved example
#: domain) until the site is published: change it here alone.
DOCS_URL = "https://linsense.example.org"


def docs(page: str, anchor: str = "") -> str:
    """The address of a page of the docs site.

    Parameters
    ----------
    page : str
        The page, e.g. ``"simulator"`` for docs/simulator.md.
    anchor : str, optional
        A ``#anchor`` in it.

    Returns
    -------
    str
        The URL.
    """
    return f"{DOCS_URL}/{page}/" + (f"#{anchor}" if anchor else "")
