"""Strategies and oracles shared by the property suite (tests/properties/).

The oracle of every property: an input ends either in a result that passes its own consistency
checks, or in one error of the project's hierarchy (:class:`linsense.errors.LinsenseError`) whose
message is one line naming the file (or option, or argument); on the command line that is exit code
2 and one ``linsense: error:`` line. Never another exception (a traceback), never another exit code,
and never success with a value outside the ranges the documentation gives (docs/limits.md,
docs/motor-files.md, docs/simulator.md, docs/sweeps.md): those ranges are restated here, from the
documentation, not read from the code under test.
"""

from __future__ import annotations

import math
import os
import re

import numpy as np
import tomli_w
from hypothesis import HealthCheck, settings
from hypothesis import strategies as st

from linsense.errors import LinsenseError

_COMMON = dict(
    deadline=None,
    # (run_cli and tmp_path are function-scoped: every example makes its own folder and resets the
    # captured output, so sharing them between examples is safe)
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow,
                           HealthCheck.filter_too_much, HealthCheck.data_too_large],
)
#: the hypothesis profiles of this folder's properties (docs/limits.md, "The property suite"):
#: ``ci`` (the default) a few examples per property, derandomized (the same examples on every run, so
#: ``make test`` is deterministic), no deadline, no example database; ``long`` (``make fuzz`` or
#: ``make fuzzpy``: HYPOTHESIS_PROFILE=long) ``PROP_EXAMPLES`` (2000) random examples per property
#: (times its scale), failures kept in ``.hypothesis/`` and printed with their reproduction blob.
#: Settings objects of this module, not registered profiles: they apply to these properties only (a
#: conftest.py here was imported as ``conftest`` in place of tests/conftest.py, whose names other
#: test modules import)
PROFILES = {
    "ci": settings(max_examples=100, derandomize=True, database=None, print_blob=False, **_COMMON),
    "long": settings(max_examples=int(os.environ.get("PROP_EXAMPLES", "2000")), derandomize=False,
                     print_blob=True, **_COMMON),
}
PROFILE = PROFILES[os.environ.get("HYPOTHESIS_PROFILE", "ci")]


def prop_settings(**kw):
    """``@settings`` of one property: the profile, with a per-property scale of ``max_examples``."""
    scale = kw.pop("scale", 1.0)
    return settings(PROFILE, max_examples=max(1, int(PROFILE.max_examples * scale)), **kw)


# ------------------------------------------------------------------ hostile values
#: TOML can carry these where a number belongs (tomli_w writes nan and inf as TOML's nan and inf)
NON_FINITE = st.sampled_from([math.nan, math.inf, -math.inf])
HOSTILE_NUMBERS = st.one_of(
    NON_FINITE,
    st.sampled_from([0.0, -0.0, -1.0, 1e308, -1e308, 5e-324, 1e-300, 1e300, 2.0**63, -(2.0**63)]),
    st.sampled_from([0, -1, 2**63 - 1, -(2**63), 10**30, 4, 3, 65537, 100_001, 10**9]),
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(min_value=-(2**64), max_value=2**64),
)
_SCALARS = st.one_of(
    HOSTILE_NUMBERS,
    st.booleans(),
    st.text(max_size=12),
    st.sampled_from(["1.5", "nan", "", "ecce2010", "\x00", "é", "1e3", "true"]),
    st.dates(),
)


def _nest(v, depth: int):
    for _ in range(depth):
        v = [v]
    return v


HOSTILE = st.one_of(
    _SCALARS,
    st.lists(_SCALARS, max_size=4),
    st.dictionaries(st.text(min_size=1, max_size=6), _SCALARS, max_size=3),
    st.builds(_nest, st.just(1.0), st.integers(30, 40)),  # around MAX_TOML_DEPTH = 32
)


def mostly(good, bad, one_in: int = 6):
    """``good``, and ``bad`` about once in ``one_in`` draws (hypothesis' one_of would take each half
    of the time: too few valid inputs reach the checks made on a success)."""
    return st.integers(1, one_in).flatmap(lambda k: bad if k == one_in else good)


def is_number(v) -> bool:
    """A number as the documentation means it: an int or float, not a boolean."""
    return isinstance(v, int | float) and not isinstance(v, bool)


