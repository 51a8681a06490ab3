"""The ``linsense`` command (click): each command reads its options and files and runs the package.

Bad input (a :class:`~linsense.errors.LinsenseError` or a usage error) ends with exit code 2 and a
single line on stderr naming the file, key and value; no traceback, and no output file: every
output is checked before anything is written, and written atomically. The commands live in
:mod:`linsense.cli.models`, :mod:`linsense.cli.runs` and :mod:`linsense.cli.tune`; what they
share (the report through ``logging``, ``--json``, name resolution) in ``linsense.cli._common``.
"""

from __future__ import annotations

import sys

import click

from linsense.cli import _common, firmware, models, runs, tune
from linsense.errors import LinsenseError
from linsense.version import __version__, docs


def _version(ctx: click.Context, _param: click.Parameter, value: bool) -> None:
    """``--version``: the package's version and the C library's (``LS_VERSION_*``, ls_types.h)."""
    if not value or ctx.resilient_parsing:
        return
    from linsense.ctrl import ffi, lib

    c_version = f"{lib.LS_VERSION_MAJOR}.{lib.LS_VERSION_MINOR}.{lib.LS_VERSION_PATCH}"
    real = "float" if ffi.sizeof("LS_REAL") == 4 else "double"
    click.echo(f"linsense {__version__} (C library {c_version}, LS_REAL {real})")
    ctx.exit()


class _Interrupted(Exception):
    """Ctrl-C, carried past click (which would print an empty line and abort)."""


class _Group(click.Group):
    """The group, with Ctrl-C during parsing (``--version`` imports the C extension) or a command
    (the imports of numpy and the rest) handed to :func:`main` as it is: one line, exit code 130."""

    def make_context(self, *args, **kwargs):
        try:
            return super().make_context(*args, **kwargs)
        except KeyboardInterrupt as exc:
            raise _Interrupted from exc

    def invoke(self, ctx):
        try:
            return super().invoke(ctx)
        except KeyboardInterrupt as exc:
            raise _Interrupted from exc


@click.group(cls=_Group, context_settings={"help_option_names": ["-h", "--help"]},
             epilog=f"Documentation: {docs('cli')}")
@click.option("--version", is_flag=True, expose_value=False, is_eager=True, callback=_version,
              help="Show the version of linsense and of its C library, and exit.")
@click.option("-q", "--quiet", is_flag=True, help="No report: warnings and errors only.")
@click.option("-v", "--verbose", is_flag=True, help="More detail in the report (resolved names, timing).")
def cli(quiet: bool, verbose: bool) -> None:
    """End-effect-aware HF-injection sensorless control of linear PM motors."""
    if quiet and verbose:
        raise click.UsageError("-q and -v contradict each other: give one")
    _common.configure(quiet, verbose)
    from linsense.io import working_folder

    working_folder()  # (a deleted one refused naming it, before the work: docs/cli.md, "Outputs")
    import numpy as np  # (every command computes with it: its warnings are judged by the commands)

    np.seterr(all="ignore")


for _cmd in models.COMMANDS + runs.COMMANDS + tune.COMMANDS + firmware.COMMANDS:
    cli.add_command(_cmd)


def main(argv: list[str] | None = None) -> None:
    """Entry point: run the CLI, mapping every expected failure to exit code 2 and one line.

    The one place that handles the standard streams (:func:`linsense.cli._common.std_streams`): a
    closed standard output is refused before anything runs, and a standard output that fails on
    the way (a broken pipe) ends with one line and exit code 2, never a traceback.

    Parameters
    ----------
    argv : list of str, optional
        The arguments (default: ``sys.argv[1:]``).
    """
    _common.configure(False, False)  # (a fresh report for each call, also when parsing fails)
    closed = _common.std_streams()
    if closed is not None:
        _fail(closed)
    rc = _run(argv)
    try:
        sys.stdout.flush()  # (what is still buffered fails here, not in the interpreter's exit)
    except (OSError, ValueError) as exc:
        _common.discard_stdout()
        if rc == 0:
            from linsense.io import output_error

            rc = _error(output_error("-", exc) if isinstance(exc, OSError) else
                        "<stdout>: cannot write: standard output is closed")
    sys.exit(rc)


def _fail(message: str) -> None:
    """One line on standard error and exit code 2."""
    click.echo(f"linsense: error: {message}".replace("\n", " "), err=True)
    sys.exit(2)


def _error(message) -> int:
    click.echo(f"linsense: error: {message}".replace("\n", " "), err=True)
    return 2


def _run(argv: list[str] | None) -> int:
    """Run the command; its exit code (each failure said in one line)."""
    try:
        # in this mode click returns the code of a click.exceptions.Exit instead of exiting
        rc = cli.main(args=argv, prog_name="linsense", standalone_mode=False)
        return rc if isinstance(rc, int) else 0
    except click.exceptions.Exit as exc:
        return exc.exit_code
    except click.Abort as exc:
        if isinstance(exc.__cause__, KeyboardInterrupt):  # (click turns Ctrl-C into Abort)
            click.echo("linsense: interrupted", err=True)
            return 130
        click.echo("linsense: aborted", err=True)
        return 1
    except (KeyboardInterrupt, _Interrupted):  # Ctrl-C: the run stops within a second, no output written
        click.echo("linsense: interrupted", err=True)
        return 130
    except click.UsageError as exc:
        ctx = f"{exc.ctx.command_path}: " if exc.ctx else ""
        return _error(f"{ctx}{exc.format_message()}")
    except LinsenseError as exc:  # (InputError is a LinsenseError)
        return _error(exc)
    except OSError as exc:  # (one not met by a writer: the path and the reason in words, no errno)
        from linsense.io import os_reason

        where = exc.filename if exc.filename is not None else \
            "<stdout>" if isinstance(exc, BrokenPipeError) else None
        return _error(f"{where}: {os_reason(exc)}" if where is not None else os_reason(exc))
    except ValueError as exc:
        return _error(exc)


if __name__ == "__main__":  # pragma: no cover
    main()
