"""What the commands share: option callbacks, name resolution, and the report (``logging``) and
JSON outputs.

Streams: the human report goes through the ``linsense.cli`` logger (``-q`` silences it, ``-v`` adds
detail) to standard output, or to standard error when standard output carries data (``--out -`` or
``--json``); warnings always go to standard error, errors too (one line, exit code 2). Nothing heavy
is imported here (numpy, pydantic, the C extension load inside the commands).
"""

from __future__ import annotations

import json
import logging
import math
import os
import sys
import time

import click

from linsense.limits import MAX_POINTS
from linsense.version import docs

MOTOR_HELP = "motor: a file, a preset (ecce2010) or a packaged example's name (small30)"

log = logging.getLogger("linsense.cli")


class _Report(logging.Handler):
    """The report's handler: INFO and DEBUG to standard output (standard error while standard
    output carries data), warnings and worse to standard error; the streams are looked up at each
    line (a test's captured streams, click's runner)."""

    to_stderr = False

    def emit(self, record: logging.LogRecord) -> None:
        msg = record.getMessage()
        if record.levelno >= logging.WARNING:
            msg = f"linsense: {record.levelname.lower()}: {msg}"
        to_stdout = not (record.levelno >= logging.WARNING or self.to_stderr)
        write_stream(sys.stdout if to_stdout else sys.stderr, msg + "\n", to_stdout)


def write_stream(stream, text: str, is_stdout: bool = True) -> None:
    """Write ``text`` to a standard stream and flush it.

    A stream that fails (a reader that stopped reading: broken pipe) is an
    :class:`~linsense.errors.OutputError` naming it, which the CLI's entry turns into one line and
    exit code 2 (it was logging's "--- Logging error ---" traceback); standard error failing is
    ignored (there is nowhere left to say it).
    """
    if stream is None and not is_stdout:
        return
    try:
        buf = getattr(stream, "buffer", None)
        if buf is None or not is_stdout:
            stream.write(text)
            stream.flush()
        else:  # (the whole of it: an unbuffered standard output may take a part and say nothing)
            from linsense.io import write_all

            stream.flush()
            write_all(buf, encoded(text, stream))
            buf.flush()
    except (OSError, ValueError, AttributeError) as exc:
        if not is_stdout:
            return
        from linsense.io import output_error

        if isinstance(exc, OSError):
            raise output_error("-", exc) from None
        from linsense.errors import OutputError

        raise OutputError("<stdout>", "cannot write: standard output is closed") from None


def encoded(text: str, stream) -> bytes:
    """``text`` in the encoding of ``stream``, what it cannot show escaped (``\\xe9``), as standard
    error shows it: a folder named ``out é`` under ``PYTHONIOENCODING=ascii`` (or a Latin-1 locale)
    was written, then "standard output is closed", exit 2.

    Parameters
    ----------
    text : str
        The text.
    stream : text stream
        Its ``encoding`` and ``errors`` are used (UTF-8 and strict when it has none).

    Returns
    -------
    bytes
        The bytes to write.
    """
    encoding = getattr(stream, "encoding", None) or "utf-8"
    try:
        return text.encode(encoding, getattr(stream, "errors", None) or "strict")
    except UnicodeEncodeError:
        return text.encode(encoding, "backslashreplace")


_handler = _Report()
log.addHandler(_handler)
log.propagate = False


class _MatplotlibConfig(logging.Filter):
    """matplotlib's own lines about a settings folder it cannot write (a read-only or missing HOME):
    "mkdir -p failed for path ...: [Errno 13] ..." and "Matplotlib created a temporary cache
    directory at ...", at every run and under ``-q`` too, become one linsense warning."""

    NOISE = ("mkdir -p failed for path", "Matplotlib created a temporary cache directory",
             "%s is not a writable")

    def filter(self, record: logging.LogRecord) -> bool:
        msg = str(record.msg)
        if not msg.startswith(self.NOISE):
            return True
        if msg.startswith("Matplotlib created") and isinstance(record.args, tuple) and len(record.args) == 2:
            warn(f"matplotlib has no writable folder for its settings and font cache ({record.args[1]}): it "
                 "uses a temporary one, rebuilt at every run (slower): set MPLCONFIGDIR to a writable folder")
        return False


logging.getLogger("matplotlib").addFilter(_MatplotlibConfig())