def finite_number(v) -> bool:
    return is_number(v) and math.isfinite(v)


# ------------------------------------------------------------------ text mutations
NUMBER_LITERAL = re.compile(r"(?<![\w.])[-+]?\d[\d_]*(\.\d+)?([eE][-+]?\d+)?(?![\w.])")
HOSTILE_LITERALS = ["nan", "+inf", "-inf", "1e999", "0x7fffffffffffffff", "1_000", "-0.0", '"1.0"', "true",
                    "[1.0]", "{ a = 1 }", "1e-400", "99999999999999999999999", "1979-05-27", "'x'", "0o17"]


@st.composite
def text_mutation(draw, text: str) -> str:
    """``text`` with one edit: a number literal replaced, a line dropped, doubled or cut, bytes
    inserted, or the file truncated."""
    kind = draw(st.sampled_from(["literal", "drop", "double", "insert", "truncate", "nest"]))
    lines = text.splitlines(keepends=True)
    if kind == "literal":
        spans = [m.span() for m in NUMBER_LITERAL.finditer(text)]
        if spans:
            a, b = draw(st.sampled_from(spans))
            lit = draw(st.one_of(st.sampled_from(HOSTILE_LITERALS), st.text(max_size=6)))
            return text[:a] + lit + text[b:]
    if kind == "drop" and lines:
        i = draw(st.integers(0, len(lines) - 1))
        return "".join(lines[:i] + lines[i + 1:])
    if kind == "double" and lines:
        i = draw(st.integers(0, len(lines) - 1))
        return "".join(lines[: i + 1] + lines[i:])
    if kind == "nest":
        depth = draw(st.integers(30, 200))
        return text + "\nzz = " + "[" * depth + "]" * depth + "\n"
    if kind == "truncate":
        return text[: draw(st.integers(0, len(text)))]
    pos = draw(st.integers(0, len(text)))
    return text[:pos] + draw(st.text(min_size=1, max_size=8)) + text[pos:]


def toml_text(doc: dict) -> str:
    return tomli_w.dumps(doc)


# ------------------------------------------------------------------ dict mutations
@st.composite
def mutated(draw, doc: dict, sections: dict[str, tuple[str, ...]], max_edits: int = 3) -> tuple[dict, list]:
    """A copy of ``doc`` with up to ``max_edits`` edits: a key set to a hostile value, deleted,
    misspelled, added, or a section replaced by a non-table. ``sections`` names the known keys of
    each section (``""`` for the top level). Returns the new document and the edits made."""
    doc = {k: (dict(v) if isinstance(v, dict) else v) for k, v in doc.items()}
    edits = []
    for _ in range(draw(st.integers(0, max_edits))):
        sec = draw(st.sampled_from(sorted(sections)))
        table = doc if sec == "" else doc.get(sec)
        if not isinstance(table, dict):
            continue
        keys = sections[sec]
        key = draw(st.sampled_from(keys))
        kind = draw(st.sampled_from(["value", "value", "slip", "slip", "delete", "typo", "extra", "section"]))
        if kind == "slip" and is_number(table.get(key)):  # a slip of unit (mm for m, mH for H) or sign
            table[key] = table[key] * draw(st.sampled_from([1e3, 1e-3, 1e6, 1e-6, 1e12, -1.0, 0.0]))
        elif kind in ("value", "slip"):
            table[key] = draw(HOSTILE)
        elif kind == "delete":
            table.pop(key, None)
        elif kind == "typo" and key in table and len(key) > 2:
            i = draw(st.integers(0, len(key) - 1))
            new = key[:i] + key[i + 1:]
            if new not in keys:
                table[new] = table.pop(key)
        elif kind == "typo" and key in table and re.fullmatch(r"[LM][0-9]", key):  # (L4 typed L04)
            table[f"{key[0]}{'0' * draw(st.integers(1, 2))}{key[1:]}"] = table.pop(key)
        elif kind == "extra":
            table[draw(st.sampled_from(["zz", key + "_x", key.upper() + "X"]))] = draw(_SCALARS)
        elif kind == "section" and sec:
            doc[sec] = draw(_SCALARS)
        edits.append((sec, key, kind))
    return doc, edits


