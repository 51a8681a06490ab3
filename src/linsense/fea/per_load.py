"""``linsense fea``'s steps below its figures: the load currents, a table's motor and LUT, the LUT against
load (see docs/fea.md); :func:`linsense.report.fea.run_fea` writes the output set."""

from __future__ import annotations

import math
import tempfile
from pathlib import Path

import numpy as np

from linsense.fea import outputs

LOAD_OPTION = "--load-current"


def parse_currents(value, option: str = LOAD_OPTION, what: str = "q-axis currents in A",
                   positive: bool = False) -> list[float]:
    """The q-axis load currents of ``--load-current``: a number or a comma list (``"0,1,2"``).

    Parameters
    ----------
    value : float or str or iterable
        The option's value.
    option : str, optional
        The option, named in messages.
    what : str, optional
        What the currents are, for messages.
    positive : bool, optional
        All must be above 0 (``--polarity``).

    Returns
    -------
    list of float
        A, in the order given.

    Raises
    ------
    linsense.errors.InputError
        Empty, not a number, not finite or beyond the range of currents of
        :data:`linsense.plausible.KINDS` (1 kA; "did you type mA?"), not positive where asked, or
        given twice.
    """
    from linsense.errors import InputError
    from linsense.plausible import implausible

    if isinstance(value, (int, float)):
        items = [value]
    elif isinstance(value, str):
        items = [v.strip() for v in value.split(",")]
    else:
        items = list(value)
    example = "0.5,1,2" if positive else "0,1,2"
    if not items or items == [""]:
        raise InputError(option, "", f"no current given ({what}, e.g. 2 or {example})")
    currents: list[float] = []
    for v in items:
        try:
            c = float(v)
        except (TypeError, ValueError):
            raise InputError(option, "", f"{v!r} is not a number ({what}, comma-separated, "
                             f"e.g. {example})") from None
        if not math.isfinite(c):
            raise InputError(option, "", f"must be finite currents in A, got {v!r}")
        beyond = implausible("current", abs(c))  # (the table of plausible values: 2000 for 2 A)
        if beyond is not None:
            raise InputError(option, "", f"{what}: {beyond}")
        if positive and c <= 0:
            raise InputError(option, "", f"must be positive amplitudes in A, got {v!r}")
        if c in currents:
            raise InputError(option, "", f"{c:g} A is given twice")
        currents.append(c + 0.0)  # -0.0 -> 0.0
    return currents


def load_tag(current: float) -> str:
    """The suffix of a load's files (``inductances_<I>A.csv``): ``2A``.

    Parameters
    ----------
    current : float
        A.

    Returns
    -------
    str
        The suffix.
    """
    return f"{current:g}A"


def _motor_of(res, folder: Path, tag: str = ""):
    """(motor or None, ModelError message or None) of a Result's table written into ``folder``."""
    from linsense.errors import ModelError
    from linsense.model.motor import load_motor

    table = f"inductances{tag}.csv"
    (folder / table).write_text(outputs.inductances_csv(res), encoding="utf-8")
    (folder / f"motor{tag}.toml").write_text(outputs.motor_toml(res, table), encoding="utf-8")
    try:
        return load_motor(folder / f"motor{tag}.toml"), None
    except ModelError as exc:
        return None, str(exc)


def lut_of(res, points: int = 360) -> np.ndarray:
    """Psi_LUT (eq. 12) at ``points`` positions of the motor model of a Result's table.

    Parameters
    ----------
    res : Result
        The FEA result.
    points : int, optional
        Table points.

    Returns
    -------
    ndarray
        rad.

    Raises
    ------
    ValueError
        When the table gives no usable motor (the model's refusal).
    """
    from linsense.compensation.lut import build_lut

    with tempfile.TemporaryDirectory(prefix="linsense-fea-") as d:
        motor, problem = _motor_of(res, Path(d))
        if motor is None:
            raise ValueError(problem)
        return build_lut(motor, points).values


def load_written(path: Path, shown: Path):
    """Load the motor file just written, or say why it is refused.

    Parameters
    ----------
    path : Path
        Where it was written.
    shown : Path
        Its final path, named in the message instead of ``path``.

    Returns
    -------
    motor : Motor or None
        The motor.
    problem : str or None
        The ModelError's message when refused.
    """
    from linsense.errors import ModelError
    from linsense.model.motor import load_motor

    try:
        return load_motor(path), None
    except ModelError as exc:
        return None, str(exc).replace(str(path), str(shown))


def load_sweep(results, luts) -> dict:
    """fea.json's ``lut_vs_load``: the loads, their force, each LUT's largest difference from the first's.

    Parameters
    ----------
    results : list of Result
        One per load.
    luts : list of Lut or None
        Each load's LUT (None: none).

    Returns
    -------
    dict
        ``currents_A``, ``force_N``, ``max_diff_deg``, ``psi_lut_peak_deg``, ``table_max_rel_diff``,
        ``newton_iterations``, ``solve_s``, ``rule``.
    """
    kf = outputs.force_constant(results[0])
    ref = luts[0]
    diffs = [None if ref is None or lu is None else float(np.degrees(np.abs(lu.values - ref.values).max()))
             for lu in luts]
    e0 = outputs.table(results[0])[1]
    table_diff = [float(np.abs(outputs.table(r)[1] - e0).max() / np.abs(e0).max()) for r in results]
    return {
        "currents_A": [r.load_current for r in results],
        "force_N": [None if kf is None else kf * r.load_current for r in results],
        "max_diff_deg": diffs,
        "psi_lut_peak_deg": [None if lu is None else float(np.degrees(np.abs(lu.values).max()))
                             for lu in luts],
        "table_max_rel_diff": table_diff,
        "newton_iterations": [r.newton for r in results],
        "solve_s": [r.times["solve_s"] for r in results],
        "rule": "max_diff_deg: max over theta of |Psi_LUT(load) - Psi_LUT(first load)|, electrical deg; "
                "table_max_rel_diff: max |entry - first load's| / max |entry|",
    }


def load_sweep_line(v: dict) -> str:
    """The LUT-against-load comparison in one line, for the report.

    Parameters
    ----------
    v : dict
        :func:`load_sweep`'s result.

    Returns
    -------
    str
        Per load the largest difference, and the largest of all.
    """
    parts = []
    for i, f, d in zip(v["currents_A"], v["force_N"], v["max_diff_deg"], strict=True):
        force = "" if f is None else f" ({f:.0f} N)"
        parts.append(f"{i:g} A{force} {'n/a' if d is None else f'{d:.2g} deg'}")
    valid = [d for d in v["max_diff_deg"] if d is not None]
    tail = f": max difference {max(valid):.2g} deg" if valid else ": no LUT (no usable saliency)"
    return f"LUT against load (vs {v['currents_A'][0]:g} A): " + ", ".join(parts) + tail
