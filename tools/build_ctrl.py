"""cffi build script of :mod:`linsense._ctrl`, the compiled binding of the C99 firmware library.

API (out-of-line) mode: ``setup.py`` names this file in ``cffi_modules``, so ``pip install``
(editable or not) compiles the library (``csrc/ctrl``), the simulator (``csrc/sim``) and the
binding's C helpers (``csrc/py``) into the extension ``linsense._ctrl``. It is a build input, not
part of the package (wheels do not ship it).

The declarations given to cffi are generated from the headers, never written here: every public
header (``csrc/include/linsense/*.h``), the simulator's and the helpers' (``csrc/py/*.h``) go
through the C preprocessor (``-DLS_CFFI``, which a header may test to hide what the binding must
not see; ``<...>`` system headers replaced by empty files) and pycparser; ``static inline``
functions become prototypes (cffi's wrappers call the inline code), names ending in ``_`` (the
library's internals) are left out, integer macros become ``#define NAME ...``, real ones
(``#define NAME LS_R(1.0e3)``: the library's limits, read in Python as ``lib.NAME``, the value C
compares with) ``static const double NAME;``, and ``LS_REAL`` becomes
``float...``: cffi takes the values and the real type (float, or double with ``-DLS_REAL_DOUBLE``
in ``CFLAGS``) from the headers when it compiles, and checks every struct layout and signature
there. A header change needs no edit here; a mismatch fails the build.

Run directly (``python tools/build_ctrl.py``) to compile in place for a quick check, or with
``--cdef`` to print the generated declarations.
"""

from __future__ import annotations

import importlib.util
import os
import re
import shlex
import subprocess
import sys
import sysconfig
import tempfile
from pathlib import Path

from cffi import FFI
from cffi.commontypes import COMMON_TYPES
from pycparser import c_ast, c_generator, c_parser

ROOT = Path(__file__).resolve().parents[1]
CSRC = ROOT / "csrc"
INCLUDE = CSRC / "include"
PY = CSRC / "py"
#: the simulator's header (not firmware, so not among the library's public headers)
SIM_HEADER = CSRC / "sim" / "ls_sim.h"
HEADERS = sorted(set((INCLUDE / "linsense").glob("*.h")) | {SIM_HEADER}) + sorted(PY.glob("*.h"))
INCLUDE_DIRS = [INCLUDE, PY] + ([] if INCLUDE in SIM_HEADER.parents else [SIM_HEADER.parent])
#: every header, named relative to its include directory
UMBRELLA = "".join(f'#include "{next(h.relative_to(d) for d in INCLUDE_DIRS if d in h.parents).as_posix()}"\n'
                   for h in HEADERS)
#: the simulator as one unity build (ls_sim_all.c includes its parts: its time loop inlines them)
SOURCES = sorted((CSRC / "ctrl").glob("*.c")) + [CSRC / "sim" / "ls_sim_all.c"] + sorted(PY.glob("*.c"))
if not (CSRC / "ctrl").is_dir() or not SIM_HEADER.is_file():
    raise RuntimeError(f"linsense C sources not found under {CSRC} (expected csrc/ctrl/*.c, {SIM_HEADER})")
#: the type names cffi knows by itself (int32_t, bool, size_t ...): declared for pycparser only
KNOWN_TYPES = sorted(n for n in COMMON_TYPES if n.isidentifier())
#: an integer constant expression (a macro cffi can read as ``#define NAME ...``)
INT_EXPR = re.compile(r"(?:\s|0[xX][0-9a-fA-F]+[uUlL]*|[0-9]+[uUlL]*|<<|>>|[-+*/%()|&^~])+")
#: a real constant of the library, ``LS_R(<decimal literal>)``
REAL_EXPR = re.compile(r"LS_R\([0-9.]+(?:[eE][-+]?[0-9]+)?\)")


def _load(rel: str):
    """Load a module of the source tree by path, ``rel`` from the root (the package is not
    importable at build time, and cffi runs this file without ``tools/`` on ``sys.path``)."""
    spec = importlib.util.spec_from_file_location(f"_linsense_{Path(rel).stem}", ROOT / rel)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


