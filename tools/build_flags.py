"""The compiler flags of the extension :mod:`linsense._ctrl`: their one home, tables only.

No cffi, no compiler run, no side effect: ``tools/build_ctrl.py`` (the cffi build), ``setup.py``
(``build_ext``, which picks a family by the compiler setuptools runs) and ``tools/pil.py`` (the host
recorder, compiled as the extension is) each read it once. It is a build input: the extension's
source digest (``linsense._digest.BUILD_INPUTS``) hashes it.

By family: gcc and clang (Linux, macOS, MinGW) -O3, C99, ISO C's floating-point contraction off as
the firmware is compiled (every controller operation rounds as written), the plant
(``csrc/sim/ls_sim_all.c``) with it on (fused multiply-adds: a fifth shorter dependency chains); MSVC
/O2 /fp:precise (no contraction). ``LINSENSE_NATIVE=1`` (the Makefile's venv) adds
:data:`NATIVE_ARGS` to gcc's (never in wheels).
"""

from __future__ import annotations

import os

#: tuned for the building machine: the Makefile's venv and the host recorder, never a wheel
NATIVE_ARGS = ["-march=native"]
_NATIVE = NATIVE_ARGS if os.environ.get("LINSENSE_NATIVE") == "1" else []
#: the library's, the binding's and the plant's flags, by compiler family
COMPILE_ARGS = {"gcc": ["-std=c99", "-O3", "-ffp-contract=off", *_NATIVE], "msvc": ["/O2", "/fp:precise"]}
#: what the plant (csrc/sim/ls_sim_all.c) adds, by compiler family
PLANT_ARGS = {"gcc": ["-ffp-contract=fast"], "msvc": []}
