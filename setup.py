"""Build of the compiled part of linsense; everything else is declared in pyproject.toml.

``cffi_modules`` runs ``tools/build_ctrl.py`` (outside the package: wheels do not ship it), which
compiles the C99 firmware library (``csrc/``) into the extension ``linsense._ctrl`` at install
time, editable or not, with declarations generated from its headers.

The controller (``csrc/ctrl/*.c``) is compiled as the firmware is: with ISO C's floating-point
contraction off (``-ffp-contract=off``, what ``-std=c99`` means for gcc on the MCU and in the C
tests), so that the simulator runs the controller's arithmetic bit for bit as written, whatever the
code's layout and whether the host has FMA. The rest of the extension (the simulator's plant,
``csrc/sim``) keeps the build script's flags (``-ffp-contract=fast``: fused multiply-adds where the
host has them, for speed).
"""

import os

from setuptools import setup
from setuptools.command.build_ext import build_ext


class BuildExt(build_ext):
    """``build_ext`` that compiles ``csrc/ctrl/*.c`` with ``-ffp-contract=off`` (see the module)."""

    def build_extension(self, ext):
        ctrl = [s for s in ext.sources if "csrc/ctrl/" in s.replace(os.sep, "/")]
        if ctrl and self.compiler.compiler_type == "unix":
            objects = self.compiler.compile(
                ctrl, output_dir=self.build_temp, include_dirs=ext.include_dirs, debug=self.debug,
                extra_postargs=[*ext.extra_compile_args, "-ffp-contract=off"], depends=ext.depends)
            ext.sources = [s for s in ext.sources if s not in ctrl]
            ext.extra_objects = [*(ext.extra_objects or []), *objects]
        super().build_extension(ext)


setup(cmdclass={"build_ext": BuildExt}, cffi_modules=["tools/build_ctrl.py:ffibuilder"])