# ------------------------------------------------------------------ the oracle
def attempt(fn, *args, **kw):
    """``("ok", value)`` or ``("refused", error)`` for an error of the project's hierarchy with a
    one-line message; any other exception propagates (the property fails with its traceback)."""
    try:
        return "ok", fn(*args, **kw)
    except LinsenseError as exc:
        msg = str(exc)
        assert msg and "\n" not in msg, f"a refusal must be one line, got {msg!r}"
        return "refused", exc


def cli_outcome(res, names: tuple[str, ...]) -> str:
    """``"ok"`` (exit 0) or ``"refused"`` (exit 2 with one ``linsense: error:`` line naming one of
    ``names``: the input file(s), the options); anything else fails."""
    assert res.code in (0, 2), (res.code, res.err)
    assert "Traceback" not in res.err, res.err
    if res.code == 0:
        return "ok"
    lines = res.err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("linsense: error: "), res.err
    assert any(n in lines[0] for n in names), (names, lines[0])
    return "refused"


# ------------------------------------------------------------------ the motor, independently
#: docs/motor-files.md and docs/limits.md ("Plausibility of a motor"): the documented ranges
MOTOR_RANGES = {
    "R_s": (0.0, 100.0),
    "pole_pitch": (1e-3, 1.0),
    "force_constant": (1e-2, 1e4),
    "mass": (1e-3, 1e4),
}
L0_RANGE = (1e-6, 0.5)
#: s, the longest electrical time constant L0 / R_s (R_s > 0) of a real linear motor
MAX_TIME_CONSTANT = 0.1
MAX_ORDER = 63
MOTOR_SECTIONS = {
    "": ("motor", "inductance", "friction", "pm_flux", "saturation"),
    "motor": ("name", "R_s", "pole_pitch", "force_constant", "mass"),
    "inductance": ("L0", "L2", "M0", "M2", "dM0", "L4", "M4", "L6"),
    "friction": ("viscous", "coulomb"),
    "saturation": ("polarity", "q_drop", "q_current", "magnet_current"),
    "pm_flux": ("harmonics",),
}


@st.composite
def motor_doc(draw) -> dict:
    """A plausible motor file (every value within the documented ranges) around a salient eq. (3)
    model (the shape of tests/conftest.py's salient_params), with optional sections."""
    R_s = draw(st.floats(0.0, 100.0))
    L0 = draw(st.floats(2e-6, 0.5))
    if L0 > MAX_TIME_CONSTANT * R_s > 0:  # (a real motor: R_s to the inductance's time constant)
        R_s = min(100.0, 1.001 * L0 / MAX_TIME_CONSTANT)
    M0 = draw(st.floats(-0.45, -0.1)) * L0
    L2 = draw(st.floats(-0.2, -0.02)) * L0
    M2 = draw(st.floats(-0.2, 0.0)) * L0
    dM0 = draw(st.floats(-0.45, 0.45)) * (-L2 - 2 * M2)
    doc = {
        "motor": {
            "name": draw(st.text(st.characters(min_codepoint=32, max_codepoint=0x2FF,
                                               exclude_characters="\x7f"), min_size=1, max_size=10)),
            "R_s": R_s,
            "pole_pitch": draw(st.floats(1e-3, 1.0)),
            "force_constant": draw(st.floats(1e-2, 1e4)),
            "mass": draw(st.floats(1e-3, 1e4)),
        },
        "inductance": {"L0": L0, "L2": L2, "M0": M0, "M2": M2, "dM0": dM0},
    }
    if draw(st.booleans()):
        doc["inductance"]["L4"] = draw(st.floats(-0.02, 0.02)) * L0
    if draw(st.booleans()):
        doc["friction"] = {"viscous": draw(st.floats(0, 100)), "coulomb": draw(st.floats(0, 100))}
    if draw(st.booleans()):
        orders = draw(st.lists(st.integers(2, 63), max_size=3, unique=True))
        doc["pm_flux"] = {"harmonics": [{"order": o, "amplitude": draw(st.floats(-0.1, 0.1)),
                                         "phase_deg": draw(st.floats(-360, 360))} for o in orders]}
    if draw(st.booleans()):
        doc["saturation"] = {"polarity": draw(st.floats(0.0, 0.01)), "q_drop": draw(st.floats(0.0, 0.5)),
                             "q_current": draw(st.floats(0.1, 10.0))}
    return doc


