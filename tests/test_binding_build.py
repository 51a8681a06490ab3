"""The binding's build (tools/build_ctrl.py): declarations generated from the headers, a
short script outside the package, and no C helper for Python that nothing calls."""

from __future__ import annotations

import importlib.util
import re
import shutil
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SCRIPT = ROOT / "tools" / "build_ctrl.py"


def test_the_build_script_is_short_and_outside_the_package():
    assert len(SCRIPT.read_text().splitlines()) <= 150
    assert not list((ROOT / "src").rglob("*build_ctrl*.py"))  # (wheels ship src/linsense only)
    assert "tools/build_ctrl.py:ffibuilder" in (ROOT / "setup.py").read_text()


def test_every_python_helper_is_called():
    headers = "".join(p.read_text() for p in (ROOT / "csrc" / "py").glob("*.h"))
    declared = set(re.findall(r"\b(ls_py_\w+)\s*\(", headers))
    assert "ls_py_drive_run" in declared
    python = "".join(p.read_text() for d in ("src", "tests") for p in (ROOT / d).rglob("*.py"))
    unused = sorted(name for name in declared if not re.search(rf"\blib\.{name}\b", python))
    assert not unused, f"C helpers of the binding nothing calls: {unused}"


def _load(script: Path):
    spec = importlib.util.spec_from_file_location("build_ctrl_copy", script)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_a_header_change_reaches_the_binding_without_a_python_edit(tmp_path):
    """The declarations follow the headers: a new function, struct and constant in a public header
    appear in the cdef, static inline functions as prototypes, internal names (trailing _) not."""
    shutil.copytree(ROOT / "csrc", tmp_path / "csrc", ignore=shutil.ignore_patterns("tests"))
    (tmp_path / "tools").mkdir()
    shutil.copy(SCRIPT, tmp_path / "tools")
    shutil.copy(SCRIPT.with_name("build_flags.py"), tmp_path / "tools")  # (the flags it reads)
    (tmp_path / "src" / "linsense").mkdir(parents=True)
    shutil.copy(ROOT / "src" / "linsense" / "_digest.py", tmp_path / "src" / "linsense")
    header = tmp_path / "csrc" / "include" / "linsense" / "ls_added.h"
    header.write_text('#ifndef LS_ADDED_H\n#define LS_ADDED_H\n#include "linsense/ls_types.h"\n'
                      "#define LS_ADDED_MAX 0x10u\n"
                      "typedef struct { LS_REAL gain; int32_t count[3]; } ls_added;\n"
                      "ls_status ls_added_init(ls_added *a, LS_REAL gain);\n"
                      "static inline LS_REAL ls_added_step(ls_added *a, LS_REAL x) { return a->gain * x; }\n"
                      "void ls_added_internal_(ls_added *a);\n"
                      # (idioms a header may grow: a compiler attribute, a static assertion, float_t)
                      "#ifdef __GNUC__\n"
                      "#define LS_ADDED_INLINE static inline __attribute__((always_inline))\n"
                      "#else\n#define LS_ADDED_INLINE static inline\n#endif\n"
                      "_Static_assert(sizeof(ls_added) > 0, \"size\");\n#include <math.h>\n"
                      "LS_ADDED_INLINE float_t ls_added_twice(float_t x) { return x + x; }\n#endif\n")
    cdef = _load(tmp_path / "tools" / "build_ctrl.py").cdef()
    assert "ls_status ls_added_init(ls_added *a, LS_REAL gain);" in cdef
    assert "LS_REAL ls_added_step(ls_added *a, LS_REAL x);" in cdef
    assert re.search(r"LS_REAL gain;\s*int32_t count\[3\];\s*\} ls_added;", cdef)
    assert "#define LS_ADDED_MAX ..." in cdef and "typedef float... LS_REAL;" in cdef
    assert "ls_added_internal_" not in cdef and "LS_CFFI" not in cdef
    assert "{ return" not in cdef  # (no function body)
    assert "float_t ls_added_twice(float_t x);" in cdef and "__attribute__" not in cdef


def test_only_the_plant_is_compiled_with_contraction():
    """setup.py: the extension is compiled as the firmware is (ISO C's contraction off), the plant
    (csrc/sim/ls_sim_all.c) alone with -ffp-contract=fast. On an x86-64 host with FMA (the Makefile's
    -march=native), no fused multiply-add may appear in a function of the controller, its inline
    blocks or the binding's helpers: only in the simulator's."""
    import platform
    import subprocess

    import linsense._ctrl as ext

    if platform.machine() != "x86_64" or not shutil.which("objdump"):
        import pytest

        pytest.skip("needs objdump on x86-64")
    text = subprocess.run(["objdump", "-d", "--no-show-raw-insn", ext.__file__], capture_output=True,
                          text=True, check=True).stdout
    fused, fn = set(), ""
    for line in text.splitlines():
        head = re.match(r"^[0-9a-f]+ <(.+)>:$", line)
        if head:
            fn = head[1]
        elif re.search(r"\bv?f(n)?m(add|sub)\d", line):
            fused.add(fn)
    controller = sorted(f for f in fused if f.startswith(("ls_", "_cffi")) and not f.startswith("ls_sim"))
    assert not controller, f"fused multiply-adds in the controller's code: {controller}"
