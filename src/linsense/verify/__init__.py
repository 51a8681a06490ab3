"""Verification of a designed drive in the simulator: the certificate of `linsense tune`, and
``tune(motor, ...) -> TuneResult``, what that command does (design, scenario or C header, certificate)
callable from Python."""

from linsense.verify.tuning import TuneResult, tune

__all__ = ["TuneResult", "tune"]
