"""Verification of a designed drive in the simulator: the certificate of `linsense tune`."""
