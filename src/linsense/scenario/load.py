"""Reading a scenario: a file or a dict validated into a :class:`Scenario` (the loader).

Validation is pydantic in strict mode (:mod:`linsense.scenario.sections`, then the rules between keys
of :mod:`linsense.scenario.rules`): unknown or missing keys, wrong types, non-finite numbers and
out-of-range values end in :class:`~linsense.errors.InputError` naming the file, the dotted key and
the value.
"""

from __future__ import annotations

import datetime
import re
from pathlib import Path
from typing import Annotated

import numpy as np
from pydantic import TypeAdapter, ValidationError, model_validator

from linsense._check import path_arg
from linsense.errors import InputError
from linsense.io import folder_of, read_toml, working_folder
from linsense.plausible import slip
from linsense.scenario.keys import sections, unit_kinds
from linsense.scenario.rules import CHECKS
from linsense.scenario.sections import ScenarioSchema
from linsense.validation import to_input_error

_BRANCH = re.compile(r"^(float|int|bool|str|list\[.*\]|constrained-.*|function-.*)$")


class ScenarioFile(ScenarioSchema):
    """A whole scenario file, validated: its keys (:class:`~linsense.scenario.sections.ScenarioSchema`),
    then the rules between them (:data:`linsense.scenario.rules.CHECKS`, in order)."""

    @model_validator(mode="after")
    def _check(self) -> ScenarioFile:
        """The rules between keys, section by section, in the order their refusals take."""
        for check in CHECKS:
            check(self)
        return self


class Scenario:
    """A validated scenario: the parsed file plus where it came from.

    Parameters
    ----------
    spec : ScenarioFile
        Every key, defaults filled in.
    source : str
        File name (or ``"<dict>"``) used in error messages.
    base_dir : Path
        Folder against which a relative motor path is resolved.
    """

    def __init__(self, spec: ScenarioFile, source: str, base_dir: Path) -> None:
        self.spec = spec
        self.source = source
        self.base_dir = Path(base_dir)

    @property
    def name(self) -> str:
        """The scenario's name (``scenario.name``)."""
        return self.spec.scenario.name

    def to_dict(self) -> dict:
        """Plain data (every key, defaults filled in; ``None`` for unset optional keys dropped).

        Returns
        -------
        dict
            Section to keys.
        """
        return self.spec.model_dump(exclude_none=True)

    def given(self) -> dict:
        """The keys the file (or dict) gave, without the defaults (the rest is designed or defaulted
        when the scenario is built).

        Returns
        -------
        dict
            Section to the keys given.
        """
        return self.spec.model_dump(exclude_unset=True, exclude_none=True)

    def replace(self, **sections) -> Scenario:
        """A copy with some keys changed, validated again.

        E.g. ``replace(inverter={"fidelity": "switching"})``. Keys left unset stay unset (their gains
        are still designed).

        Parameters
        ----------
        **sections : dict or object
            Section name to the keys to change (a dict, merged), or a top-level key to its value.

        Returns
        -------
        Scenario
            The new scenario, same source and folder.

        Raises
        ------
        linsense.errors.InputError
            When the changed scenario is invalid.
        """
        data = self.given()
        for sec, vals in sections.items():
            if isinstance(vals, dict):
                data.setdefault(sec, {}).update(vals)
            else:
                data[sec] = vals
        return scenario_from_dict(data, self.source, self.base_dir)

    def __reduce__(self):  # picklable for simulate_many (the pydantic model re-validates on load)
        return (scenario_from_dict, (self.given(), self.source, str(self.base_dir)))

    def __repr__(self) -> str:
        return f"Scenario({self.name!r}, source={self.source!r})"

#: pydantic's errors of a value beyond its field's bounds
_RANGE_ERRORS = ("greater_than", "greater_than_equal", "less_than", "less_than_equal")


def _slip_of(key: str, data: dict) -> str:
    """The slip of unit that makes the value ``data`` gives at ``key`` one its field accepts
    (``injection.quadrature = 90``: "did you type %? (90 % is 0.9)"), or ``""``."""
    kind = unit_kinds().get(key)
    value = data
    for part in key.split("."):
        value = value.get(part) if isinstance(value, dict) else None
    if kind is None or isinstance(value, bool) or not isinstance(value, int | float):
        return ""
    path, _, name = key.rpartition(".")
    model = next(m for p, m in sections().values() if p == path)
    field = model.model_fields[name]
    ann = Annotated[field.annotation, *field.metadata] if field.metadata else field.annotation
    adapter = TypeAdapter(ann)

    def accepted(v: float) -> bool:
        try:
            adapter.validate_python(v, strict=True)
        except ValidationError:
            return False
        return True

    return slip(kind, float(value), ok=accepted)


def _has_path(data: dict, dotted: str) -> bool:
    """Whether ``data`` has the (dotted) section ``dotted``."""
    for part in dotted.split("."):
        if not isinstance(data, dict) or part not in data:
            return False
        data = data[part]
    return True


#: the values a TOML file can hold (a date, a time and a date-time among them)
_TOML_SCALARS = (str, bool, int, float, datetime.date, datetime.time)


