"""Figures and reports: the paper's figures, the simulator's and the certificate's plots, the sweep
maps, the FEA's pictures and the HTML report of ``linsense reproduce``.

Every figure is a :class:`matplotlib.figure.Figure` rendered without a backend; matplotlib is
imported here first, so that an ``MPLBACKEND`` it refuses is named (it was matplotlib's "Key
backend: 'nonsense' is not a valid value for backend", naming no variable).
"""

import os

try:
    import matplotlib  # noqa: F401 (checked once, for every module of the package)
except ValueError as _exc:  # (matplotlib validates MPLBACKEND at its import)
    _backend = os.environ.get("MPLBACKEND")
    if _backend is None:
        raise
    from linsense.errors import InputError

    raise InputError("MPLBACKEND", "", f"{_backend!r} is not a backend matplotlib knows (linsense "
                                       "draws without one): unset MPLBACKEND, or set a valid one such as "
                                       "'agg'") from None
