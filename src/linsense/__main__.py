"""The ``linsense`` console entry (``python -m linsense`` and the ``linsense`` script).

A tiny module: everything heavy (click, numpy, the compiled controller library) is imported inside
:func:`entry`'s ``try``, so that Ctrl-C during the start-up imports ends like Ctrl-C during a run,
with exit code 130 and the one line ``linsense: interrupted``, never a traceback.

The command runs numpy's BLAS on one thread unless ``OPENBLAS_NUM_THREADS`` is set: its linear
algebra is small (the C loop does the work), a sweep runs in parallel by runs, and OpenBLAS's
thread pool, started at numpy's import, costs about 50 ms of CPU in every process (a fifth of a
short ``linsense simulate``) and oversubscribes the cores of a sweep's worker threads.
"""

import os
import sys

#: exit code of a run stopped by Ctrl-C (128 + SIGINT), as a shell reports it
INTERRUPTED = 130


def entry(argv=None) -> None:
    """Run the CLI (:func:`linsense.cli.main`); Ctrl-C at any time, also while importing, exits 130.

    Parameters
    ----------
    argv : list of str, optional
        The arguments (default: ``sys.argv[1:]``).
    """
    # one BLAS thread (read once, at numpy's import, so set before it; the user's setting wins)
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    try:
        from linsense.cli import main

        main(argv)
    except KeyboardInterrupt:
        sys.stderr.write("linsense: interrupted\n")
        sys.stderr.flush()
        sys.exit(INTERRUPTED)


if __name__ == "__main__":
    entry()
