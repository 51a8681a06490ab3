"""linsense.scenario: the vocabulary of a scenario file, the one description of a simulated drive.

What a scenario may say and how it is read, below the design (``tune``) that writes scenario keys
and the simulator (``sim``) that runs them: the keys, their types, ranges, units and defaults
(:mod:`~linsense.scenario.sections`, also the source of docs/simulator.md's key table); the rules
between keys, one function per section or concern run in one ordered table
(:mod:`~linsense.scenario.rules`); the dotted keys and :func:`key`, how code spells a key
(:mod:`~linsense.scenario.keys`); the loader, ``load_scenario(path) -> Scenario``
(:mod:`~linsense.scenario.load`); the bounds the rules share with the design
(:mod:`~linsense.scenario.bounds`). ``import linsense.scenario`` is light: the names below are
imported when first asked for (the schema reads its defaults from the compiled C library).
"""

from __future__ import annotations

import importlib

#: each public name -> the module of the package that defines it
_HOMES = {
    "Scenario": "load", "ScenarioFile": "load", "as_scenario": "load", "load_scenario": "load",
    "scenario_from_dict": "load", "toml_values": "load",
    "ScenarioSchema": "sections", "MetricsSection": "sections", "METRIC_BOUNDS": "sections",
    "CHECKS": "rules", "compensation_of": "rules",
    "key": "keys", "unit_kinds": "keys",
}

__all__ = sorted(_HOMES)


def __getattr__(name: str):
    # imported when asked for, so that the design's import of the bounds loads no C extension
    if name in _HOMES:
        return getattr(importlib.import_module(f"linsense.scenario.{_HOMES[name]}"), name)
    raise AttributeError(f"module 'linsense.scenario' has no attribute {name!r}")
