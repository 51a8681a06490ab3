"""Atomic file output: a failed run never leaves a half-written file behind."""

from __future__ import annotations

import math
import os
import stat
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path


def finite_cell(source: str, row: int, column: str, cell: str) -> float:
    """Parse one CSV cell as a finite number, or raise InputError naming row and column."""
    from linsense.errors import InputError

    try:
        v = float(cell)
    except ValueError:
        raise InputError(source, f"row {row}, column {column}", f"not a number: {cell!r}") from None
    if not math.isfinite(v):
        raise InputError(source, f"row {row}, column {column}", f"not finite: {cell!r}")
    return v


def read_text_file(path: str | os.PathLike, what: str) -> str:
    """Text of a user file, or InputError naming it: ``what`` says what was expected."""
    from linsense.errors import InputError

    src = str(path)
    p = Path(path)
    if not p.is_file():
        raise InputError(src, "", f"no such {what}")
    try:
        return p.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(src, "", f"cannot read: {exc}") from None


def write_atomic(path: str | os.PathLike, data: str | bytes) -> Path:
    """Write ``data`` to ``path`` through a temporary file in the same folder and a rename."""
    return write_atomic_with(path, lambda f: f.write(data.encode() if isinstance(data, str) else data))


def write_atomic_with(path: str | os.PathLike, writer: Callable) -> Path:
    """Call ``writer(binary_file)`` on a temporary file, then rename it onto ``path``.

    The parent folder is created if needed. On any exception the temporary file is removed
    and ``path`` is left as it was. ``"-"`` writes to standard output; an existing target that
    is not a regular file (``/dev/null``, a FIFO, ``/dev/stdout``) is written in place, never
    replaced.
    """
    if str(path) == "-":
        writer(sys.stdout.buffer)
        sys.stdout.flush()
        return Path("-")
    path = Path(path)
    try:
        special = not stat.S_ISREG(os.stat(path).st_mode)
    except FileNotFoundError:
        special = False
    if special:
        with open(path, "wb") as f:
            writer(f)
        return path
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as f:
            writer(f)
            f.flush()
            os.fsync(f.fileno())
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        raise
    return path
