"""Build of the compiled part of linsense; everything else is declared in pyproject.toml.

``cffi_modules`` runs ``tools/build_ctrl.py`` (outside the package: wheels do not ship it), which
compiles the C99 firmware library (``csrc/``) into the extension ``linsense._ctrl`` at install
time, editable or not, with declarations generated from its headers.

The flags depend on the compiler setuptools actually runs (``build_ext``'s
``compiler.compiler_type``), from ``tools/build_flags.py``'s ``COMPILE_ARGS`` and ``PLANT_ARGS`` (their
one home, a table without side effects, which ``tools/build_ctrl.py`` reads too):
gcc and clang (``unix``, ``mingw32``, ``cygwin``) compile as the firmware is, with ISO C's
floating-point contraction off (``-ffp-contract=off``, what ``-std=c99`` means for gcc on the MCU and
in the C tests): the controller, its inline blocks and the binding's helpers compute bit for bit as
written, whatever the code's layout and whether the host has FMA. Only the simulator's plant
(``csrc/sim/ls_sim_all.c``) is compiled with ``-ffp-contract=fast`` (fused multiply-adds where the
host has them, for speed). MSVC gets ``/O2 /fp:precise`` (no contraction, no ``-std``).

``build_py`` also copies the C controller library into the package, as data: ``csrc/ctrl`` (sources
and internal headers), ``csrc/include/linsense`` (public headers) and the CMake package
(``csrc/CMakeLists.txt``, ``csrc/cmake``) become ``linsense/csrc/...`` in the wheel
(``linsense.get_include()``, ``linsense firmware export``); not the simulator, the tests or the
binding's helpers. An editable install reads them from ``csrc/`` itself.

The extension uses only CPython's limited API (cffi defines ``Py_LIMITED_API``; the file is
``_ctrl.abi3.so``), so the wheel is tagged ``cp311-abi3``: one wheel for Python 3.11 and later.
"""

import glob
import importlib.util
import os
import sys
import sysconfig

from setuptools import setup
from setuptools.command.build_ext import build_ext
from setuptools.command.build_py import build_py

HERE = os.path.dirname(os.path.abspath(__file__))
#: the C library's files shipped in the wheel, relative to csrc/ (linsense.firmware.project.LIBRARY_FILES;
#: tests/test_dist.py checks the wheel holds exactly these)
C_LIBRARY = ("CMakeLists.txt", "cmake/*.cmake", "cmake/*.cmake.in", "include/linsense/*.h",
             "ctrl/*.c", "ctrl/*.h")


def _load_flags():
    """``tools/build_flags.py``, the compiler flags' one home (loaded by path: ``tools/`` is no package)."""
    path = os.path.join(HERE, "tools", "build_flags.py")
    spec = importlib.util.spec_from_file_location("_linsense_build_flags", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


FLAGS = _load_flags()


class BuildExt(build_ext):
    """``build_ext`` with the flags of the compiler it runs; the plant alone with contraction on."""

    def build_extension(self, ext):
        compile_args, plant_args = FLAGS.COMPILE_ARGS, FLAGS.PLANT_ARGS
        family = "msvc" if self.compiler.compiler_type == "msvc" else "gcc"
        ext.extra_compile_args = list(compile_args[family])
        plant = [s for s in ext.sources if s.replace(os.sep, "/").endswith("csrc/sim/ls_sim_all.c")]
        if plant and plant_args[family]:
            objects = self.compiler.compile(
                plant, output_dir=self.build_temp, include_dirs=ext.include_dirs, debug=self.debug,
                extra_postargs=[*ext.extra_compile_args, *plant_args[family]], depends=ext.depends)
            ext.sources = [s for s in ext.sources if s not in plant]
            ext.extra_objects = [*(ext.extra_objects or []), *objects]
        super().build_extension(ext)


class BuildPy(build_py):
    """``build_py``, and the C library copied into the package as ``linsense/csrc/...`` (not in an
    editable install, which reads the repository's ``csrc/``)."""

    def run(self):
        super().run()
        if getattr(self, "editable_mode", False):
            return
        csrc = os.path.join(HERE, "csrc")
        for pattern in C_LIBRARY:
            for src in sorted(glob.glob(os.path.join(csrc, pattern))):
                dst = os.path.join(self.build_lib, "linsense", "csrc", os.path.relpath(src, csrc))
                self.mkpath(os.path.dirname(dst))
                self.copy_file(src, dst)


# the abi3 tag (not for a free-threaded or non-CPython build, which cannot use the limited API)
abi3 = sys.implementation.name == "cpython" and not sysconfig.get_config_var("Py_GIL_DISABLED")
setup(cmdclass={"build_ext": BuildExt, "build_py": BuildPy}, cffi_modules=["tools/build_ctrl.py:ffibuilder"],
      options={"bdist_wheel": {"py_limited_api": "cp311"}} if abi3 else {})
