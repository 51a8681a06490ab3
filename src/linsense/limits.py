"""Limits on every size a user can type, checked before anything is allocated (docs/limits.md).

Each limit is far above what a real motor, bench or study needs and far below what exhausts a
machine's memory; the message of a refused value names the option or key, the value and the limit.
The simulator's own sizes come from the C library (``LS_SIM_MAX_ORDER``), not restated here: they
are read from the compiled extension on first use (:func:`max_harmonic_order`), so that importing
linsense, or its model, loads no C extension.
"""

from __future__ import annotations

import functools

from linsense.errors import InputError
from linsense.plausible import KINDS


@functools.cache
def max_harmonic_order() -> int:
    """Highest Fourier order of L_abc(theta) and of the PM flux: the C plant keeps orders 0 ..
    ``LS_SIM_MAX_ORDER - 1`` (63), read from the C library on first use. Also
    ``MAX_HARMONIC_ORDER`` and ``MAX_TABLE_ORDER`` (the Fourier order of a tabulated L_abc(theta): a
    longer table is fitted by least squares up to it; 8,000 rows interpolated exactly took minutes,
    100,000 asked for 37 GiB), attributes of this module read the same way.

    Returns
    -------
    int
        ``LS_SIM_MAX_ORDER - 1``.
    """
    from linsense._ctrl import lib

    return int(lib.LS_SIM_MAX_ORDER) - 1


@functools.cache
def max_angle() -> float:
    """The largest electrical angle (rad, either sign) a position argument of the API takes:
    ``LS_POS_PERIOD_MAX`` (2^24) periods, the firmware's range of positions (docs/limits.md), read
    from the C library on first use. Beyond it an angle is no position of a drive, and the
    harmonics of the models overflow (``cos(k theta)`` of 1e308 rad gave NaN).

    Returns
    -------
    float
        ``2 pi LS_POS_PERIOD_MAX``, rad.
    """
    import math

    from linsense._ctrl import lib

    return 2.0 * math.pi * float(lib.LS_POS_PERIOD_MAX)


def __getattr__(name: str) -> int:
    # MAX_HARMONIC_ORDER and MAX_TABLE_ORDER come from the C library: read when first asked for
    if name in ("MAX_HARMONIC_ORDER", "MAX_TABLE_ORDER"):
        return max_harmonic_order()
    raise AttributeError(f"module 'linsense.limits' has no attribute {name!r}")

#: positions per electrical period of a table, a LUT or a figure (--points)
MAX_POINTS = 100_000
#: rows of a table a user gives (an inductance table of a motor file): as many as ``linsense model
#: --points`` writes, so that every table linsense writes it also reads
MAX_TABLE_ROWS = MAX_POINTS
#: columns of such a table (``linsense model`` writes 17) and characters of one of its fields (a
#: number needs at most 24)
MAX_TABLE_COLUMNS = 64
MAX_TABLE_FIELD_CHARS = 100
#: positions of an emulated bench measurement or of a calibration (--positions)
MAX_POSITIONS = 10_000
#: nesting of arrays and tables in a TOML file (motor, scenario, sweep): the deepest a file of
#: linsense has is 4
MAX_TOML_DEPTH = 32
#: bytes of a text file a user gives (a motor, scenario, sweep or geometry TOML file, a JSON LUT):
#: the largest linsense writes is a few kB; read no further than this (a multi-GB file was read
#: whole before it was refused)
MAX_TEXT_FILE_BYTES = 16 * 1024**2
#: Hz, highest injection frequency of a table (``lut --f-inj``): half of a 1 MHz PWM; above it the
#: resistance's share is nil and the HF currents underflow (1e300 Hz gave an all-zero table). The
#: range of the kind ``injection_frequency`` in the one table of plausible values
#: (:data:`linsense.plausible.KINDS`)
MAX_F_INJ = KINDS["injection_frequency"].high
#: Hz, lowest injection frequency of a table (``lut --f-inj``): an HF injection runs at hundreds of
#: Hz to tens of kHz, and the design refuses below f_pwm / 4 = 125 Hz (its bandwidths follow the
#: injection); 1 Hz, the limit before, made a table of the resistance alone without a word (``lut
#: --f-inj 1``, kHz typed for Hz), 1e-10 Hz left the saliency's share under rounding
MIN_F_INJ = KINDS["injection_frequency"].low
#: PWM periods of one simulated run (duration x f_pwm): about an hour of computing
MAX_STEPS = 10_000_000_000
#: bytes of the trace one run keeps in memory (recorded samples x about 140 B)
MAX_TRACE_BYTES = 2 * 1024**3
#: bytes of the trace file a streamed run (``linsense simulate``) writes, counted as 144 B per sample
#: (the columns uncompressed; a Parquet file is about 110 B per sample): 240 million samples
MAX_TRACE_FILE_BYTES = 32 * 1024**3


def check_count(source: str, key: str, value: int, limit: int, what: str) -> int:
    """``value`` if ``1 <= value <= limit``.

    Parameters
    ----------
    source : str
        Where it was given, for messages.
    key : str
        Its key or option.
    value : int
        The count.
    limit : int
        The largest allowed.
    what : str
        What is counted, for messages.

    Returns
    -------
    int
        ``value``.

    Raises
    ------
    linsense.errors.InputError
        Naming ``key`` and the limit.
    """
    if value < 1:
        raise InputError(source, key, f"must be at least 1, got {value}")
    if value > limit:
        raise InputError(source, key, f"{value:,} {what} is beyond the limit of {limit:,} (docs/limits.md)")
    return value
