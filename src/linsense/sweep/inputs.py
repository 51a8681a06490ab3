"""What a sweep's rows depend on, file by file: the record kept in ``DIR/sweep.json`` and checked
whenever the sweep resumes or its folder is reused (docs/sweeps.md, "What a sweep depends on").

The rows are a function of the sweep file, its base scenario, the motors the scenario names (the
plant's ``motor``, the controller's ``controller.model.motor``, also when the sweep's ``set`` or an
axis gives it), the tables those motor files name (``inductance.table``, ``saturation.tables``), the
measured compensation table the scenario, ``set`` or an axis names (``observer.lut_file``) and
the code (linsense's version and the sources the C library was compiled from). Each input is
recorded by its SHA-256: the sweep file's as read, the other files' on disk, a preset's text; a
file named but missing is recorded as absent (creating it is a change).
"""

from __future__ import annotations

import json
import os
from pathlib import Path

from linsense._digest import bytes_sha256, file_sha256
from linsense.errors import LinsenseError
from linsense.io import parse_toml
from linsense.sweep.spec import SweepSpec

ABSENT = "absent"
SWEEP_FILE = "sweep file"
BASE = "base scenario"
PRESET = "motor preset"
MEASURED = "measured table"
#: inputs held in memory for the whole sweep (not re-read by the runs): not checked while it runs
IN_MEMORY = (SWEEP_FILE, PRESET)


def _entry(what: str, path: str, sha: str | None) -> dict:
    return {"what": what, "path": path, "sha256": sha or ABSENT}


def _file(what: str, path: Path) -> tuple[dict, bytes | None]:
    """The entry of the file at ``path`` and its bytes (None when absent), read once.

    Recorded by its real path (symbolic links resolved, never normalised by its text: ``lk/..``
    after a linked folder ``lk`` is its target's parent, where the runs read; the text's parent
    was recorded as absent, and an edited base scenario resumed into the same rows)."""
    p = Path(os.path.realpath(path))
    try:
        data = p.read_bytes()
    except (FileNotFoundError, NotADirectoryError, IsADirectoryError):
        return _entry(what, str(p), None), None
    return _entry(what, str(p), bytes_sha256(data)), data


def _toml(data: bytes | None, source: str) -> dict:
    """The TOML data of an input's bytes, {} when it does not parse (the run refuses it then, and
    its bytes are recorded all the same)."""
    if data is None:
        return {}
    try:
        return parse_toml(data.decode("utf-8"), source)
    except (LinsenseError, UnicodeDecodeError):
        return {}


def _motor(what: str, spec: str, scenario_dir: Path) -> list[dict]:
    """The entries of one motor (a preset's text, or a motor file and the tables it names)."""
    from linsense.model.motor import motor_path, names_a_path, preset_names, preset_text, table_files

    spec = motor_path(spec)  # (a packaged example motor's name: its file)
    if not names_a_path(spec):
        if spec not in preset_names():
            return []  # (every run refuses it: the rows do not depend on any file)
        return [_entry(PRESET, spec, bytes_sha256(preset_text(spec).encode("utf-8")))]
    p = Path(spec) if Path(spec).is_absolute() else scenario_dir / spec
    entry, data = _file(what, p)
    out = [entry]
    folder = Path(entry["path"]).parent  # (the real file's: as the motor's reader takes them)
    for kind, t in table_files(_toml(data, str(p))):
        tp = Path(t) if Path(t).is_absolute() else folder / t
        out.append(_file(kind, tp)[0])
    return out


def sweep_inputs(sw: SweepSpec) -> list[dict]:
    """Every input of a sweep's rows, in a fixed order.

    A file named twice is recorded once, under its first role.

    Parameters
    ----------
    sw : SweepSpec
        The sweep.

    Returns
    -------
    list of dict
        ``{"what", "path", "sha256"}`` each.
    """
    if sw.text_sha256 is not None:
        entries = [_entry(SWEEP_FILE, os.path.realpath(sw.source), sw.text_sha256)]
    else:  # a sweep given as a dict: its validated content
        text = json.dumps(sw.spec.model_dump(mode="json"), sort_keys=True)
        entries = [_entry(SWEEP_FILE, sw.source, bytes_sha256(text.encode("utf-8")))]
    base, data = _file(BASE, sw.scenario_path)
    entries.append(base)
    scenario = _toml(data, base["path"])
    scenario_dir = Path(base["path"]).parent
    specs = [("motor file", scenario.get("motor"))]
    controller = scenario.get("controller")
    model = controller.get("model") if isinstance(controller, dict) else None
    if isinstance(model, dict):
        specs.append(("controller's motor file", model.get("motor")))
    key = "controller.model.motor"  # (a sweep may set or vary it: a file per value)
    specs.append(("controller's motor file", sw.spec.sweep.set.get(key)))
    for axis in sw.spec.axis:
        if axis.key == key and axis.values is not None:
            specs += [("controller's motor file", v) for v in axis.values]
    for what, spec in specs:
        if isinstance(spec, str) and spec.strip():
            entries += _motor(what, spec, scenario_dir)
    # the measured compensation table (observer.lut_file), relative to the scenario like a motor file
    observer = scenario.get("observer")
    key = "observer.lut_file"
    luts = [observer.get("lut_file") if isinstance(observer, dict) else None, sw.spec.sweep.set.get(key)]
    for axis in sw.spec.axis:
        if axis.key == key and axis.values is not None:
            luts += list(axis.values)
    for lut in luts:
        if isinstance(lut, str) and lut.strip():
            entries.append(_file(MEASURED, Path(lut) if Path(lut).is_absolute() else scenario_dir / lut)[0])
    seen: set[tuple[str, str]] = set()
    unique = []
    for e in entries:
        k = _key(e)
        if k not in seen:
            seen.add(k)
            unique.append(e)
    return unique


