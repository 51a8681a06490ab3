"""The calibrated LUT against load on the saturated plant, compared with the FEA's LUT against load
("with the saturated plant, the calibrated LUT at 0, 20 and 40 N ... agree with the FEA's
LUT-against-load within 0.3 deg").

The drive's calibration mode (:func:`linsense.studies.calibrate.calibrate`, switching inverter with
the dead time, the paper's pulsating injection) runs on the saturated plant of a motor file whose
``[saturation]`` holds the FEA's incremental inductance tables at several q currents, under each
load force; its table's change
from the first load is compared with the change of the FEA's ``lut_<I>A.csv`` (eq. 12 of each
load's table) at the same q current ``i_q = F / force_constant``, interpolated linearly between
the FEA's load currents.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from linsense.io import folder_of, read_csv_table
from linsense.model.motor import load_motor
from linsense.studies.calibrate import calibrate


def read_lut_csv(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """``theta_deg, psi_lut_deg`` columns of a LUT file, in rad.

    Through the one bounded CSV reader, :func:`linsense.io.read_csv_table`.

    Parameters
    ----------
    path : Path
        The CSV file.

    Returns
    -------
    theta : ndarray
        rad.
    psi : ndarray
        rad.

    Raises
    ------
    linsense.errors.InputError
        A bad header or cell.
    """
    data = read_csv_table(path, ("theta_deg", "psi_lut_deg"), "LUT")[0]
    return np.radians(data[:, 0]), np.radians(data[:, 1])


def _periodic_interp(theta: np.ndarray, th: np.ndarray, ps: np.ndarray) -> np.ndarray:
    return np.interp(np.mod(theta, 2.0 * np.pi), th, ps, period=2.0 * np.pi)


def fea_lut_change(folder: Path, currents: tuple[float, ...], i_q: float, theta: np.ndarray) -> np.ndarray:
    """The FEA's LUT at ``i_q`` minus its LUT at ``currents[0]``, at ``theta``.

    ``folder/lut_<I>A.csv`` interpolated linearly in the current between the two nearest loads.

    Parameters
    ----------
    folder : Path
        Folder of the FEA's LUT files.
    currents : tuple of float
        The FEA's load currents, A, increasing.
    i_q : float
        q current, A.
    theta : ndarray
        Electrical positions, rad.

    Returns
    -------
    ndarray
        rad.

    Raises
    ------
    ValueError
        ``i_q`` outside ``currents``.
    """
    cur = np.asarray(currents, dtype=float)

    def lut(c: float) -> np.ndarray:
        th, ps = read_lut_csv(folder / f"lut_{c:g}A.csv")
        return _periodic_interp(theta, th, ps)

    base = lut(cur[0])
    if not cur.min() <= i_q <= cur.max():
        raise ValueError(f"i_q = {i_q:g} A is outside the FEA's load currents {cur.min():g}..{cur.max():g} A")
    j = int(np.clip(np.searchsorted(cur, i_q) - 1, 0, cur.size - 2))
    w = (i_q - cur[j]) / (cur[j + 1] - cur[j])
    return (1.0 - w) * lut(cur[j]) + w * lut(cur[j + 1]) - base


@dataclass
class LutLoad:
    """Calibrated LUTs at several loads and their comparison with the FEA (angles in rad).

    Attributes
    ----------
    theta : ndarray
        Calibration positions, rad.
    loads : tuple of float
        Loads, N.
    i_q : tuple of float
        ``F / force_constant``, A.
    tables : list of ndarray
        Calibrated LUT per load, rad.
    cal_change : list of ndarray
        Table minus the first load's, rad.
    fea_change : list of ndarray
        The FEA's LUT change at the same i_q, rad.
    metrics : dict
        ``runs``: each calibration's metrics.
    """

    theta: np.ndarray  # rad, calibration positions
    loads: tuple[float, ...]  # N
    i_q: tuple[float, ...]  # A, F / force_constant
    tables: list[np.ndarray]  # rad, calibrated LUT per load
    cal_change: list[np.ndarray]  # rad, table minus the first load's
    fea_change: list[np.ndarray]  # rad, the FEA's LUT change at the same i_q
    metrics: dict = field(default_factory=dict)

    @property
    def max_diff_deg(self) -> float:
        """deg, the largest |calibrated change - FEA change| over the positions and loads."""
        return float(max(np.degrees(np.abs(c - f)).max() for c, f in zip(self.cal_change, self.fea_change,
                                                                          strict=True)))


def lut_vs_load(motor_file: str | Path, loads=(0.0, 20.0, 40.0), positions: int = 56,
                fidelity: str = "switching") -> LutLoad:
    """Calibrate on the saturated plant of a motor file at each load and compare with the FEA.

    The motor file has a ``[saturation]`` with FEA tables whose ``lut_<I>A.csv`` sit beside it.

    Parameters
    ----------
    motor_file : str or Path
        The motor file.
    loads : sequence of float, optional
        Loads, N.
    positions : int, optional
        Calibration points.
    fidelity : str, optional
        Inverter model.

    Returns
    -------
    LutLoad
        The tables and their changes.

    Raises
    ------
    ValueError
        A motor file without FEA saturation tables.
    RuntimeError
        A calibration that did not complete.
    """
    path = Path(motor_file)
    m = load_motor(path)
    if m.saturation is None or not m.saturation.tables:
        raise ValueError(f"{path}: needs a [saturation] section with FEA tables")
    tables, metrics, iq = [], [], []
    for f in loads:
        c = calibrate(str(path), positions=positions, load=float(f), fidelity=fidelity, quad=0.0,
                      saturation={"enabled": True})
        if not c.completed:
            raise RuntimeError(f"calibration at {f:g} N did not complete: {c.metrics}")
        tables.append(c.psi_measured)
        metrics.append(c.metrics)
        iq.append(float(f) / m.force_constant)
    theta = 2.0 * np.pi * np.arange(positions) / positions
    cal_change = [t - tables[0] for t in tables]
    folder = folder_of(path)  # (the FEA's LUT files beside the motor file, through a link too)
    fea_change = [fea_lut_change(folder, m.saturation.currents, i, theta) - fea_lut_change(
        folder, m.saturation.currents, iq[0], theta) for i in iq]
    return LutLoad(theta, tuple(float(f) for f in loads), tuple(iq), tables, cal_change, fea_change,
                   {"runs": metrics})
