"""Gain and injection design for a user's motor: ``linsense tune`` (docs/tuning.md)."""

from linsense.tune.design import Design, DriveData, design

__all__ = ["Design", "DriveData", "design"]
