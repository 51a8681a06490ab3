"""Fingerprint of the C sources compiled into the cffi extension.

Used by the build script (``_build_ctrl.py``, loaded by path at build time, when the package is
not importable yet) and by ``linsense.ctrl`` at import, to detect an extension built from other
sources. Standard library only.
"""

from __future__ import annotations

import hashlib
from pathlib import Path


def source_digest(csrc: Path, build_script: Path) -> str:
    """SHA-256 over the C sources, the library's internal and public headers and the build script."""
    h = hashlib.sha256()
    files = (
        sorted((csrc / "ctrl").glob("*.c"))
        + sorted((csrc / "ctrl").glob("*.h"))  # (internal headers: ls_drive_defaults.h, ...)
        + sorted((csrc / "sim").glob("*.c"))
        + sorted((csrc / "include" / "linsense").glob("*.h"))
    )
    for f in [*files, build_script]:
        h.update(f.name.encode())
        h.update(f.read_bytes())
    return h.hexdigest()
