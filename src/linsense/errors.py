"""One exception hierarchy for everything linsense refuses to do.

The CLI turns any :class:`LinsenseError` into exit code 2 and the one-line ``str(err)``.
"""

from __future__ import annotations

import re

#: a run of characters without a space longer than this in a message (a user's value, key or
#: section name: a 50 MB key gave a 50 MB line) is cut to its first MAX_SHOWN_CHARS
MAX_WORD_CHARS = 200
#: characters kept of a cut run, before an ellipsis and the run's length
MAX_SHOWN_CHARS = 80
#: characters of a key, and of a message, after which the rest is cut (values with spaces)
MAX_KEY_CHARS = 200
MAX_MESSAGE_CHARS = 1000
_LONG_WORD = re.compile(rf"\S{{{MAX_WORD_CHARS + 1},}}")
_LONG_QUOTED = re.compile(rf"'([^'\n]{{{MAX_WORD_CHARS - 1},}})'|\"([^\"\n]{{{MAX_WORD_CHARS - 1},}})\"")


def _cut(text: str, keep: int) -> str:
    return f"{text[:keep]}\u2026 ({len(text):,} characters)"


def _cut_quoted(m: re.Match) -> str:
    q, inner = ("'", m.group(1)) if m.group(1) is not None else ('"', m.group(2))
    return f"{q}{inner[:MAX_SHOWN_CHARS]}\u2026{q} ({len(inner):,} characters)"


def shown(value) -> str:
    """``repr`` of a user's value for a message or a comment, a numpy scalar as the plain Python number.

    ``360.0``, not ``np.float64(360.0)``.

    Parameters
    ----------
    value : object
        The value to show.

    Returns
    -------
    str
        ``repr(value)``, of ``value.item()`` for a 0-d numpy value.
    """
    item = getattr(value, "item", None)  # (numpy scalars; errors.py does not import numpy)
    return repr(item() if callable(item) and getattr(value, "ndim", None) == 0 else value)


def one_line(text: str) -> str:
    """``text`` with its line breaks written as ``\\n`` and ``\\r``: a message is one line, whatever
    the value in it (a file named ``"0\\n"`` made a refusal of two lines).

    Parameters
    ----------
    text : str
        The text.

    Returns
    -------
    str
        The text on one line.
    """
    return text.replace("\r", "\\r").replace("\n", "\\n")


def bounded(text: str, limit: int = MAX_MESSAGE_CHARS) -> str:
    """``text`` with every user value in it bounded, for a one-line message (docs/limits.md).

    A quoted value (``'...'`` or ``"..."``, as ``repr`` writes it) or a run without spaces longer
    than :data:`MAX_WORD_CHARS` becomes its first :data:`MAX_SHOWN_CHARS` characters, an ellipsis
    and its length; what is still longer than ``limit`` is cut there the same way. Every message
    of :class:`InputError` and :class:`ModelError` goes through it, so no message quotes a whole
    50 MB value.

    Parameters
    ----------
    text : str
        The message (anything else is passed through ``str``).
    limit : int, optional
        Characters after which the whole text is cut, default :data:`MAX_MESSAGE_CHARS`.

    Returns
    -------
    str
        The bounded text.
    """
    text = one_line(str(text))
    if len(text) > MAX_WORD_CHARS:
        text = _LONG_QUOTED.sub(_cut_quoted, text)
        text = _LONG_WORD.sub(lambda m: _cut(m.group(), MAX_SHOWN_CHARS), text)
    return _cut(text, limit) if len(text) > limit else text


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
        self.source = one_line(str(source))
        self.key = key = bounded(key, MAX_KEY_CHARS) if key else key
        self.message = message = bounded(message)
        where = f"{self.source}: {key}" if key else self.source
        super().__init__(f"{where}: {message}")


class ModelError(LinsenseError):
    """A motor model that loads but cannot be used (not positive definite, no saliency...).

    Parameters
    ----------
    source : str
        The motor file (or preset) the model came from.
    key : str
        Dotted key inside ``source`` at fault; may be empty.
    message : str
        What is wrong, including the value.
    """

    def __init__(self, source: str, key: str, message: str) -> None:
        self.source = one_line(str(source))
        self.key = key = bounded(key, MAX_KEY_CHARS) if key else key
        message = bounded(message)
        where = f"{self.source}: {key}" if key else self.source
        super().__init__(f"{where}: {message}")


