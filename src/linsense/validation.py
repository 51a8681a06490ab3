"""Turning pydantic's validation errors into the project's one-line :class:`InputError`.

Motor files (:mod:`linsense.model.motor_schema`) and scenario files (:mod:`linsense.scenario.sections`) are
validated by pydantic models in strict mode. The first problem becomes an ``InputError`` naming the
file, the dotted key and the value; an unknown key is answered with the closest known key of its
section ("did you mean 'pole_pitch'?"), and it is reported before a missing key, which a misspelled
key usually also causes.
"""

from __future__ import annotations

import types
import typing

from pydantic import BaseModel, ValidationError

from linsense._check import closest_key, repr_line
from linsense.errors import InputError, KeyProblem


def _section_model(root: type[BaseModel], loc: list) -> type[BaseModel] | None:
    """The pydantic model class of the section at ``loc`` (field names and list indices) below ``root``."""
    model: type[BaseModel] | None = root
    for part in loc:
        if isinstance(part, int) or model is None:
            continue
        field = model.model_fields.get(str(part))
        if field is None:
            return None
        model = _model_in(field.annotation)
    return model


def _model_in(annotation) -> type[BaseModel] | None:
    """The BaseModel class inside an annotation (``X``, ``X | None``, ``list[X]``, ``Annotated``)."""
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return annotation
    if isinstance(annotation, types.UnionType) or typing.get_origin(annotation) is not None:
        for arg in typing.get_args(annotation):
            found = _model_in(arg)
            if found is not None:
                return found
    return None


def to_input_error(exc: ValidationError, source: str, root: type[BaseModel]) -> InputError:
    """The first problem of a pydantic ``ValidationError`` (an unknown key first) as an InputError.

    Parameters
    ----------
    exc : pydantic.ValidationError
        The error.
    source : str
        The file, named in the message.
    root : type
        The pydantic model validated (for the known keys of a section).

    Returns
    -------
    InputError
        The error to raise, naming the dotted key and the value.
    """
    errors = exc.errors(include_url=False)
    extra = [e for e in errors if e["type"] == "extra_forbidden"]
    err = extra[0] if extra else errors[0]
    loc = list(err["loc"])
    names = [str(p) for p in loc]
    ctx = err.get("ctx") or {}
    inner = ctx.get("error")
    if isinstance(inner, KeyProblem):
        return InputError(source, ".".join(names + [inner.key]), inner.message)
    key = ".".join(names)
    kind = err["type"]
    value = err.get("input")
    if kind == "missing":
        return InputError(source, key, "missing required key")
    if kind == "extra_forbidden":
        section = _section_model(root, loc[:-1])
        hint = closest_key(names[-1], section.model_fields) if section is not None else ""
        return InputError(source, key, f"unknown key (value {repr_line(value)}){hint}")
    if kind == "finite_number":
        return InputError(source, key, f"expected a finite number, got {repr_line(value)}")
    msg = err["msg"]
    msg = msg[0].lower() + msg[1:] if msg else msg
    return InputError(source, key, f"{msg}, got {repr_line(value)}")
