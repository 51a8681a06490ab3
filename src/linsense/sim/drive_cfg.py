"""The drive configuration of a scenario: ``ls_drive_cfg`` filled from the one mapping of scenario
keys to its fields (:mod:`linsense.tune.cfgmap`), over ``ls_drive_default_cfg``."""

from __future__ import annotations

from operator import attrgetter

from linsense.analysis.emf import emf_pm_compensation
from linsense.analysis.hf import end_anisotropy
from linsense.ctrl import drive_default_cfg, ffi, lib, set_member
from linsense.model.motor import Motor
from linsense.scenario.load import Scenario
from linsense.sim.cache import memo, motor_key
from linsense.tune.cfgmap import ROWS, Values, square_schedule
from linsense.tune.injection import rotating_design


def value_of(spec, key: str):
    """The value of the dotted scenario ``key`` in ``spec`` (given, designed or default).

    Parameters
    ----------
    spec : ScenarioFile
        The validated scenario.
    key : str
        Dotted key.

    Returns
    -------
    object
        The value (None for a key it does not have).
    """
    obj = spec
    for part in key.split("."):
        obj = getattr(obj, part, None)
    return obj


#: dotted scenario key -> its getter (the mapping's keys are all scenario keys: tests/test_build_mapping.py)
_GETTERS: dict[str, attrgetter] = {}


def drive_values(sc: Scenario, motor: Motor, model_motor: Motor, known: dict) -> Values:
    """The inputs of the mapping (:mod:`linsense.tune.cfgmap`) for a designed scenario.

    Its keys, what the controller believes (``controller.model.*``: ``known``), the plant motor's
    pole pitch and the model's derived values (end anisotropy, the rotating demodulator's constants,
    the square wave's d-current schedule), each computed on first use.

    Parameters
    ----------
    sc : Scenario
        The designed scenario.
    motor : Motor
        The plant's motor.
    model_motor : Motor
        The motor the controller believes in.
    known : dict
        Motor values the controller uses.

    Returns
    -------
    Values
        The mapping's inputs.
    """
    s = sc.spec
    model_key = motor_key(model_motor)

    def rotating(v: Values) -> dict:
        f_inj = v.field("inject.freq")
        return rotating_design(model_motor, known["R_s"], v["injection.amplitude"], f_inj,
                               v["inverter.f_pwm"], v["control.delay_comp"])

    derived = {f"controller.model.{k}": val for k, val in known.items()}
    derived.update({
        "motor.pole_pitch": motor.pole_pitch,
        "model.end_anisotropy": lambda v: memo(("end_anisotropy", model_key),
                                               lambda: end_anisotropy(model_motor)),
        "model.emf_pm": lambda v: memo(("emf_pm", model_key), lambda: emf_pm_compensation(model_motor).cfg()),
        "model.rotating": rotating,
        "model.square_schedule": square_schedule,
    })

    def given(key: str) -> bool:
        section, name = key.rsplit(".", 1)
        return name in value_of(s, section).model_fields_set

    def get(key: str):
        getter = _GETTERS.get(key)
        if getter is None:
            getter = _GETTERS[key] = attrgetter(key)
        return getter(s)

    return Values(get, derived, given=given)


#: the rows the simulator sets (the observer's gains apart), with each field's struct and member
_SIM_ROWS = tuple((r, tuple(r.field.split(".")[:-1]), r.field.split(".")[-1]) for r in ROWS
                  if r.sim and r.kind != "gains")


def fill(v: Values):
    """A new ``ls_drive_cfg *`` with every field of the mapping the simulator sets.

    ``ls_drive_default_cfg`` with the mapping's fields (in its order), then the observer's gains
    (``ls_observer_gains`` from ``observer.bandwidth_hz``, or the file's ``k1``..``k3``).

    Parameters
    ----------
    v : Values
        The mapping's inputs (:func:`drive_values`).

    Returns
    -------
    cffi ``ls_drive_cfg *``
        The configuration.
    """
    d = drive_default_cfg()
    structs: dict[tuple[str, ...], object] = {(): d}  # (each sub-struct looked up once)
    for row, head, member in _SIM_ROWS:
        if row.when is not None and not row.when(v):
            continue
        value = v.field(row.field)
        obj = structs.get(head)
        if obj is None:
            obj = d
            for part in head:
                obj = getattr(obj, part)
            structs[head] = obj
        set_member(obj, member, getattr(lib, value) if row.kind == "enum" else value)
    lib.ls_observer_gains(ffi.addressof(d, "obs"), v["observer.bandwidth_hz"])
    if v["observer.k1"] is not None:
        d.obs.k1, d.obs.k2 = v["observer.k1"], v["observer.k2"]
        if v["observer.k3"] is not None:
            d.obs.k3 = v["observer.k3"]
    return d


def calibration_table(d, points: int):
    """The calibration's table, set in ``d``.

    Parameters
    ----------
    d : cffi ``ls_drive_cfg *``
        The configuration.
    points : int
        Table points.

    Returns
    -------
    cffi ``float[points]``
        The table, caller-owned: keep it alive with the drive.
    """
    table = ffi.new("float[]", points)
    d.cal.table = table
    return table

