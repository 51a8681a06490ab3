"""The model table written by ``linsense model``: one row per position, SI units."""

from __future__ import annotations

import numpy as np

from linsense._check import instance, integer, reals
from linsense.analysis.hf import equilibrium_error, loop_gain_factor, psi_lut
from linsense.errors import InputError
from linsense.model.inductance import DERIVED_COLUMNS, ENTRIES
from linsense.model.motor import as_motor

#: Columns of the model table, in order (the first fourteen are fixed by the CLI contract).
MODEL_COLUMNS = ("theta_deg",) + ENTRIES + DERIVED_COLUMNS


def model_table(motor, points: int) -> dict[str, np.ndarray]:
    """Model quantities at ``points`` equally spaced positions over [0, 360) deg.

    Inductances in H; angles in electrical degrees; ``gain_nolut`` = ``1 + de*/dtheta``.

    Parameters
    ----------
    motor : Motor
        The motor.
    points : int
        Positions, 4 .. :data:`linsense.limits.MAX_POINTS`.

    Returns
    -------
    dict of str to ndarray
        Columns by name: ``theta_deg``, the six entries, ``L_d, L_q, L_dq``, ``saliency``,
        ``psi_lut_deg``, ``err_nolut_deg``, ``gain_nolut``, ``L_alpha, L_beta, L_alphabeta``.

    Raises
    ------
    linsense.errors.InputError
        ``motor`` not a motor, ``points`` not an integer in range.
    """
    from linsense.limits import MAX_POINTS

    src = "linsense.analysis.model_table.model_table"
    # (the API refuses what `linsense model --points` refuses: 3 was a ValueError, 4.5 a TypeError and
    # 10**9 ran the machine out of memory)
    motor = as_motor(motor, src)
    points = integer(points, src, "points", 4, MAX_POINTS)
    theta = np.linspace(0.0, 2.0 * np.pi, points, endpoint=False)
    ind = motor.inductance
    e = ind.entries(theta)
    L_dq = ind.L_dq(theta)
    L_ab = ind.L_ab(theta)
    cols = {"theta_deg": np.degrees(theta)}
    cols.update({name: e[:, j] for j, name in enumerate(ENTRIES)})
    cols["L_d"] = L_dq[:, 0, 0]
    cols["L_q"] = L_dq[:, 1, 1]
    cols["L_dq"] = L_dq[:, 0, 1]
    cols["saliency"] = cols["L_q"] - cols["L_d"]
    cols["psi_lut_deg"] = np.degrees(psi_lut(motor, theta))
    cols["err_nolut_deg"] = np.degrees(equilibrium_error(motor, theta))
    cols["gain_nolut"] = loop_gain_factor(motor, theta)
    cols["L_alpha"] = L_ab[:, 0, 0]
    cols["L_beta"] = L_ab[:, 1, 1]
    cols["L_alphabeta"] = L_ab[:, 0, 1]
    return cols


def table_to_csv(cols: dict[str, np.ndarray]) -> str:
    """CSV text with a header; floats with 12 significant digits (byte-reproducible).

    Parameters
    ----------
    cols : dict of str to ndarray
        Columns by name (:func:`model_table`).

    Returns
    -------
    str
        The CSV text.

    Raises
    ------
    linsense.errors.InputError
        ``cols`` not a dict of columns of one length of real numbers.
    """
    src = "linsense.analysis.model_table.table_to_csv"
    instance(cols, src, "cols", dict, "a dict of columns (model_table)")
    names = list(cols)
    data = [reals(cols[n], src, f"cols[{n!r}]", "values", ndim=1, finite=False) for n in names]
    if len({c.size for c in data}) > 1:
        raise InputError(src, "cols", f"columns of different lengths: {[c.size for c in data]}")
    data = np.column_stack(data) if data else np.zeros((0, 0))
    lines = [",".join(names)]
    lines += [",".join(f"{v:.12g}" for v in row) for row in data]
    return "\n".join(lines) + "\n"
