"""Build of the compiled part of linsense; everything else is declared in pyproject.toml.

``cffi_modules`` runs ``tools/build_ctrl.py`` (outside the package: wheels do not ship it), which
compiles the C99 firmware library (``csrc/``) into the extension ``linsense._ctrl`` at install
time, editable or not, with declarations generated from its headers.

The extension is compiled as the firmware is, with ISO C's floating-point contraction off
(``-ffp-contract=off``, what ``-std=c99`` means for gcc on the MCU and in the C tests): the
controller, its inline blocks and the binding's helpers compute bit for bit as written, whatever the
code's layout and whether the host has FMA. Only the simulator's plant (``csrc/sim/ls_sim_all.c``)
is compiled with ``-ffp-contract=fast`` (fused multiply-adds where the host has them, for speed).
"""

import os

from setuptools import setup
from setuptools.command.build_ext import build_ext


class BuildExt(build_ext):
    """``build_ext`` that compiles the plant (``csrc/sim/ls_sim_all.c``) with contraction on."""

    def build_extension(self, ext):
        plant = [s for s in ext.sources if s.replace(os.sep, "/").endswith("csrc/sim/ls_sim_all.c")]
        if plant and self.compiler.compiler_type == "unix":
            objects = self.compiler.compile(
                plant, output_dir=self.build_temp, include_dirs=ext.include_dirs, debug=self.debug,
                extra_postargs=[*ext.extra_compile_args, "-ffp-contract=fast"], depends=ext.depends)
            ext.sources = [s for s in ext.sources if s not in plant]
            ext.extra_objects = [*(ext.extra_objects or []), *objects]
        super().build_extension(ext)


setup(cmdclass={"build_ext": BuildExt}, cffi_modules=["tools/build_ctrl.py:ffibuilder"])
