"""A calibration's output set (``linsense calibrate``): the measured table, its stamp, metrics, figure.

:func:`calibrate_to` is what the command runs, so that Python reaches it too: the calibration of
:func:`~linsense.studies.calibrate.calibrate`, then ``lut_measured.csv``, ``lut_measured.json``
(when it completed: the stamped table a scenario reads), ``metrics.json``, ``timing.json`` and the
figure, written atomically as one output set.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from linsense.compensation.measured import resolution_warning
from linsense.io import output_set, split_timing
from linsense.scenario.load import Scenario
from linsense.sim.to_folder import write_metrics
from linsense.studies.calibrate import Calibration, calibrate, lut_csv, measured_json


@dataclass
class CalibrationOutput:
    """What :func:`calibrate_to` made.

    Parameters
    ----------
    calibration : Calibration
        The run (its table, stamp and metrics).
    metrics : dict
        ``metrics.json`` (without the timing).
    timing : dict
        ``timing.json``.
    files : list of Path
        The files written.
    warnings : list of str
        A table too coarse for the drive that reads it
        (:func:`~linsense.compensation.measured.resolution_warning`).
    """

    calibration: Calibration
    metrics: dict
    timing: dict
    files: list[Path] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)

    @property
    def completed(self) -> bool:
        """Whether the calibration measured every position."""
        return bool(self.calibration.completed)


def calibrate_to(out: str | Path, motor=None, *, positions: int = 56, load: float = 0.0,
                 fidelity: str = "switching", quad: float | None = None, source: str = "<calibrate>",
                 scenario: Scenario | None = None, drive: dict | None = None, saturated: bool = False,
                 figure: Callable[[Calibration, Path], object] | None = None) -> CalibrationOutput:
    """Run the calibration on the drive that will use the table and write its output set.

    Parameters
    ----------
    out : str or Path
        The folder: missing, empty or an earlier output of linsense.
    motor : Motor or str or None, optional
        As :func:`~linsense.studies.calibrate.calibrate`'s (None with ``scenario``: its motor).
    positions, load, fidelity, quad, source, scenario, drive
        As :func:`~linsense.studies.calibrate.calibrate`'s.
    saturated : bool, optional
        The saturated plant (``saturation.enabled = true``).
    figure : callable or None, optional
        ``figure(calibration, path)`` draws ``calibration.png``, e.g.
        :func:`linsense.report.figures.fig_calibration` saved (the studies are below the figures);
        None: no figure.

    Returns
    -------
    CalibrationOutput
        The calibration, its metrics and the files written.
    """
    extra = {"saturation": {"enabled": True}} if saturated else {}
    cal = calibrate(motor, positions, load, fidelity, quad=quad, source=source, scenario=scenario,
                    drive=drive, **extra)
    metrics, timing = split_timing(cal.metrics)
    warnings = []
    if cal.completed and cal.stamp is not None:  # (a table too coarse for the drive that reads it)
        st = cal.stamp
        w = resolution_warning(cal.motor, st.points, st.injection, st.f_inj, st.quad,
                               scenario.spec.observer.lut_points if scenario is not None else 256)
        warnings += [w] if w else []
    with output_set(out, "calibrate") as s:
        s.write("lut_measured.csv", lut_csv(cal))
        if cal.completed:  # (the stamped table a scenario reads: observer.lut_model = "measured")
            s.write("lut_measured.json", measured_json(cal))
        write_metrics(s, metrics, timing)
        if figure is not None:
            figure(cal, s.path("calibration.png"))
    return CalibrationOutput(cal, metrics, timing, list(s.files), warnings)
