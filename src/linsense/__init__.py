"""linsense: end-effect-aware saliency-based sensorless control of linear PM motors.

The package is in layers, each importing only from those below it (the layout in README.md;
``.importlinter`` holds the contract that ``make lint`` checks): ``model`` (inductance models,
frames, motor files) < ``analysis`` (psi maps, saliency, uncompensated observer) <
``compensation`` (LUT generation and export) < ``tune`` (the drive's design) < ``sim`` (the
simulator's binding, scenarios, metrics) < ``identify`` < ``sweep``, ``fea``, ``verify`` <
``report`` (figures) < ``reproduce`` < ``cli``; under them all the shared modules (``errors``,
``io``, ``limits``, ``validation``, ``version``, the C binding ``ctrl``). Angles are electrical
radians inside.
"""

from linsense.errors import InputError, LinsenseError, ModelError
from linsense.version import __version__

__all__ = ["InputError", "LinsenseError", "ModelError", "Motor", "get_include", "load_motor", "simulate",
           "simulate_many", "__version__"]


def get_include() -> str:
    """The folder of the C library's public headers (``#include "linsense/ls_drive.h"``).

    The wheel ships the controller library's headers and sources in the package
    (``linsense/csrc/include``, ``linsense/csrc/ctrl``, its CMake files beside them); an editable
    install reads them from the repository's ``csrc/``. ``linsense firmware export`` copies them
    from here.

    Returns
    -------
    str
        The absolute path of the folder holding ``linsense/ls_types.h`` and the other headers.

    Raises
    ------
    LinsenseError
        When neither holds the headers (a broken installation).
    """
    from pathlib import Path

    here = Path(__file__).resolve().parent
    for root in (here / "csrc", here.parents[1] / "csrc"):  # (the wheel's, then a source tree's)
        if (root / "include" / "linsense" / "ls_types.h").is_file() and (root / "ctrl").is_dir():
            return str(root / "include")
    raise LinsenseError(f"the C library's headers are not installed with linsense "
                        f"({here / 'csrc' / 'include'} is missing): reinstall linsense")


def __getattr__(name: str):
    # imported when asked for, so that ``import linsense`` stays light (the console entry,
    # linsense.__main__, imports numpy inside its Ctrl-C handling); the simulator needs the
    # compiled extension
    if name in ("Motor", "load_motor"):
        from linsense.model import motor

        return getattr(motor, name)
    if name in ("simulate", "simulate_many"):
        from linsense.sim import simulation

        return getattr(simulation, name)
    raise AttributeError(f"module 'linsense' has no attribute {name!r}")