class OutputError(InputError):
    """An output (``--out``) that linsense refuses to write or replace.

    E.g. a folder holding files no linsense run wrote. Names the path and why; an
    :class:`InputError` with the path as its source and an empty key.

    Parameters
    ----------
    path : str or os.PathLike
        The output refused.
    message : str
        Why.
    """

    def __init__(self, path, message: str) -> None:
        super().__init__(str(path), "", message)


class SimulationError(LinsenseError):
    """The C simulator refused its configuration or inputs."""


class ConfigError(LinsenseError):
    """A configuration refused by the C library's ``ls_<module>_init`` (non-zero ``ls_status``);
    the binding (:mod:`linsense.ctrl`) composes the message: the refusing C function, each offending
    field with its value and what the C library allows, the status.

    Parameters
    ----------
    module : str
        C module, e.g. ``"ls_inject"``.
    fields : dict
        The offending field(s) and their values (empty when no single field could be named).
    status : int
        The ``ls_status`` returned (``LS_ERR_NULL`` = 1, ``LS_ERR_PARAM`` = 2).
    message : str
        The whole message.
    """

    def __init__(self, module: str, fields: dict, status: int, message: str) -> None:
        self.module = module
        self.fields = dict(fields)
        self.status = int(status)
        super().__init__(bounded(message))  # (one line: a mode named "\n" made two)


class SaturationRangeError(LinsenseError, ValueError):
    """Saturation data the C plant cannot take (:mod:`linsense.model.saturation`).

    Also a ``ValueError`` (a value out of the model's range), as it was.

    Parameters
    ----------
    key : str
        The motor-file key at fault.
    message : str
        What is wrong, including the value.
    """

    def __init__(self, key: str, message: str) -> None:
        super().__init__(message)
        self.key = key


class KeyProblem(LinsenseError, ValueError):
    """Raised inside a pydantic validator to name the offending sub-key of the section it checks;
    :func:`linsense.validation.to_input_error` turns it into an :class:`InputError` (pydantic takes
    only a ``ValueError`` from a validator, hence the second base).

    Parameters
    ----------
    key : str
        The key, relative to the section (dotted for deeper keys).
    message : str
        What is wrong, including the value.
    """

    def __init__(self, key: str, message: str) -> None:
        self.key = key
        self.message = message
        super().__init__(message)


class MissingExtraError(LinsenseError, ImportError):
    """A feature whose optional dependencies (a pip extra of linsense) are not installed; raised by
    :func:`linsense._extras.require`. The message is one line naming the feature, the missing
    module and the command that installs the extra. Also an ``ImportError`` (a module that cannot be
    imported), so that code testing for a module with ``except ImportError`` keeps working.

    Parameters
    ----------
    feature : str
        What needs the module, e.g. ``"the Parquet trace"``.
    modules : tuple of str
        The missing (or failing) modules.
    extras : tuple of str
        The extras that bring them, e.g. ``("parquet",)``.
    reason : str, optional
        Why the import failed when the module is installed but does not import.
    """

    def __init__(self, feature: str, modules: tuple[str, ...], extras: tuple[str, ...],
                 reason: str = "") -> None:
        self.feature = feature
        self.modules = tuple(modules)
        self.extras = tuple(extras)
        names = ", ".join(self.modules)
        what = f"which fails to import ({bounded(reason, MAX_SHOWN_CHARS)})" if reason else \
            f"{'which is' if len(self.modules) == 1 else 'which are'} not installed"
        extras = ",".join(self.extras)
        # (linsense is not on PyPI yet: the extra is installed from the source tree, README "Set-up")
        message = (f"{feature} needs {names}, {what}: pip install -e '.[{extras}]' in linsense's source "
                   f"tree (make install installs every extra)")
        super().__init__(message.replace("\n", " "), name=self.modules[0] if self.modules else None)


def as_given(exc: InputError) -> InputError:
    """A refusal as it was made: the default ``refusal`` of the commands' APIs (the command line
    passes one that names the option typed).

    Parameters
    ----------
    exc : InputError
        The refusal.

    Returns
    -------
    InputError
        ``exc`` itself.
    """
    return exc
