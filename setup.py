"""Build of the compiled part of linsense; everything else is declared in pyproject.toml.

``cffi_modules`` runs ``tools/build_ctrl.py`` (outside the package: wheels do not ship it), which
compiles the C99 firmware library (``csrc/``) into the extension ``linsense._ctrl`` at install
time, editable or not, with declarations generated from its headers.
"""

from setuptools import setup

setup(cffi_modules=["tools/build_ctrl.py:ffibuilder"])
