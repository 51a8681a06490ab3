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
#: trajectories out and back at the design's v_max and a_max, reached: each move covers at least
#: TRAJ_PITCHES pole pitches and cruises at v_max over at least CRUISE_PITCHES of them (so the
#: estimate meets the full speed over a whole electrical period); peak |estimation error| while
#: moving and at rest (deg)
TRAJ_PITCHES = 2.0
CRUISE_PITCHES = 1.0
TRAJ_PEAK_ERR_DEG = 3.0
TRAJ_REST_ERR_DEG = 1.0
#: the trajectories' loads, fractions of the rated load opposing positive motion: every out-and-back
#: run meets its load opposing on the way out and aiding on the way back (and the reverse for a
#: negative fraction); --quick runs TRAJ_LOADS_QUICK
TRAJ_LOADS = (0.0, 0.25, 0.5, 0.75, 1.0, -0.25, -0.5, -0.75, -1.0)
TRAJ_LOADS_QUICK = (1.0, -1.0)
#: the pause between the moves of a trajectory, s (the reversal run has none: it goes through zero
#: speed at the rated load)
TRAJ_DWELL_S = 0.3
#: holds at these fractions of the rated load
HOLD_LOADS = (0.0, 0.5, -0.5)
#: off-nominal plants (the controller keeps the nominal model and LUT): |x - target| (deg) and no
#: limit cycle above HOLD_PP_DEG
OFF_ERR_DEG = TOLERANCE_ERR_DEG
#: name -> (inductance scale, R_s scale, end-effect scale): the design's own tolerances
OFF_NOMINAL = TOLERANCES
#: the off-nominal plants whose table is measured on them before they are judged, as a drive
#: engineer meets a motor whose end effect is off its file: the firmware's calibration (paper
#: Fig. 9) with the drive under test, then the holds and a trajectory with the measured table, at
#: the nominal plant's bounds (docs/tuning.md, "The end-effect tolerance")
CALIBRATED = tuple(name for name, (_, _, k_e) in TOLERANCES.items() if k_e != 1.0)
#: the calibration's positions over the period (the paper's 56) and the bound on its table against
#: the plant's own (deg): reported, and tested
CAL_POSITIONS = 56
CAL_TABLE_ERR_DEG = 0.3
#: positions over the electrical period: full and --quick
POSITIONS = 16
POSITIONS_QUICK = 8
#: the run lengths (s): a hold settles for HOLD_SETTLE_S and is judged over END_WINDOW_S
HOLD_SETTLE_S = 0.5
END_WINDOW_S = 0.3
