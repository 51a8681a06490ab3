"""Sweep files (TOML): a base scenario and the axes to vary (docs/sweeps.md).

::

    [sweep]
    name = "stability-map"
    scenario = "../scenarios/step6_lut.toml"   # the base, relative to this file
    sampling = "grid"                          # grid | random | lhs
    samples = 64                               # random, lhs: number of runs
    seed = 1
    study = "stability-map"                    # optional: its figure and summary line
    set = { "inverter.fidelity" = "switching" }   # optional: keys set in every run

    [[axis]]
    key = "reference.position_mm"              # any scenario key (dotted)
    values = [1.5, 3.0, 4.5, 6.0]

    [[axis]]
    key = "observer.bandwidth_hz"
    min = 10.0
    max = 80.0
    n = 8                                      # grid points between min and max (grid only)
    log = true

    [[axis]]
    key = "lut_motor.inductance.L0"            # the motor the controller's tables are built from
    relative = true                            # values, min, max are factors of the base value
    min = 0.8
    max = 1.2

Keys: a scenario key (``observer.bandwidth_hz``), a key of the plant's motor file
(``motor.inductance.dM0``), or a key of the motor the controller believes in
(``lut_motor.inductance.L0``: the LUT, gain table and gains are built from it, the plant keeps the
true motor; :mod:`linsense.sim.build`, ``controller.model.motor``).
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Literal, get_args

from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from linsense._check import brief, instance, path_arg
from linsense._digest import bytes_sha256
from linsense.errors import InputError, KeyProblem
from linsense.io import folder_of, parse_toml, read_text_file, working_folder
from linsense.plausible import implausible
from linsense.validation import to_input_error

_STRICT = ConfigDict(extra="forbid", strict=True, allow_inf_nan=False)
#: most runs one sweep file may ask for (docs/limits.md)
MAX_RUNS = 1_000_000
Value = float | int | bool | str
Study = Literal["stability-map", "lut-robustness", "injection"]
#: the built-in studies (each writes ``DIR/<study>.png``)
STUDIES: tuple[str, ...] = get_args(Study)


class Axis(BaseModel):
    """One ``[[axis]]`` of a sweep file: a key and its values (docs/sweeps.md).

    Attributes
    ----------
    key : str
        Dotted scenario key, or ``motor.*`` / ``lut_motor.*``.
    values : list or None
        The values; else ``min`` and ``max`` (with ``n`` on a grid).
    min : float or None
        Lower end.
    max : float or None
        Upper end.
    n : int or None
        Grid points between ``min`` and ``max``.
    log : bool
        Grid/random/lhs spaced in log between ``min`` and ``max``.
    relative : bool
        ``values``, ``min``, ``max`` are factors of the base value.
    """
    model_config = _STRICT
    key: str
    values: Annotated[list[Value], Field(min_length=1, max_length=100_000)] | None = None
    min: float | None = None
    max: float | None = None
    n: int | None = Field(default=None, ge=1, le=100_000)  # grid points between min and max
    log: bool = False  # grid/random/lhs spaced in log between min and max
    relative: bool = False  # values, min, max are factors of the base value

    @model_validator(mode="after")
    def _check(self) -> Axis:
        parts = self.key.split(".")
        if len(parts) < 2 or not all(parts):
            raise KeyProblem("key", f"expected a dotted key (e.g. 'observer.bandwidth_hz'), got {self.key!r}")
        if self.values is None:
            if self.min is None or self.max is None:
                raise KeyProblem("values", "give 'values', or 'min' and 'max'")
            if not self.min < self.max:
                raise KeyProblem("max", f"must be above min = {self.min:g}, got {self.max:g}")
            if self.log and self.min <= 0:
                raise KeyProblem("min", f"must be positive with log = true, got {self.min:g}")
        else:
            if self.min is not None or self.max is not None or self.n is not None:
                raise KeyProblem("values", "give 'values' or 'min'/'max'/'n', not both")
            if self.log:
                raise KeyProblem("log", "only with 'min' and 'max' (the values are given)")
        if self.relative and self.values is not None and not all(
                isinstance(v, int | float) and not isinstance(v, bool) for v in self.values):
            raise KeyProblem("values", "relative values must be numbers (factors of the base value)")
        if self.relative:  # (a factor in percent: values = [80, 100] made every run 80 times off)
            given = [("values", v) for v in self.values or ()]
            given += [(k, getattr(self, k)) for k in ("min", "max") if getattr(self, k) is not None]
            for key, v in given:
                msg = implausible("factor", float(v))
                if msg is not None:
                    raise KeyProblem(key, f"relative = true makes it a factor of the base value: {msg}")
        return self


class SweepSection(BaseModel):
    """The ``[sweep]`` section of a sweep file.

    Attributes
    ----------
    name : str
        Name in outputs.
    scenario : str
        Base scenario file, relative to the sweep file.
    sampling : str
        ``grid``, ``random`` or ``lhs``.
    samples : int or None
        Runs of ``random`` and ``lhs``.
    seed : int
        Random seed.
    study : str or None
        ``stability-map``, ``lut-robustness`` or ``injection``.
    batch : int or None
        Runs per task and per Parquet partition; default: about 32 tasks, at most 128 runs each.
    trace : bool
        Keep each run's trace (memory grows with duration); default: metrics only.
    set : dict
        Keys set in every run before the axes' values (same keys as an axis).
    """
    model_config = _STRICT
    name: str = Field(default="sweep", min_length=1)
    scenario: str = Field(min_length=1)  # base scenario file, relative to the sweep file
    sampling: Literal["grid", "random", "lhs"] = "grid"
    samples: int | None = Field(default=None, ge=1, le=MAX_RUNS)  # random, lhs
    seed: int = Field(default=0, ge=0, lt=2**63)
    study: Study | None = None
    # runs per task and per Parquet partition; default: about 32 tasks, at most 128 runs each (a task
    # costs a few ms of scheduling and writing: large sweeps want large batches, small ones several)
    batch: int | None = Field(default=None, ge=1, le=10_000)
    trace: bool = False  # keep each run's trace (memory grows with duration); default: metrics only
    # keys set in every run before the axes' values (same keys as an axis: scenario, motor., lut_motor.)
    set: dict[str, Value] = Field(default_factory=dict)


def _scenario_key(where: str, key: str) -> None:
    """Refuse a key that is neither a scenario key nor a motor file's (``motor.*``, ``lut_motor.*``):
    a misspelt one (``reference.positon_mm``) refused every run, each row saying why, and the sweep
    ended with exit code 0 and "4 runs: 0 stable, 0 not, 4 refused"."""
    from linsense._check import closest_key
    from linsense.scenario.keys import all_keys

    if key.split(".")[0] in ("motor", "lut_motor") or key in all_keys():
        return
    raise KeyProblem(where, f"{key!r} is not a key of a scenario file (a dotted key: 'scenario.duration'), "
                     f"nor of a motor file's (motor.*, lut_motor.*){closest_key(key, all_keys())}")


class SweepFile(BaseModel):
    """A whole sweep file, validated.

    Attributes
    ----------
    sweep : SweepSection
        ``[sweep]``.
    axis : list of Axis
        The ``[[axis]]`` tables (1 to 16).
    """
    model_config = _STRICT
    sweep: SweepSection
    axis: Annotated[list[Axis], Field(min_length=1, max_length=16)]

    @model_validator(mode="after")
    def _check(self) -> SweepFile:
        s = self.sweep
        keys = [a.key for a in self.axis]
        dup = {k for k in keys if keys.count(k) > 1}
        if dup:
            raise KeyProblem("axis", f"key {sorted(dup)[0]!r} appears twice")
        if s.sampling == "grid":
            if s.samples is not None:
                raise KeyProblem("sweep.samples", "only with sampling = \"random\" or \"lhs\" (a grid has "
                                 "the product of its axes)")
            for i, a in enumerate(self.axis):
                if a.values is None and a.n is None:
                    raise KeyProblem(f"axis.{i}.n", f"{a.key}: a grid axis with min and max needs n")
        else:
            if s.samples is None:
                raise KeyProblem("sweep.samples", f"required with sampling = {s.sampling!r}")
        for where, key in [*((f"axis.{i}.key", k) for i, k in enumerate(keys)),
                           *((f"sweep.set.{k}", k) for k in s.set)]:
            _scenario_key(where, key)
        return self


class SweepSpec:
    """A validated sweep file.

    Parameters
    ----------
    spec : SweepFile
        The pydantic model.
    source : str
        The file, or ``"<dict>"``, named in messages.
    base_dir : Path
        Folder the base scenario is relative to.
    text_sha256 : str or None, optional
        The SHA-256 of the file's text the spec was parsed from (None for a sweep given as a dict:
        :mod:`linsense.sweep.inputs` then digests the validated spec).
    """

    def __init__(self, spec: SweepFile, source: str, base_dir: Path, text_sha256: str | None = None) -> None:
        self.spec = spec
        self.source = source
        self.base_dir = base_dir
        self.text_sha256 = text_sha256

    @property
    def name(self) -> str:
        """The sweep's name (``sweep.name``)."""
        return self.spec.sweep.name

    @property
    def scenario_path(self) -> Path:
        """The base scenario file's path (relative to the sweep file's folder)."""
        p = Path(self.spec.sweep.scenario)
        return p if p.is_absolute() else self.base_dir / p


