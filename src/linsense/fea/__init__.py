"""linsense.fea."""
