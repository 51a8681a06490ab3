"""linsense.studies: experiments run on the simulator, each many closed-loop runs summed up.

The firmware's LUT calibration (:mod:`~linsense.studies.calibrate`; its output set,
:func:`~linsense.studies.calibration_folder.calibrate_to`, is ``linsense calibrate``), the
calibrated LUT against load (:mod:`~linsense.studies.lut_load`), the start-up from unknown positions
with the magnet polarity (:mod:`~linsense.studies.startup_runs`) and the motion loop's margins
along the position without the LUT (:mod:`~linsense.studies.position_margins`). Each builds its
scenarios, runs them on :mod:`linsense.sim` and reports; ``linsense calibrate``, ``linsense
reproduce`` and the certificate (:mod:`linsense.verify`) use them.
"""

from linsense.studies.calibrate import Calibration, calibrate, calibration_scenario, lut_csv, measured_json
from linsense.studies.calibration_folder import CalibrationOutput, calibrate_to
from linsense.studies.lut_load import LutLoad, lut_vs_load
from linsense.studies.position_margins import margins_along
from linsense.studies.startup_runs import StartupRun, start_positions, startup_run, startup_runs

__all__ = ["Calibration", "CalibrationOutput", "LutLoad", "StartupRun", "calibrate", "calibrate_to",
           "calibration_scenario", "lut_csv",
           "lut_vs_load", "margins_along", "measured_json", "start_positions", "startup_run",
           "startup_runs"]
