"""Gain and injection design for a user's motor: ``linsense tune`` (docs/tuning.md)."""

from linsense.tune.design import Design, DriveData, design
from linsense.tune.drive_design import DriveDesign, design_drive

__all__ = ["Design", "DriveData", "DriveDesign", "design", "design_drive"]
