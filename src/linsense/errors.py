"""One exception hierarchy for everything linsense refuses to do.

The CLI turns any :class:`LinsenseError` into exit code 2 and the one-line ``str(err)``.
"""

from __future__ import annotations


class LinsenseError(Exception):
    """Base class of every error linsense raises on purpose."""


class InputError(LinsenseError):
    """Bad user input: names the file, the key (or row/column) and the offending value.

    Parameters
    ----------
    source : str
        The file (or preset, or option) the value came from.
    key : str
        Dotted key, column name or row reference inside ``source``; may be empty.
    message : str
        What is wrong, including the value.
    """

    def __init__(self, source: str, key: str, message: str) -> None:
        self.source = str(source)
        self.key = key
        self.message = message
        where = f"{self.source}: {key}" if key else self.source
        super().__init__(f"{where}: {message}")


class ModelError(LinsenseError):
    """A motor model that loads but cannot be used (not positive definite, no saliency...)."""

    def __init__(self, source: str, key: str, message: str) -> None:
        self.source = str(source)
        self.key = key
        where = f"{self.source}: {key}" if key else self.source
        super().__init__(f"{where}: {message}")


class OutputError(InputError):
    """An output (``--out``) that linsense refuses to write or replace, e.g. a folder holding
    files no linsense run wrote. Names the path and why."""

    def __init__(self, path, message: str) -> None:
        super().__init__(str(path), "", message)