#: the compiler flags by family, from their one home (a direct run takes the platform's default)
COMPILE_ARGS = _load("tools/build_flags.py").COMPILE_ARGS
DIGEST = _load("src/linsense/_digest.py").source_digest(ROOT)


def preprocess(*flags: str) -> str:
    """The C preprocessor's output for every header, with empty files for the system headers (and
    the ``-D``/``-U`` of ``CFLAGS``, which the compiler gets too)."""
    cc = shlex.split(os.environ.get("CC") or sysconfig.get_config_var("CC") or "cc")
    flags += tuple(f for f in shlex.split(os.environ.get("CFLAGS", "")) if f.startswith(("-D", "-U")))
    with tempfile.TemporaryDirectory() as tmp:
        fake = Path(tmp)
        for name in {n for h in HEADERS for n in re.findall(r"#\s*include\s*<([^>]+)>", h.read_text())}:
            (fake / name).parent.mkdir(parents=True, exist_ok=True)
            (fake / name).write_text("typedef float float_t;typedef double double_t;" * (name == "math.h"))
        (fake / "ls_cffi.c").write_text(UMBRELLA)
        cmd = [*cc, "-E", "-P", "-std=c99", "-nostdinc", "-DLS_CFFI", "-D__attribute__(x)=", f"-I{fake}",
               *(f"-I{d}" for d in INCLUDE_DIRS), *flags, str(fake / "ls_cffi.c")]
        return subprocess.run(cmd, check=True, stdout=subprocess.PIPE, text=True).stdout


def cdef() -> str:
    """The declarations of every header, as cffi reads them."""
    known = "".join(f"typedef int {n};\n" for n in KNOWN_TYPES)
    ast = c_parser.CParser().parse(known + preprocess(), "ls_cffi.c")
    gen = c_generator.CGenerator()
    decls = []
    for node in ast.ext:
        if isinstance(node, c_ast.FuncDef):  # a static inline function: its prototype (cffi calls it)
            node = node.decl
            node.storage, node.funcspec = [], []
        if hasattr(node, "name") and node.name not in KNOWN_TYPES and not (node.name or "").endswith("_"):
            decls.append(gen.visit(node) + ";")
    defines = sorted(re.findall(r"^#define ([A-Za-z]\w*) (.*)$", preprocess("-dM"), re.M))
    macros = [f"#define {name} ..." for name, body in defines
              if name != "LS_CFFI" and re.search(r"[0-9]", body) and INT_EXPR.fullmatch(body)]
    macros += [f"static const double {name};" for name, body in defines if REAL_EXPR.fullmatch(body)]
    text = "\n".join(macros + decls) + "\n"
    return re.sub(r"\btypedef (?:float|double) LS_REAL;", "typedef float... LS_REAL;", text)


def _rel(p: Path) -> str:
    """Path relative to the working directory when possible (setuptools prefers relative sources)."""
    try:
        return os.path.relpath(p)
    except ValueError:  # another drive (Windows)
        return str(p)


def make_ffibuilder(absolute_paths: bool = False) -> FFI:
    """The FFI builder of ``linsense._ctrl``.

    Source paths are relative to the working directory (the project root under pip and
    setuptools) unless ``absolute_paths``; ``FFI.compile`` changes directory, so it needs them.
    """
    path = str if absolute_paths else _rel
    ffi = FFI()
    ffi.cdef(cdef())
    ffi.set_source(
        "linsense._ctrl",
        UMBRELLA + f'const char *ls_py_source_digest(void) {{ return "{DIGEST}"; }}\n',
        sources=[path(p) for p in SOURCES],
        include_dirs=[path(d) for d in INCLUDE_DIRS],
        extra_compile_args=COMPILE_ARGS["msvc" if os.name == "nt" else "gcc"],
        libraries=["m"] if os.name == "posix" else [],
    )
    return ffi


ffibuilder = make_ffibuilder()

if __name__ == "__main__":
    if "--cdef" in sys.argv:
        print(cdef(), end="")
    else:
        make_ffibuilder(absolute_paths=True).compile(tmpdir=str(ROOT / "build" / "cffi"), verbose=True)