def sweep_from_dict(data: dict, source: str = "<dict>", base_dir: str | Path | None = None) -> SweepSpec:
    """Validate parsed sweep data.

    Parameters
    ----------
    data : dict
        Sections, as parsed from TOML.
    source : str, optional
        Named in messages.
    base_dir : str or Path or None, optional
        Folder the base scenario is relative to (None: the working folder).

    Returns
    -------
    SweepSpec
        The validated sweep.

    Raises
    ------
    linsense.errors.InputError
        Naming ``source``, the key and the value.
    """
    src = "linsense.sweep.sweep_from_dict"
    instance(source, src, "source", str, "a str (named in messages)")
    if base_dir is not None:
        base_dir = path_arg(base_dir, src, "base_dir", "a folder")
    if not isinstance(data, dict):
        raise InputError(source, "", f"a sweep is a table of sections, got {type(data).__name__}")
    try:
        spec = SweepFile.model_validate(data)
    except ValidationError as exc:
        raise to_input_error(exc, source, SweepFile) from None
    return SweepSpec(spec, source, Path(base_dir) if base_dir is not None else working_folder())


def load_sweep(path: str | Path) -> SweepSpec:
    """Read and validate a sweep TOML file.

    Its text is read once: the spec and its digest are of the same bytes.

    Parameters
    ----------
    path : str or Path
        The file.

    Returns
    -------
    SweepSpec
        The validated sweep, with ``text_sha256``.

    Raises
    ------
    linsense.errors.InputError
        An unreadable file, bad TOML or an invalid key.
    """
    path = path_arg(path, "linsense.sweep.load_sweep", "path", "a sweep file")
    text = read_text_file(path, "sweep file")
    sw = sweep_from_dict(parse_toml(text, str(path)), str(path), folder_of(path))
    sw.text_sha256 = bytes_sha256(text.encode("utf-8"))
    return sw


def as_sweep(obj) -> SweepSpec:
    """A :class:`SweepSpec` from a SweepSpec, a path or a dict.

    Parameters
    ----------
    obj : SweepSpec or str or Path or dict
        The sweep.

    Returns
    -------
    SweepSpec
        The sweep.

    Raises
    ------
    linsense.errors.InputError
        An invalid sweep, or ``obj`` none of these.
    """
    if isinstance(obj, SweepSpec):
        return obj
    if isinstance(obj, dict):
        return sweep_from_dict(obj)
    if isinstance(obj, str | Path):
        from linsense import examples

        return load_sweep(examples.named("sweeps", obj))  # (a packaged example's name: its file)
    raise InputError("linsense.sweep.sweep", "spec", f"expected a SweepSpec, a sweep file's path, a packaged "
                     f"sweep's name or a dict, got {brief(obj)} ({type(obj).__name__})")
