"""linsense's version, in the lowest layer so that any module can name it (``linsense.__version__``
re-exports it; the package itself imports from the layers above)."""

__version__ = "0.1.0"
