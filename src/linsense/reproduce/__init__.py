"""Reproduction of the paper's results: ``linsense reproduce`` (runs, claims, figures, report)."""
