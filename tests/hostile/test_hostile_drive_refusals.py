"""``ctrl.Drive`` refusals name the C field, its value and the limit.

``ls_drive_init`` answers with one status. The binding named only the sections whose own init
refused ("obs = refused by ls_observer_init ... see the named sections") or, for a rule of the drive
itself, the list of every drive-level rule: no field, no value, no limit (23 cases below). Now the
search of the simulator's refusals (:func:`linsense.ctrl.refused_group`, :func:`linsense.ctrl.c_limit`:
the C library asked, no limit restated in Python) names the one field at fault, its value and the
nearest value ``ls_drive_init`` accepts with the rest of the configuration, or its rule (above 0,
finite, one value for a family of fields).
"""

from __future__ import annotations

import re

import pytest

from linsense import ctrl
from linsense.errors import ConfigError

NAN = float("nan")


def _set(cfg, path: str, value) -> None:
    *head, last = path.split(".")
    for part in head:
        cfg = getattr(cfg, part)
    setattr(cfg, last, value)


def _get(cfg, path: str):
    for part in path.split("."):
        cfg = getattr(cfg, part)
    return cfg
#: field, value, what the message says of the limit: a number it must be below / above, or a rule
CASES = [
    ("obs.mass", 1e-9, "smallest"), ("obs.k1", 1e9, "largest"), ("obs.k2", 1e12, "largest"),
    ("obs.k3", -1.0, "above 0"), ("obs.omega_max", 1e9, "largest"), ("obs.force_max", 0.0, "above 0"),
    ("obs.fric_v", 1e6, "largest"), ("inject.amplitude", 1e6, "largest"), ("inject.freq", 1e5, "largest"),
    ("demod.f_lpf", 1e9, "largest"), ("demod.min_level", -1.0, "smallest"), ("bpf.q", 1e6, "largest"),
    ("bpf.f0", 1e9, "largest"), ("sep.q", 0.0, "smallest"), ("current.kp", -1.0, "above 0"),
    ("current.ki", NAN, "finite"), ("i_max", 0.0, "above 0"), ("force_constant", -1.0, "above 0"),
    ("enc_counts", -5, "smallest"), ("traj.v_max", -1.0, "above 0"), ("prot.v_dc_min", 1e9, "largest"),
    ("mod.dead_time", 1.0, "largest"), ("dtres.l_d", -1.0, "smallest"),
    # families of one value (every module at the drive's fs; one pole pitch)
    ("fs", 32000.0, "one value"), ("pole_pitch", 0.03, "one value"),
]


@pytest.mark.parametrize("field, value, limit", CASES, ids=[c[0] for c in CASES])
def test_a_refusal_names_the_field_its_value_and_the_limit(field, value, limit):
    cfg = ctrl.drive_default_cfg()
    _set(cfg, field, value)
    with pytest.raises(ConfigError) as e:
        ctrl.Drive(cfg)
    msg = str(e.value)
    assert f"ls_drive: {field} = " in msg and "\n" not in msg, msg
    assert list(e.value.fields) == [field], e.value.fields
    shown = str(_get(cfg, field))  # (as the C field holds it: a float32 of 1e9 is 1e+09)
    assert (f"{float(shown):.6g}" if "." in shown or "e" in shown else shown) in msg, msg
    if limit in ("smallest", "largest"):
        assert re.search(rf"{limit} value ls_drive_init accepts with the rest of this configuration, "
                         r"-?[0-9.e+-]+$", msg), msg
    elif limit == "one value":
        assert "takes one value for" in msg and "fields)" in msg, msg
    else:
        assert f"it must be {limit}" in msg or f"it must be a {limit}" in msg, msg


def test_the_limit_named_is_the_one_the_c_library_keeps():
    # the value named is accepted, and a little beyond it is refused (no limit restated in Python)
    cfg = ctrl.drive_default_cfg()
    cfg.obs.k1 = 1e9
    with pytest.raises(ConfigError) as e:
        ctrl.Drive(cfg)
    lim = float(str(e.value).rsplit(", ", 1)[1])
    cfg.obs.k1 = lim
    ctrl.Drive(cfg)
    cfg.obs.k1 = lim * 1.001
    with pytest.raises(ConfigError):
        ctrl.Drive(cfg)


def test_a_configuration_of_another_library_version_says_so():
    cfg = ctrl.drive_default_cfg()
    cfg.lib_version = 3
    with pytest.raises(ConfigError, match=r"lib_version = 3 .*another version of the library"):
        ctrl.Drive(cfg)
