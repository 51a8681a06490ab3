"""linsense.identify."""