def code_identity() -> dict:
    """The code the rows come from.

    Returns
    -------
    dict
        ``linsense``: the version; ``c_library``: the digest of the C sources its extension was
        compiled from.
    """
    from linsense import version
    from linsense.ctrl import built_digest

    return {"linsense": version.__version__, "c_library": built_digest()}


def digest(inputs: list[dict], code: dict) -> str:
    """One SHA-256 over the inputs and the code (what ``sweep.json``'s ``digest`` holds).

    Parameters
    ----------
    inputs : list of dict
        :func:`sweep_inputs`.
    code : dict
        :func:`code_identity`.

    Returns
    -------
    str
        Hex digest.
    """
    return bytes_sha256(json.dumps({"inputs": inputs, "code": code}, sort_keys=True).encode("utf-8"))


def show(path: str) -> str:
    """A recorded path as a person reads it: relative to the working folder when inside it.

    Parameters
    ----------
    path : str
        The recorded path.

    Returns
    -------
    str
        The path to show.
    """
    from linsense.io import working_folder

    try:
        return str(Path(path).relative_to(working_folder()))
    except (ValueError, LinsenseError):
        return path


def _pair(old: str, new: str) -> str:
    """``sha256 0123456789ab -> ba9876543210``; ``absent`` for a missing file."""
    if ABSENT not in (old, new):
        return f"sha256 {old[:12]} -> {new[:12]}"
    return " -> ".join(ABSENT if s == ABSENT else f"sha256 {s[:12]}" for s in (old, new))


def _key(e: dict) -> tuple[str, str]:
    """An input's identity: the sweep file by its role (a copy elsewhere is the same sweep), every
    other file by its path."""
    if e["what"] == SWEEP_FILE:
        return (SWEEP_FILE, "")
    return (PRESET if e["what"] == PRESET else "file", e["path"])


def changes(old_inputs: list[dict], old_code: dict, inputs: list[dict], code: dict) -> list[str]:
    """What differs between a recorded digest and the present one.

    Parameters
    ----------
    old_inputs : list of dict
        The recorded inputs.
    old_code : dict
        The recorded code.
    inputs : list of dict
        The present inputs.
    code : dict
        The present code.

    Returns
    -------
    list of str
        Each a phrase naming the input and both digests (empty: the same inputs).
    """
    out = []
    old = {_key(e): e for e in old_inputs}
    new = {_key(e): e for e in inputs}
    for k, e in new.items():
        name = f"{e['what']} {show(e['path'])}"
        if k not in old:
            out.append(f"{name} (not an input before)")
        elif old[k]["sha256"] != e["sha256"]:
            out.append(f"{name} ({_pair(old[k]['sha256'], e['sha256'])})")
    out += [f"{e['what']} {show(e['path'])} (no longer an input)" for k, e in old.items() if k not in new]
    if old_code.get("linsense") != code["linsense"]:
        out.append(f"the linsense version ({old_code.get('linsense')} -> {code['linsense']})")
    if old_code.get("c_library") != code["c_library"]:
        out.append(f"the compiled C library (sources {str(old_code.get('c_library'))[:12]} -> "
                   f"{code['c_library'][:12]})")
    return out


def changed_on_disk(recorded: list[dict]) -> list[str]:
    """The recorded files the runs read that no longer hold their recorded bytes.

    A check while the sweep runs: the sweep file and presets are in memory.

    Parameters
    ----------
    recorded : list of dict
        The recorded inputs.

    Returns
    -------
    list of str
        Each naming the file and both digests.
    """
    out = []
    for e in recorded:
        if e["what"] in IN_MEMORY:
            continue
        now = file_sha256(Path(e["path"])) or ABSENT
        if now != e["sha256"]:
            out.append(f"{e['what']} {show(e['path'])} ({_pair(e['sha256'], now)})")
    return out


def valid_record(m) -> str | None:
    """Why a manifest's digest record cannot be compared (None: it can).

    Parameters
    ----------
    m : object
        The manifest as read.

    Returns
    -------
    str or None
        What is wrong, as ``"<manifest> " + why`` reads.
    """
    if not isinstance(m, dict):
        return f"is not a table of keys but a {type(m).__name__}"
    if m.get("format") != "linsense-sweep":
        return f"has format {m.get('format')!r}, not 'linsense-sweep'"
    ins = m.get("inputs")
    if ins is None or "code" not in m:
        return "records no digest of its inputs (written by a linsense before they were recorded)"
    if not isinstance(ins, list) or not all(
            isinstance(e, dict) and all(isinstance(e.get(k), str) for k in ("what", "path", "sha256"))
            for e in ins):
        return "has 'inputs' that are not a list of {what, path, sha256}"
    code = m.get("code")
    if not isinstance(code, dict) or not all(isinstance(code.get(k), str) for k in ("linsense", "c_library")):
        return "has a 'code' that is not {linsense, c_library}"
    if m.get("digest") != digest(ins, code):
        return "has a 'digest' that does not match its inputs (edited by hand?)"
    return None
