"""Fingerprints: of the C sources compiled into the cffi extension, and of files (a sweep's inputs).

``source_digest`` is used by the build script (``tools/build_ctrl.py``, loaded by path at build time,
when the package is not importable yet) and by ``linsense.ctrl`` at import, to detect an extension
built from other sources; ``file_sha256`` by :mod:`linsense.sweep.inputs`, the record of what a
sweep's rows depend on. Standard library only.
"""

from __future__ import annotations

import hashlib
from pathlib import Path


def source_digest(csrc: Path, build_script: Path) -> str:
    """SHA-256 over the C sources, the library's headers, the build script and setup.py."""
    h = hashlib.sha256()
    files = (
        sorted((csrc / "ctrl").glob("*.c"))
        + sorted((csrc / "ctrl").glob("*.h"))  # (internal headers: ls_drive_defaults.h, ...)
        + sorted((csrc / "sim").glob("*.c"))
        + sorted((csrc / "sim").glob("*.h"))
        + sorted((csrc / "include" / "linsense").glob("*.h"))
        + sorted((csrc / "py").glob("*.[ch]"))  # (the binding's C helpers)
    )
    setup = csrc.parent / "setup.py"  # (its compiler flags; absent from an installed wheel's tree)
    for f in [*files, build_script, *([setup] if setup.is_file() else [])]:
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