def _in(v, lo, hi) -> bool:
    return finite_number(v) and lo <= v <= hi


def nesting(obj) -> int:
    """Depth of arrays and tables, the file's top table counting 1 (docs/limits.md: at most 32)."""
    depth, stack = 0, [(obj, 1)]
    while stack:
        o, d = stack.pop()
        depth = max(depth, d)
        children = o.values() if isinstance(o, dict) else o
        stack.extend((c, d + 1) for c in children if isinstance(c, dict | list))
    return depth


MAX_TOML_DEPTH = 32


def motor_violations(doc) -> list[str]:
    """Dotted keys of ``doc`` (a parsed motor file with eq. 3 parameters) that break what
    docs/motor-files.md and docs/limits.md say; empty when the file is valid as documented (it may
    still be refused as a winding that cannot exist: checked separately). ``<file>``: the file as a
    whole (nested too deep)."""
    if not isinstance(doc, dict) or nesting(doc) > MAX_TOML_DEPTH:
        return ["<file>"]
    bad = [k for k in doc if k not in MOTOR_SECTIONS[""]]
    for sec in ("motor", "inductance"):
        if not isinstance(doc.get(sec), dict):
            bad.append(sec)
    for sec in ("friction", "pm_flux", "saturation"):
        if sec in doc and not isinstance(doc[sec], dict):
            bad.append(sec)
    m = doc.get("motor") if isinstance(doc.get("motor"), dict) else {}
    for k in m:
        if k not in MOTOR_SECTIONS["motor"]:
            bad.append(f"motor.{k}")
    name = m.get("name")
    if not (isinstance(name, str) and name and not any(ord(c) < 32 or ord(c) == 127 for c in name)):
        bad.append("motor.name")
    for k, (lo, hi) in MOTOR_RANGES.items():
        if not _in(m.get(k), lo, hi):
            bad.append(f"motor.{k}")
    ind = doc.get("inductance") if isinstance(doc.get("inductance"), dict) else {}
    for k, v in ind.items():
        h = re.fullmatch(r"([LM])([1-9]\d*)", k)  # (L4, M4, L6 ...: docs/motor-files.md)
        if k in ("L0", "L2", "M0", "M2", "dM0"):
            pass
        elif not h or int(h.group(2)) < 4 or int(h.group(2)) % 2 or int(h.group(2)) > MAX_ORDER:
            bad.append(f"inductance.{k}")
            continue
        if not finite_number(v):
            bad.append(f"inductance.{k}")
    for k in ("L0", "L2", "M0", "M2", "dM0"):
        if k not in ind:
            bad.append(f"inductance.{k}")
    if not _in(ind.get("L0"), *L0_RANGE):
        bad.append("inductance.L0")
    elif _in(m.get("R_s"), *MOTOR_RANGES["R_s"]) and ind["L0"] > MAX_TIME_CONSTANT * m["R_s"] > 0:
        bad.append("inductance.L0")
    fr = doc.get("friction") if isinstance(doc.get("friction"), dict) else {}
    for k, v in fr.items():
        if k not in MOTOR_SECTIONS["friction"] or not (finite_number(v) and v >= 0):
            bad.append(f"friction.{k}")
    pm = doc.get("pm_flux") if isinstance(doc.get("pm_flux"), dict) else {}
    for k in pm:
        if k != "harmonics":
            bad.append(f"pm_flux.{k}")
    hs = pm.get("harmonics", [])
    if not isinstance(hs, list):
        bad.append("pm_flux.harmonics")
        hs = []
    orders = []
    for h in hs:
        ok = isinstance(h, dict) and set(h) <= {"order", "amplitude", "phase_deg"} and "order" in h \
            and "amplitude" in h and isinstance(h["order"], int) and not isinstance(h["order"], bool) \
            and 2 <= h["order"] <= MAX_ORDER and finite_number(h["amplitude"]) \
            and finite_number(h.get("phase_deg", 0.0))
        if not ok:
            bad.append("pm_flux.harmonics")
        else:
            orders.append(h["order"])
    if len(set(orders)) != len(orders):
        bad.append("pm_flux.harmonics")
    sat = doc.get("saturation") if isinstance(doc.get("saturation"), dict) else {}
    for k, v in sat.items():
        ok = {"polarity": lambda x: x >= 0, "q_drop": lambda x: 0 <= x < 1, "q_current": lambda x: x > 0,
              "magnet_current": lambda x: x > 0}.get(k)
        if ok is None or not finite_number(v) or not ok(v):
            bad.append(f"saturation.{k}")
    return bad


