"""The dotted keys of a scenario file (``inverter.dead_time``), read from its schema.

:func:`key` and :func:`checked` are how a module above spells scenario keys: they raise on a key the
schema does not have, so that a misspelt key fails where it is written, not in a scenario file. The
module is light to import (the design imports it): the schema, which reads its defaults from the
compiled C library, is loaded on the first call.
"""

from __future__ import annotations

import functools
from collections.abc import Mapping

from pydantic import BaseModel


def _sections(model: type[BaseModel], prefix: str = "") -> dict[str, tuple[str, type[BaseModel]]]:
    """Every section below ``model`` by the name of its model class: its dotted path and its class
    (``{"ReferenceSection": ("reference", ReferenceSection), "ModelOverride": ("controller.model",
    ModelOverride), ...}``)."""
    out = {}
    for name, field in model.model_fields.items():
        sub = field.annotation
        if isinstance(sub, type) and issubclass(sub, BaseModel):
            out[sub.__name__] = (f"{prefix}{name}", sub)
            out.update(_sections(sub, f"{prefix}{name}."))
    return out


@functools.cache
def sections() -> dict[str, tuple[str, type[BaseModel]]]:
    """Every section of a scenario file by the name of its model class.

    Returns
    -------
    dict
        Model class name to the section's dotted path and its class (``{"ModelOverride":
        ("controller.model", ModelOverride), ...}``).
    """
    from linsense.scenario.sections import ScenarioSchema

    return _sections(ScenarioSchema)


def unit_kinds() -> dict[str, str]:
    """The scenario keys that hold a quantity of a kind of the table of plausible values
    (:data:`linsense.plausible.KINDS`), each with its kind: the fields whose ``json_schema_extra``
    names one (``{"inverter.dead_time": "dead_time", "controller.model.L_d": "inductance", ...}``).

    Returns
    -------
    dict
        Dotted key to kind, in the file's order of sections.
    """
    out = {}
    for path, model in sections().values():
        for name, field in model.model_fields.items():
            extra = field.json_schema_extra if isinstance(field.json_schema_extra, dict) else {}
            if "kind" in extra:
                out[f"{path}.{name}"] = extra["kind"]
    return out


@functools.cache
def all_keys() -> frozenset[str]:
    """Every dotted key of a scenario file: ``motor`` and ``section.key`` (``controller.model.L_d``),
    sections themselves not counted.

    Returns
    -------
    frozenset of str
        The keys.
    """
    from linsense.scenario.sections import ScenarioSchema

    paths = {path for path, _ in sections().values()}
    out = {name for name in ScenarioSchema.model_fields if name not in paths}
    for path, model in sections().values():
        out |= {f"{path}.{name}" for name in model.model_fields if f"{path}.{name}" not in paths}
    return frozenset(out)


def key(dotted: str) -> str:
    """``dotted``, a key of a scenario file, checked against the schema.

    Parameters
    ----------
    dotted : str
        The dotted key (``"injection.amplitude"``).

    Returns
    -------
    str
        ``dotted`` itself.

    Raises
    ------
    KeyError
        When no scenario file has the key (a misspelt key in the code: not an input error).
    """
    if dotted not in all_keys():
        raise KeyError(f"{dotted!r} is not a key of a scenario file (linsense.scenario.sections)")
    return dotted


def in_a_section(dotted: str) -> bool:
    """Whether ``dotted`` is spelt as a key of a section of a scenario file (its first part names a
    section: ``injection.amplitude``, or a misspelt ``injection.amplitdue``), unlike a motor file's key
    that a design carries beside them (``motor.pole_pitch``).

    Parameters
    ----------
    dotted : str
        A dotted key.

    Returns
    -------
    bool
        Whether its first part is a section's name.
    """
    head, dot, _ = dotted.partition(".")
    return bool(dot) and any(path == head for path, _ in sections().values())


def checked(keys: Mapping[str, object], section: str = "") -> Mapping[str, object]:
    """``keys`` itself, each of its keys in a scenario's section checked with :func:`key`.

    Parameters
    ----------
    keys : Mapping
        Dotted key (or, with ``section``, the key within it) to value.
    section : str, optional
        The section the keys are in (``"startup"``); empty: the keys are dotted from the top.

    Returns
    -------
    Mapping
        ``keys``, unchanged.

    Raises
    ------
    KeyError
        A key of a section that no scenario file has.
    """
    for k in keys:
        dotted = f"{section}.{k}" if section else k
        if in_a_section(dotted):
            key(dotted)
    return keys