def configure(quiet: bool, verbose: bool) -> None:
    """Set the report's level for one invocation: ``-q`` warnings and errors only, ``-v`` details
    too, else the report (INFO)."""
    log.setLevel(logging.WARNING if quiet else logging.DEBUG if verbose else logging.INFO)
    _handler.to_stderr = False
    _STATE.update(t0=time.perf_counter(), cpu0=time.process_time())


_STATE: dict = {}


def data_on_stdout() -> None:
    """Standard output carries data from now on (``--out -``, ``--json``): the report moves to
    standard error."""
    _handler.to_stderr = True


def say(line: str) -> None:
    """One line of the human report."""
    log.info("%s", line)


def detail(line: str) -> None:
    """One line shown with ``-v`` only."""
    log.debug("%s", line)


def warn(line: str) -> None:
    """A warning, on standard error (also with ``-q``)."""
    log.warning("%s", line)


def quiet() -> bool:
    """``-q`` given: no report, so no progress bar either."""
    return not log.isEnabledFor(logging.INFO)


def progress() -> bool:
    """Draw progress bars: standard error is a terminal and ``-q`` not given."""
    return sys.stderr.isatty() and not quiet()


def elapsed() -> None:
    """``-v``: the command's CPU and wall time."""
    if "t0" in _STATE:
        cpu, wall = time.process_time() - _STATE["cpu0"], time.perf_counter() - _STATE["t0"]
        detail(f"({cpu:.2f} s CPU, {wall:.2f} s wall in the command)")


