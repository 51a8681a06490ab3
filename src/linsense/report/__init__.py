"""linsense.report."""
