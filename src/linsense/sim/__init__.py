"""linsense.sim."""