def _plain(obj):
    """JSON-safe: non-finite floats as null, tuples and numpy scalars and arrays as plain values."""
    if isinstance(obj, dict):
        return {str(k): _plain(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [_plain(v) for v in obj]
    if isinstance(obj, bool) or obj is None or isinstance(obj, str | int):
        return obj
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if hasattr(obj, "tolist"):  # numpy scalars and arrays
        return _plain(obj.tolist())
    if isinstance(obj, os.PathLike):
        return os.fspath(obj)
    return str(obj)


def emit_json(command: str, files, ok: bool | None, **fields) -> None:
    """The ``--json`` summary: one JSON object on standard output, keys sorted (docs/cli.md lists
    them): ``command``, ``files`` (written, in order), ``ok`` (what the command checks held), and
    the command's own ``fields``."""
    doc = {"command": command, "files": [os.fspath(f) for f in files], "ok": ok, **fields}
    write_stream(sys.stdout, json.dumps(_plain(doc), indent=1, sort_keys=True, allow_nan=False) + "\n")


# ------------------------------------------------------------------ the standard streams
#: the one line for a command started with its standard output closed (``>&-``)
STDOUT_CLOSED = ("standard output is closed (>&-): the report, --json and --out - are written there; "
                 "redirect it to /dev/null to discard them")


def std_streams() -> str | None:
    """Check the standard streams at the command's start: the one place that handles closed ones.

    A closed standard stream (``<&-``, ``>&-``, ``2>&-``: Python then sets ``sys.stdin`` and the
    others to None, and the next file opened takes the free descriptor) gets ``os.devnull`` on its
    descriptor, so that no output file is ever opened as descriptor 0, 1 or 2 (where a C library's
    or a child's writes would land in it). A closed standard error is then written to
    ``os.devnull`` (nowhere left to say anything; the exit code still tells); a closed standard
    input is refused when read (:func:`read_stdin`); a closed standard output is the command's
    refusal, returned here (it was an AttributeError traceback after the work was done).

    Returns
    -------
    str or None
        The message of the refusal (:data:`STDOUT_CLOSED`), or None.
    """
    for fd, stream, mode in ((0, sys.stdin, os.O_RDONLY), (1, sys.stdout, os.O_WRONLY),
                             (2, sys.stderr, os.O_WRONLY)):
        if stream is not None:
            continue
        try:
            os.fstat(fd)  # (taken already by a file opened meanwhile: left alone)
        except OSError:
            null = os.open(os.devnull, mode)
            if null != fd:
                os.dup2(null, fd)
                os.close(null)
    if sys.stderr is None:
        sys.stderr = open(os.devnull, "w", encoding="utf-8")  # noqa: SIM115 (for the process' life)
    return STDOUT_CLOSED if sys.stdout is None else None


def read_stdin() -> bytes:
    """The bytes of standard input (``-`` as a file argument), at most one more than
    :data:`~linsense.limits.MAX_TEXT_FILE_BYTES` (:func:`linsense.io.decode_text` refuses more).

    Returns
    -------
    bytes
        What was read.

    Raises
    ------
    linsense.errors.InputError
        Standard input closed (``<&-``), unreadable, or empty.
    """
    from linsense.errors import InputError
    from linsense.io import os_reason
    from linsense.limits import MAX_TEXT_FILE_BYTES

    stdin = sys.stdin
    if stdin is None or getattr(stdin, "closed", False):
        raise InputError("<stdin>", "", "standard input is closed (<&-): pipe the scenario in (< file.toml), "
                                        "or give its file instead of -")
    try:
        buf = getattr(stdin, "buffer", None)
        data = buf.read(MAX_TEXT_FILE_BYTES + 1) if buf is not None else \
            stdin.read(MAX_TEXT_FILE_BYTES + 1).encode()
    except OSError as exc:
        raise InputError("<stdin>", "", f"cannot read standard input: {os_reason(exc)}") from None
    if not data:
        raise InputError("<stdin>", "", "empty: standard input holds nothing (pipe the scenario in: "
                                        "< file.toml, or give its file instead of -)")
    return data


def discard_stdout() -> None:
    """Point standard output's descriptor at ``os.devnull`` after it failed (a broken pipe), so that
    the interpreter's last flush does not print "Exception ignored ... BrokenPipeError"."""
    try:
        fd = sys.stdout.fileno()
        null = os.open(os.devnull, os.O_WRONLY)
    except (AttributeError, OSError, ValueError):  # (a test's captured stream: nothing to do)
        return
    os.dup2(null, fd)
    os.close(null)


def json_option(f):
    """``--json``: the command's summary as one JSON object on standard output."""
    return click.option("--json", "as_json", is_flag=True,
                        help="print a machine-readable summary: one JSON object on standard output "
                             "(the report goes to standard error)")(f)


def files_report(files) -> None:
    """The files written, one a line."""
    for f in files:
        say(str(f))


def points(ctx, param, value: int) -> int:
    """Click callback: a table length in [4, MAX_POINTS]."""
    if value < 4:
        raise click.BadParameter(f"must be >= 4, got {value}")
    if value > MAX_POINTS:
        raise click.BadParameter(f"{value:,} is beyond the limit of {MAX_POINTS:,} ({docs('limits')})")
    return value


def quad(ctx, param, value):
    """Click callback: the injection's q-axis share kappa, in [0, 1), or None (90 for 0.9: "did you
    type %?")."""
    from linsense.plausible import slip

    def ok(v: float) -> bool:
        return math.isfinite(v) and 0.0 <= v < 1.0

    if value is not None and not ok(value):
        hint = slip("share", value, ok=ok)
        raise click.BadParameter(f"must be in [0, 1), got {value!r}" + (f"; {hint}" if hint else ""))
    return value


def plausible(kind: str, unit: str | None = None):
    """Click callback: a finite number within the plausible range of ``kind``
    (:data:`linsense.plausible.KINDS`; in ``unit``, default the kind's), or None; a value outside
    is refused with the slip of unit that brings it in."""
    from linsense.plausible import implausible

    def check(ctx, param, value):
        if value is None:
            return value
        msg = implausible(kind, value, unit)
        if not math.isfinite(value):
            msg = f"must be a finite number, got {value!r}"
        if msg is not None:
            raise click.BadParameter(msg)
        return value

    return check


def finite(minimum: float, strict: bool):
    """Click callback: a finite number ``> minimum`` (``>=`` unless ``strict``), or None."""

    def check(ctx, param, value):
        if value is None:
            return value
        ok = math.isfinite(value) and (value > minimum if strict else value >= minimum)
        if not ok:
            op = ">" if strict else ">="
            bound = f" {op} {minimum:g}" if math.isfinite(minimum) else ""
            raise click.BadParameter(f"must be a finite number{bound}, got {value!r}")
        return value

    return check


def load(spec: str):
    """The motor ``spec`` names (a file, a preset, a packaged example)."""
    from linsense.model.motor import load_motor

    motor = load_motor(spec)
    detail(f"motor {spec!r}: {motor.source}")
    return motor


def example(kind: str, spec: str, key: str, extra: tuple[str, ...] = ()) -> str:
    """A file argument resolved: a path if it exists, else the packaged example of ``kind`` it
    names, else exit code 2 and one line listing the names (:func:`linsense.examples.resolve`)."""
    from linsense import examples

    path = examples.resolve(kind, spec, key, extra)
    if path != spec:
        detail(f"{spec}: the packaged example {path}")
    return path


#: the help of an ``--out`` that has a default (:func:`default_out`)
OUT_HELP = "(default: NAME-{command}{ext} in the working folder, NAME the {what}'s)"


def out_option(command: str, what: str, *, folder: bool, ext: str = "", dash: bool = False):
    """``--out`` with the default of :func:`default_out` (it was required by every command).

    Parameters
    ----------
    command : str
        The command, in the default's name.
    what : str
        What the default is named after ("scenario", "motor"), for the help.
    folder : bool
        An output folder (else a file).
    ext : str, optional
        The file's extension in the help (``.csv``; a command whose extension follows its format
        gives it in words).
    dash : bool, optional
        ``-`` writes to standard output.
    """
    kind = "output folder" if folder else "output file" + (" (- for standard output)" if dash else "")
    path = click.Path(file_okay=False) if folder else click.Path(dir_okay=False, allow_dash=dash)
    default = OUT_HELP.format(command=command, ext=ext or ("/" if folder else ""), what=what)
    return click.option("--out", default=None, type=path, callback=folder_out if folder else file_out,
                        help=f"{kind} {default}")


def file_out(ctx, param, value):
    """Click callback of an output file (and, through :func:`folder_out`, of a folder): a loop of
    symbolic links is refused before the work (:func:`linsense.io.out_target`, the one resolution
    of every output; it was refused after a certificate's run, or never)."""
    if value is not None and value != "-":
        from linsense.io import out_target

        not_empty(ctx, param, value)
        out_target(value)
    return value


def not_empty(ctx, param, value):
    """Click callback of a path: an empty one is refused (``--out "$DIR"`` with ``DIR`` unset wrote a
    sweep or the examples into the working folder, ``--table ""`` was ".: is a folder")."""
    if value is not None and not str(value).strip():
        raise click.BadParameter("empty: give a path (an unset shell variable?)")
    return value


def folder_out(ctx, param, value):
    """Click callback of an output folder: ``-`` is refused (it made a folder named ``-`` where
    ``--out -`` of a file means standard output); then :func:`file_out`."""
    if value == "-":
        raise click.BadParameter("a folder is written here, not standard output: give the folder's name "
                                 "(./- for a folder named -)")
    return file_out(ctx, param, value)


def default_out(out: str | None, name: str, command: str, ext: str = "") -> str:
    """The ``--out`` of a command, ``NAME-COMMAND[EXT]`` in the working folder when none is given.

    One rule for every command that writes an output (docs/cli.md, "Outputs"): ``NAME`` is what the
    command runs on, as given (a file's stem, a preset's or example's name; a scenario from standard
    input: its ``[scenario] name``), made safe for a file name (:func:`linsense.io.safe_name`);
    ``EXT`` the file's extension (none for a folder). The report says where it writes.

    Parameters
    ----------
    out : str or None
        The ``--out`` given.
    name : str
        The argument the command runs on (``step3_lut``, ``motors/m.toml``).
    command : str
        The command (``simulate``).
    ext : str, optional
        The file's extension with its dot; "" for an output folder.

    Returns
    -------
    str
        ``out``, or the default.
    """
    if out is not None:
        return out
    from pathlib import PurePath

    from linsense.io import safe_name

    stem = PurePath(name.rstrip("/\\")).name
    if PurePath(stem).suffix in (".toml", ".csv", ".json"):
        stem = PurePath(stem).stem
    path = f"{safe_name(stem)}-{command}{ext}"
    say(f"no --out given: writing {path}{'' if ext else '/'} (docs/cli.md, \"Outputs\")")
    return path


def show(v: float | None, unit: str, fmt: str = ".2f") -> str:
    """A metric for a person: 'n/a' where it is not defined."""
    return "n/a" if v is None else f"{v:{fmt}} {unit}"


def see(page: str) -> str:
    """A command's help epilog: its page on the docs site."""
    return f"Documentation: {docs(page)}"
