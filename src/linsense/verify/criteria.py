"""The verification's bounds (docs/tuning.md, "The certificate"): one home for each number.

Angles are electrical degrees (fractions of the pole pitch: 1 deg = tau / 360), so that a bound
means the same thing for a 20 mm and a 100 mm motor; times in seconds.
"""

from __future__ import annotations

from linsense.tune.margins import TOLERANCE_ERR_DEG, TOLERANCES

#: nominal plant, holds: steady |x - target| (deg) and peak-to-peak of the true position (deg)
HOLD_ERR_DEG = 1.0
HOLD_PP_DEG = 0.15
#: steps of these fractions of the pole pitch: settled (within SETTLE_BAND_DEG, p-p <= HOLD_PP_DEG
#: over the end window) within STEP_SETTLE_S of the step
STEP_FRACTIONS = (0.1, 0.75)
SETTLE_BAND_DEG = 1.0
STEP_SETTLE_S = 0.4
#: load step of LOAD_STEP_FRACTION of the rated load while holding: back within SETTLE_BAND_DEG
#: within LOAD_RECOVER_S
LOAD_STEP_FRACTION = 0.5
LOAD_RECOVER_S = 0.3
#: trajectory over TRAJ_PITCHES pole pitches at the designed speed and acceleration with the rated
#: load: peak |estimation error| while moving and at rest (deg)
TRAJ_PITCHES = 2.0
TRAJ_PEAK_ERR_DEG = 3.0
TRAJ_REST_ERR_DEG = 1.0
#: holds at these fractions of the rated load
HOLD_LOADS = (0.0, 0.5, -0.5)
#: off-nominal plants (the controller keeps the nominal model and LUT): |x - target| (deg) and no
#: limit cycle above HOLD_PP_DEG
OFF_ERR_DEG = TOLERANCE_ERR_DEG
#: name -> (inductance scale, R_s scale, end-effect scale): the design's own tolerances
OFF_NOMINAL = TOLERANCES
#: positions over the electrical period: full and --quick
POSITIONS = 16
POSITIONS_QUICK = 8
#: the run lengths (s): a hold settles for HOLD_SETTLE_S and is judged over END_WINDOW_S
HOLD_SETTLE_S = 0.5
END_WINDOW_S = 0.3
