"""linsense: end-effect-aware saliency-based sensorless control of linear PM motors.

The package follows the layout of DEVELOPERS.md: ``model`` (inductance models, frames,
motor files), ``analysis`` (psi maps, saliency, uncompensated observer), ``compensation``
(LUT generation and export) and ``report`` (figures). Angles are electrical radians inside.
"""

from linsense.errors import InputError, LinsenseError, ModelError
from linsense.model.motor import Motor, load_motor

__version__ = "0.1.0"

__all__ = ["InputError", "LinsenseError", "ModelError", "Motor", "load_motor", "simulate", "simulate_many",
           "__version__"]


def __getattr__(name: str):
    # the simulator needs the compiled extension: import it only when asked for
    if name in ("simulate", "simulate_many"):
        from linsense.sim import run

        return getattr(run, name)
    raise AttributeError(f"module 'linsense' has no attribute {name!r}")
