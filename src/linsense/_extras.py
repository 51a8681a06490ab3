"""The optional dependencies of linsense: the pip extras and the one way to import them.

``pip install linsense`` (the core) covers the model, the LUT, tune, simulate (CSV trace),
calibrate, identify and their figures. The rest comes with an extra (pyproject.toml's
``[project.optional-dependencies]``): ``parquet`` (the Parquet trace, DataFrames), ``sweep`` (the
sweep engine on dask.distributed), ``fea`` (the finite-element model), ``report`` (the HTML report
of ``linsense reproduce``), and ``all``. A module that needs one imports it through :func:`require`
inside the function that uses it, so that the core imports and runs without it, and a missing one
stops in one line (:class:`~linsense.errors.MissingExtraError`) naming the extra to install.
"""

from __future__ import annotations

import importlib
import importlib.util
from types import ModuleType

from linsense.errors import MissingExtraError

#: the top-level modules linsense imports from each extra's packages (pyproject.toml keeps the same
#: sets as distributions: tests/test_extras.py compares them)
EXTRAS: dict[str, tuple[str, ...]] = {
    "parquet": ("pyarrow", "pandas"),
    "sweep": ("dask", "distributed", "pandas", "pyarrow", "rich"),
    "fea": ("skfem", "rich"),
    "report": ("jinja2", "markupsafe", "rich"),
}


def available(module: str) -> bool:
    """Whether ``module`` (a top-level name such as ``"pyarrow"``) is installed, without importing it.

    Parameters
    ----------
    module : str
        The module's import name.

    Returns
    -------
    bool
        True when Python's import system finds it.
    """
    try:
        return importlib.util.find_spec(module) is not None
    except (ImportError, ValueError):
        return False


def require(module: str, *, extra: str, feature: str) -> ModuleType:
    """Import ``module``, an optional dependency, or stop naming the extra that brings it.

    Parameters
    ----------
    module : str
        The module to import, e.g. ``"pyarrow.parquet"``.
    extra : str
        The extra of linsense that installs it (a key of :data:`EXTRAS`), e.g. ``"parquet"``.
    feature : str
        What needs it, for the message, e.g. ``"the Parquet trace"``.

    Returns
    -------
    types.ModuleType
        The imported module.

    Raises
    ------
    MissingExtraError
        When the module is not installed, or is installed but fails to import.
    """
    if extra not in EXTRAS:
        raise ValueError(f"unknown extra {extra!r}")
    try:
        return importlib.import_module(module)
    except ImportError as exc:
        top = module.partition(".")[0]
        missing = isinstance(exc, ModuleNotFoundError) and (exc.name or "").partition(".")[0] in (top, "")
        raise MissingExtraError(feature, (top,), (extra,), "" if missing else str(exc)) from exc


def require_extras(*extras: str, feature: str) -> None:
    """Check, before a long run starts, that every module of the given extras is installed (found,
    not imported: the run imports them through :func:`require` when it needs them).

    Parameters
    ----------
    *extras : str
        Keys of :data:`EXTRAS`, e.g. ``"report", "sweep"``.
    feature : str
        What needs them, for the message, e.g. ``"linsense reproduce"``.

    Raises
    ------
    MissingExtraError
        Naming every missing module and the extras that bring them.
    """
    missing: list[str] = []
    needed: list[str] = []
    for extra in extras:
        if extra not in EXTRAS:
            raise ValueError(f"unknown extra {extra!r}")
        gone = [m for m in EXTRAS[extra] if not available(m)]
        if gone:
            needed.append(extra)
            missing += [m for m in gone if m not in missing]
    if missing:
        raise MissingExtraError(feature, tuple(missing), tuple(needed))
