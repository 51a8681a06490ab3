"""The dotted keys of a scenario file (``inverter.dead_time``), read from its schema.

:func:`key` is how a module above spells a scenario key: it returns the key and raises on one the
schema does not have, so that a misspelt key fails where it is written, not in a scenario file.
"""

from __future__ import annotations

import functools

from pydantic import BaseModel

from linsense.scenario.schema import ScenarioSchema


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


#: a section's model class name -> its dotted path in a scenario file and its class
SECTIONS = _sections(ScenarioSchema)


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
    for path, model in SECTIONS.values():
        for name, field in model.model_fields.items():
            extra = field.json_schema_extra if isinstance(field.json_schema_extra, dict) else {}
            if "kind" in extra:
                out[f"{path}.{name}"] = extra["kind"]
    return out

#: a section's dotted path -> its class
SECTIONS_BY_PATH = {path: model for path, model in SECTIONS.values()}


@functools.cache
def all_keys() -> frozenset[str]:
    """Every dotted key of a scenario file: ``motor`` and ``section.key`` (``controller.model.L_d``).

    Returns
    -------
    frozenset of str
        The keys.
    """
    out = {name for name, f in ScenarioSchema.model_fields.items() if name not in SECTIONS_BY_PATH}
    for path, model in SECTIONS.values():
        out |= {f"{path}.{name}" for name in model.model_fields if f"{path}.{name}" not in SECTIONS_BY_PATH}
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
        raise KeyError(f"{dotted!r} is not a key of a scenario file (linsense.scenario.schema)")
    return dotted