def toml_values(data, source: str, key: str = ""):
    """``data`` (a dict of sections from Python) with only the values a TOML file can hold, so that
    a dict is validated as the same file would be: a numpy scalar of a real or boolean
    dtype becomes the Python float, int or bool it stands for (``np.True_`` is a boolean, refused
    where a number belongs as ``true`` is in a file); ``None`` (TOML has no null: it set an optional
    key to None, a TypeError in the build) and any other object (a tuple, bytes, a set, a complex
    number, an array) end in :class:`InputError` naming the dotted key.

    Parameters
    ----------
    data : object
        The value at ``key`` (the whole scenario at first).
    source : str
        Named in the message (``"<dict>"``).
    key : str
        Dotted key of ``data``.

    Returns
    -------
    object
        A copy of ``data`` with every value a TOML value.
    """
    if isinstance(data, dict):
        out = {}
        for k, v in data.items():
            if not isinstance(k, str):
                raise InputError(source, key, f"a key is a string, got {k!r} ({type(k).__name__})")
            out[k] = toml_values(v, source, f"{key}.{k}" if key else k)
        return out
    if isinstance(data, list):
        return [toml_values(v, source, f"{key}[{i}]") for i, v in enumerate(data)]
    if isinstance(data, np.generic) and data.dtype.kind in "biuf":
        return data.item()  # (np.float64 also is a float: a plain float either way)
    if isinstance(data, _TOML_SCALARS):
        return data
    if data is None:
        hint = "" if key.endswith("]") else ": leave the key out for its default"
        raise InputError(source, key, f"None is not a value of a scenario (TOML has no null){hint}")
    shown = " ".join(repr(data).split())
    raise InputError(source, key, f"expected a TOML value (a string, number, boolean, date, list or table), "
                     f"got {type(data).__name__} {shown}")


def scenario_from_dict(data: dict, source: str = "<dict>", base_dir: str | Path | None = None) -> Scenario:
    """Validate parsed scenario data.

    ``data`` from Python is held to what a TOML file can hold (:func:`toml_values`). A missing
    required key is named with its full dotted path, also when its whole section is missing
    (``reference.position_mm``: a scenario without ``[reference]`` steps to it by default).

    Parameters
    ----------
    data : dict
        Section name to keys, as parsed from TOML.
    source : str, optional
        Named in messages.
    base_dir : str or Path or None, optional
        Folder a relative motor path is resolved against (None: the working folder).

    Returns
    -------
    Scenario
        The validated scenario.

    Raises
    ------
    linsense.errors.InputError
        Naming ``source``, the dotted key and the value.
    """
    if not isinstance(data, dict):
        raise InputError(source, "", f"a scenario is a table of sections, got {type(data).__name__}")
    data = toml_values(data, source)
    try:
        spec = ScenarioFile.model_validate(data)
    except ValidationError as exc:
        # a section the data leaves out is built from its defaults, which its own rule can refuse
        # (pydantic then raises the section's error, located in the section)
        section, root = sections().get(exc.title, ("", ScenarioFile))
        err = to_input_error(exc, source, root)
        # drop the union-branch names pydantic puts into the location ("current_gain.float")
        key = ".".join(p for p in err.key.split(".") if not _BRANCH.match(p))
        key = f"{section}.{key}" if section and key else section or key
        message = err.message
        # a whole section missing ("scenario"): named by its first required key
        missing = next((v for v in sections().values() if v[0] == key), None)
        if missing is not None and message == "missing required key":
            section = key
            key += "." + next(k for k, f in missing[1].model_fields.items() if f.is_required())
        if section and not _has_path(data, section):
            message = f"{message} (the file has no [{section}] section)"
        # (a value out of its field's range: the slip of unit that brings it in, e.g. a kappa of 90)
        errors = exc.errors(include_url=False)
        first = next((e for e in errors if e["type"] == "extra_forbidden"), errors[0])
        hint = _slip_of(key, data) if first["type"] in _RANGE_ERRORS else ""
        raise InputError(source, key, message + (f"; {hint}" if hint else "")) from None
    return Scenario(spec, source, Path(base_dir) if base_dir is not None else working_folder())


def load_scenario(path: str | Path) -> Scenario:
    """Read and validate a scenario TOML file.

    Parameters
    ----------
    path : str or Path
        The file; a relative motor path in it is resolved against its folder.

    Returns
    -------
    Scenario
        The validated scenario.

    Raises
    ------
    linsense.errors.InputError
        An unreadable file, bad TOML or an invalid key, naming the file and the key; ``path`` not a
        path (``load_scenario(None)`` was a TypeError).
    """
    path = path_arg(path, "linsense.sim.load_scenario", "path", "a scenario file")
    return scenario_from_dict(read_toml(path, "scenario file"), str(path), folder_of(path))


def as_scenario(obj, caller: str = "simulate") -> Scenario:
    """A :class:`Scenario` from a Scenario, a path (str or Path) or a dict.

    Parameters
    ----------
    obj : Scenario, str, Path or dict
        The scenario.
    caller : str
        The API function named when ``obj`` is none of these.

    Returns
    -------
    Scenario
        The scenario.

    Raises
    ------
    InputError
        ``obj`` is none of these (naming ``caller`` and the argument ``scenario``), or the scenario
        it gives is invalid.
    """
    if isinstance(obj, Scenario):
        return obj
    if isinstance(obj, dict):
        return scenario_from_dict(obj)
    if isinstance(obj, str | Path):
        from linsense import examples

        return load_scenario(examples.named("scenarios", obj))  # (a packaged example's name: its file)
    shown = " ".join(repr(obj).split())
    raise InputError(caller, "scenario", f"expected a Scenario, a path of a TOML file or a dict of sections, "
                     f"got {type(obj).__name__} {shown}")
