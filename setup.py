"""Build of the compiled part of linsense; everything else is declared in pyproject.toml.

``cffi_modules`` runs ``src/linsense/_build_ctrl.py``, which compiles the C99 firmware library
(``csrc/ctrl/*.c``) into the extension ``linsense._ctrl`` at install time, editable or not.
"""

from setuptools import setup

setup(cffi_modules=["src/linsense/_build_ctrl.py:ffibuilder"])
