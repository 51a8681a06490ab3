"""linsense.compensation."""