def eq3_matrix(ind: dict, theta: np.ndarray) -> np.ndarray:
    """The 3x3 phase inductance matrix of eq. (3) with its even harmonics (docs/theory.md section 2),
    computed here from the documented formulas: ``L_A = L0 + sum L_n cos(n theta)``, B and C shifted
    by -+2 pi/3; ``M_AB = M0 + sum M_n cos(n (theta - pi/3))``, ``M_BC = M0 + dM0 + sum M_n cos(n
    theta)``, ``M_CA = M0 + dM0 + sum M_n cos(n (theta + pi/3))``."""
    orders = {2: (ind["L2"], ind["M2"])}
    for k, v in ind.items():
        h = re.fullmatch(r"([LM])(\d+)", k)
        if h and int(h.group(2)) >= 4:
            n = int(h.group(2))
            Ln, Mn = orders.get(n, (0.0, 0.0))
            orders[n] = (v, Mn) if h.group(1) == "L" else (Ln, v)
    L = np.zeros(theta.shape + (3, 3))
    s = lambda phi: sum(Ln * np.cos(n * (theta - phi)) for n, (Ln, _) in orders.items())  # noqa: E731
    mu = lambda phi: sum(Mn * np.cos(n * (theta - phi)) for n, (_, Mn) in orders.items())  # noqa: E731
    L[..., 0, 0] = ind["L0"] + s(0.0)
    L[..., 1, 1] = ind["L0"] + s(2 * np.pi / 3)
    L[..., 2, 2] = ind["L0"] + s(-2 * np.pi / 3)
    L[..., 0, 1] = L[..., 1, 0] = ind["M0"] + mu(np.pi / 3)
    L[..., 1, 2] = L[..., 2, 1] = ind["M0"] + ind["dM0"] + mu(0.0)
    L[..., 2, 0] = L[..., 0, 2] = ind["M0"] + ind["dM0"] + mu(-np.pi / 3)
    return L


_S3 = math.sqrt(3.0) / 2.0
CLARKE = (2.0 / 3.0) * np.array([[1.0, -0.5, -0.5], [0.0, _S3, -_S3]])
CLARKE_INV = np.array([[1.0, 0.0], [-0.5, _S3], [-0.5, -_S3]])


def dq_of(L_abc: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """``L_dq`` (amplitude-invariant Clarke, the dq frame rotated by theta: README, conventions)."""
    c, s = np.cos(theta), np.sin(theta)
    R = np.stack([np.stack([c, -s], -1), np.stack([s, c], -1)], -2)
    return np.swapaxes(R, -1, -2) @ (CLARKE @ L_abc @ CLARKE_INV) @ R


def winding_check(L_abc: np.ndarray, theta: np.ndarray) -> tuple[float, float]:
    """(smallest eigenvalue of L_abc over theta relative to its scale, smallest signed saliency
    margin ``sign * (L_q - L_d) - 0.01 L_mean`` relative to L_mean): both must be positive for a
    usable motor (docs/motor-files.md, "Checks on every model")."""
    scale = float(np.max(np.abs(L_abc)))
    eig = float(np.linalg.eigvalsh(L_abc)[..., 0].min()) / scale
    L_dq = dq_of(L_abc, theta)
    sal = L_dq[..., 1, 1] - L_dq[..., 0, 0]
    mean = 0.5 * (L_dq[..., 1, 1] + L_dq[..., 0, 0])
    sign = 1.0 if np.mean(sal) >= 0 else -1.0
    return eig, float(np.min((sign * sal - 0.01 * mean) / np.abs(mean)))


def check_grid(ind: dict) -> np.ndarray:
    """The positions the documentation's "at every position" is checked at (720, more for high orders)."""
    K = max([2] + [int(k[1:]) for k in ind if re.fullmatch(r"[LM]\d+", k) and int(k[1:]) >= 4])
    n = max(720, 16 * (K + 1))
    return np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
