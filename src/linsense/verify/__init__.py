"""Verification of a designed drive in the simulator: the certificate of `linsense tune`, and
``tune(motor, ...) -> TuneResult``, what that command does (design, scenario or C header, certificate)
callable from Python; ``tune_to(out, motor, ...)`` writes it as the command does, the certificate's
files beside the output."""

from linsense.verify.tune_output import tune_to
from linsense.verify.tuning import TuneResult, tune

__all__ = ["TuneResult", "tune", "tune_to"]
