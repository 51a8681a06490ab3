"""Hypothesis profiles of the property suite (docs/limits.md, "The property suite").

* ``ci`` (the default): a few examples per property, derandomized (the same examples on every run,
  so ``make test`` is deterministic), no deadline, no example database; the whole folder runs in
  well under 60 s.
* ``long``: ``HYPOTHESIS_PROFILE=long`` (``make fuzz``, or ``make fuzzpy``): ``PROP_EXAMPLES`` (2000)
  random examples per property (times its scale), failures kept in ``.hypothesis/`` and printed with
  their reproduction blob.

The profiles apply to this folder's tests only (each uses ``prop_strategies.PROFILE``); the other
tests keep hypothesis' defaults and their own settings.
"""

from __future__ import annotations

import os

from hypothesis import HealthCheck, settings

_COMMON = dict(
    deadline=None,
    # (run_cli and tmp_path are function-scoped: every example makes its own folder and resets the
    # captured output, so sharing them between examples is safe)
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow,
                           HealthCheck.filter_too_much, HealthCheck.data_too_large],
)
settings.register_profile("ci", max_examples=100, derandomize=True, database=None, print_blob=False,
                          **_COMMON)
settings.register_profile("long", max_examples=int(os.environ.get("PROP_EXAMPLES", "2000")),
                          derandomize=False, print_blob=True, **_COMMON)
