"""linsense.analysis."""
