"""Fingerprints: of the C sources compiled into the cffi extension, and of files (a sweep's inputs).

``source_digest`` is used by the build script (``tools/build_ctrl.py``, loaded by path at build time,
when the package is not importable yet) and by ``linsense.ctrl`` at import, to detect an extension
built from other sources; ``file_sha256`` by :mod:`linsense.sweep.inputs`, the record of what a
sweep's rows depend on. Standard library only.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

#: the build's Python inputs beside the C sources, relative to the source tree's root: the cffi build
#: script, its flag tables and setup.py (which picks the flags); those absent (an installed wheel's
#: tree, a copy of the build files) are left out
BUILD_INPUTS = ("tools/build_ctrl.py", "tools/build_flags.py", "setup.py")


def source_digest(root: Path) -> str:
    """SHA-256 over the C sources under ``root/csrc``, the library's headers and the build's Python
    inputs (:data:`BUILD_INPUTS`)."""
    csrc = root / "csrc"
    h = hashlib.sha256()
    files = (
        sorted((csrc / "ctrl").glob("*.c"))
        + sorted((csrc / "ctrl").glob("*.h"))  # (internal headers: ls_drive_defaults.h, ...)
        + sorted((csrc / "sim").glob("*.c"))
        + sorted((csrc / "sim").glob("*.h"))
        + sorted((csrc / "include" / "linsense").glob("*.h"))
        + sorted((csrc / "py").glob("*.[ch]"))  # (the binding's C helpers)
    )
    for f in [*files, *(p for p in (root / n for n in BUILD_INPUTS) if p.is_file())]:
        h.update(f.name.encode())
        h.update(f.read_bytes())
    return h.hexdigest()


def bytes_sha256(data: bytes) -> str:
    """SHA-256 of ``data``, hex."""
    return hashlib.sha256(data).hexdigest()


def file_sha256(path: Path) -> str | None:
    """SHA-256 of the file's bytes (hex), or None when there is no such file (a missing input is
    recorded as absent, so that creating it later counts as a change)."""
    h = hashlib.sha256()
    try:
        with open(path, "rb") as f:
            for block in iter(lambda: f.read(1 << 20), b""):
                h.update(block)
    except (FileNotFoundError, NotADirectoryError, IsADirectoryError):
        return None
    return h.hexdigest()
