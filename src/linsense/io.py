"""Atomic file output: a failed run never leaves a half-written file behind.

Single files go through :func:`write_atomic` (a temporary file and a rename); the commands that
write several files write them as one set with :func:`output_set` (a temporary sibling folder
swapped into place, with a manifest :data:`MANIFEST`). Names a user controls go into file names
only through :func:`safe_name`.
"""

from __future__ import annotations

import errno
import json
import math
import os
import re
import secrets
import shutil
import signal
import stat
import sys
import tempfile
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

#: what reports a line of a command's API (its report, a warning, a detail): ``print``, a logger's
#: method, ``list.append`` or :func:`quiet`
Say = Callable[[str], object]


def quiet(_: str) -> None:
    """Say nothing: the default ``say`` (and ``warn``, ``detail``) of the commands' APIs.

    Parameters
    ----------
    _ : str
        The line, dropped.
    """


#: a number written with a decimal comma ("1,5", "-0,25e-3"): refused by name, not as "not a number"
_DECIMAL_COMMA = re.compile(r"\s*[+-]?\d*,\d+([eE][+-]?\d+)?\s*")


def finite_cell(source: str, row: int, column: str, cell: str) -> float:
    """Parse one CSV cell as a finite number.

    Parameters
    ----------
    source : str
        The file, for messages.
    row : int
        Its line number.
    column : str
        Its column's name.
    cell : str
        The text.

    Returns
    -------
    float
        The number.

    Raises
    ------
    linsense.errors.InputError
        Empty, not a number or not finite, naming row and column.
    """
    from linsense.errors import InputError

    try:
        v = float(cell)
    except ValueError:
        if _DECIMAL_COMMA.fullmatch(cell):
            raise InputError(source, f"row {row}, column {column}",
                             f"decimal commas are not read: use a point (got {cell!r})") from None
        raise InputError(source, f"row {row}, column {column}", f"not a number: {cell!r}") from None
    if not math.isfinite(v):
        raise InputError(source, f"row {row}, column {column}", f"not finite: {cell!r}")
    return v


def read_csv_table(path: str | os.PathLike, columns: tuple[str, ...], what: str):
    """The named ``columns`` of a user's CSV table as finite floats, shape ``(rows, len(columns))``,
    and each row's line number in the file (for messages).

    Read line by line with every size bounded before it is kept (docs/limits.md): at most
    :data:`~linsense.limits.MAX_TABLE_ROWS` data rows, :data:`~linsense.limits.MAX_TABLE_COLUMNS`
    columns and :data:`~linsense.limits.MAX_TABLE_FIELD_CHARS` characters a field; only the named
    columns are kept. A UTF-8 byte-order mark is skipped; semicolon separators and decimal commas
    are refused by name (they read as one column, or as more fields than the header has); every row
    must have the header's number of fields (empty lines are skipped). Other columns are allowed
    (``linsense model`` writes more).

    Parameters
    ----------
    path : str or path
        The CSV file; its first line is the header.
    columns : tuple of str
        The columns wanted, each required.
    what : str
        What the file is, for the messages ("inductance table").

    Returns
    -------
    data : ndarray, shape (rows, len(columns))
    line : ndarray of int, shape (rows,)
        The line of each row in the file (the header is line 1).

    Raises
    ------
    InputError
        Naming the file, the row and column, the value or the count and the limit.
    """
    import array

    import numpy as np

    from linsense.errors import InputError

    src = str(path)
    rows = csv_rows(path, what)
    header = next(rows)[1]
    missing = [c for c in columns if c not in header]
    if missing:
        if any(";" in h for h in header):
            raise InputError(src, "row 1", f"{_SEMICOLONS} (and decimal commas are not read: use "
                                           f"a point); need the columns {','.join(columns)}")
        raise InputError(src, f"column {missing[0]}", f"missing column (need {','.join(columns)})")
    idx = [header.index(c) for c in columns]
    values, numbers = array.array("d"), array.array("q")
    for number, row in rows:
        if len(row) >= len(header):  # (a bad cell is named first, then a count)
            cells = [finite_cell(src, number, name, row[c].strip())
                     for c, name in zip(idx, columns, strict=True)]
        check_width(src, number, row, header)
        values.extend(cells)
        numbers.append(number)
    return (np.frombuffer(values, dtype=float).reshape(-1, len(columns)).copy(),
            np.frombuffer(numbers, dtype=np.int64).copy())


_SEMICOLONS = "semicolon separators are not read: separate the columns with commas"


def check_width(src: str, number: int, row: list[str], header: list[str]) -> None:
    """Refuse a row with another number of fields than the header.

    Parameters
    ----------
    src : str
        The file, for messages.
    number : int
        The row's line number.
    row : list of str
        Its cells.
    header : list of str
        The header's.

    Raises
    ------
    linsense.errors.InputError
        Naming the row, with the likely cause (semicolons, decimal commas).
    """
    from linsense.errors import InputError

    if len(row) != len(header):
        hint = ""
        if any(";" in c for c in row):
            hint = f" ({_SEMICOLONS})"
        elif len(row) > len(header) and any(c.strip().isdigit() for c in row):
            hint = " (decimal commas are not read: use a point)"
        raise InputError(src, f"row {number}", f"{len(row)} fields for the header's "
                                               f"{len(header)} columns{hint}")


def csv_rows(path: str | os.PathLike, what: str):
    """The rows of a user's CSV file, each size bounded before it is kept (docs/limits.md), as
    ``(line, cells)``: first the header (line 1, its cells stripped), then every non-empty data row.

    At most :data:`~linsense.limits.MAX_TABLE_ROWS` data rows, :data:`~linsense.limits.MAX_TABLE_COLUMNS`
    columns and :data:`~linsense.limits.MAX_TABLE_FIELD_CHARS` characters a field; a UTF-8 byte-order
    mark is skipped; a file that cannot be read, is not UTF-8 or has no header is refused. The one
    CSV reader of every table a user gives (inductance and saturation tables, LUTs, bench files);
    :func:`check_width` checks a row's number of fields.

    Parameters
    ----------
    path : str or os.PathLike
        The file.
    what : str
        What the file is ("LUT", "bench file"...), for messages.

    Yields
    ------
    tuple of (int, list of str)
        ``(line, cells)``.

    Raises
    ------
    InputError
        Naming the file, the row (and column), the count or size and the limit.
    """
    import csv

    from linsense.errors import InputError
    from linsense.limits import MAX_TABLE_COLUMNS, MAX_TABLE_FIELD_CHARS, MAX_TABLE_ROWS

    src = str(path)
    max_line = MAX_TABLE_COLUMNS * (MAX_TABLE_FIELD_CHARS + 3) + 2  # (quotes, separators, CRLF)
    field_limit = f"field larger than field limit of {MAX_TABLE_FIELD_CHARS} characters (docs/limits.md)"
    col_limit = f"beyond the limit of {MAX_TABLE_COLUMNS} columns (docs/limits.md)"
    number = 0  # the line being read, 1-based (the header is row 1)

    def lines(f):
        nonlocal number
        while True:
            line = f.readline(max_line + 1)
            if not line:
                return
            number += 1
            if number > MAX_TABLE_ROWS + 1:
                raise InputError(src, "", f"more than {MAX_TABLE_ROWS:,} rows: beyond the limit of "
                                          f"{MAX_TABLE_ROWS:,} rows of a table (docs/limits.md)")
            if len(line) > max_line:
                parts = line.split(",")
                if len(parts) > MAX_TABLE_COLUMNS:
                    raise InputError(src, f"row {number}", f"{len(parts) - 1:,}+ columns: {col_limit}")
                raise InputError(src, f"row {number}", field_limit)
            yield line

    try:
        with open(path, newline="", encoding="utf-8-sig") as f:
            reader = csv.reader(lines(f))
            first = next(reader, [])
            header = [h.strip() for h in _checked_row(src, number, first)]
            if not header or header == [""]:
                raise InputError(src, "", f"empty {what} (no header)")
            yield 1, header
            for row in reader:
                row = _checked_row(src, number, row)
                if not row or all(not c.strip() for c in row):
                    continue
                yield number, row
    except FileNotFoundError:
        raise InputError(src, "", f"no such {what}") from None
    except OSError as exc:  # (the reason in words: no errno, the path once)
        raise InputError(src, "", f"cannot read {what}: {os_reason(exc)}") from None
    except (UnicodeDecodeError, csv.Error) as exc:
        raise InputError(src, "", f"cannot read {what}: {exc}") from None


def _checked_row(src: str, number: int, row: list[str]) -> list[str]:
    """``row`` (line ``number`` of ``src``), refused beyond the columns' or a field's limit."""
    from linsense.errors import InputError
    from linsense.limits import MAX_TABLE_COLUMNS, MAX_TABLE_FIELD_CHARS

    if len(row) > MAX_TABLE_COLUMNS:
        raise InputError(src, f"row {number}",
                         f"{len(row):,} columns: beyond the limit of {MAX_TABLE_COLUMNS} columns "
                         "(docs/limits.md)")
    for j, cell in enumerate(row):
        if len(cell) > MAX_TABLE_FIELD_CHARS:
            raise InputError(src, f"row {number}, column {j + 1}",
                             f"field larger than field limit of {MAX_TABLE_FIELD_CHARS} characters "
                             f"(docs/limits.md): a field of {len(cell):,} characters")
    return row


def read_text_file(path: str | os.PathLike, what: str) -> str:
    """Text of a user file.

    Parameters
    ----------
    path : str or os.PathLike
        The file.
    what : str
        What was expected ("motor file"...), for messages.

    Returns
    -------
    str
        The text.

    Raises
    ------
    linsense.errors.InputError
        Naming the file: missing, unreadable, not UTF-8 or too large.
    """
    from linsense.errors import InputError
    from linsense.limits import MAX_TEXT_FILE_BYTES

    src = str(path)
    p = Path(path)
    if not p.is_file():
        if p.is_dir():
            raise InputError(src, "", f"is a folder, not a {what}")
        why = f"no such {what}" if not p.exists() else f"not a regular file: expected a {what}"
        raise InputError(src, "", why)
    try:
        with open(p, "rb") as f:
            data = f.read(MAX_TEXT_FILE_BYTES + 1)  # (bounded: no more is read)
    except OSError as exc:
        raise InputError(src, "", f"cannot read: {exc.strerror or exc}") from None
    return decode_text(data, src, what)


def decode_text(data: bytes, source: str, what: str) -> str:
    """The text of a user's file (or standard input) from its bytes.

    The one decoder of every text a user gives (TOML, JSON): UTF-8, a leading byte-order mark
    skipped (as the CSV readers skip it: a BOM was "Invalid statement at line 1, column 1"), at most
    :data:`~linsense.limits.MAX_TEXT_FILE_BYTES` bytes.

    Parameters
    ----------
    data : bytes
        The bytes read (at most one more than the limit).
    source : str
        The file, or ``<stdin>``, for messages.
    what : str
        What was expected ("scenario file"...), for messages.

    Returns
    -------
    str
        The text, without a byte-order mark.

    Raises
    ------
    linsense.errors.InputError
        Naming ``source``: too large, UTF-16, or not UTF-8 (with the byte's offset).
    """
    from linsense.errors import InputError
    from linsense.limits import MAX_TEXT_FILE_BYTES

    if len(data) > MAX_TEXT_FILE_BYTES:
        raise InputError(source, "", f"larger than the limit of {MAX_TEXT_FILE_BYTES:,} bytes of a {what} "
                                     "(docs/limits.md)")
    if data[:2] in (b"\xff\xfe", b"\xfe\xff"):  # (Windows' "Unicode": a BOM of UTF-16)
        raise InputError(source, "", f"cannot read: UTF-16 text (a byte-order mark of UTF-16): save the "
                                     f"{what} as UTF-8")
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise InputError(source, "", f"cannot read: not UTF-8 text (byte {exc.start}: "
                                     f"{data[exc.start:exc.start + 1]!r})") from None


def parse_toml(text: str, source: str) -> dict:
    """The data of a TOML text.

    The one TOML parser of every reader: a leading byte-order mark is skipped; an empty text (only
    blanks and comments) is refused as empty; arrays and tables nested deeper than
    :data:`linsense.limits.MAX_TOML_DEPTH` are refused (a 900-deep array was a RecursionError
    traceback in every reader).

    Parameters
    ----------
    text : str
        The TOML text.
    source : str
        Its name in messages.

    Returns
    -------
    dict
        The data.

    Raises
    ------
    linsense.errors.InputError
        Naming ``source``.
    """
    import tomllib

    from linsense.errors import InputError
    from linsense.limits import MAX_TOML_DEPTH

    deep = f"arrays or tables nested deeper than the limit of {MAX_TOML_DEPTH} (docs/limits.md)"
    try:
        data = tomllib.loads(text.removeprefix("\ufeff"))  # (a byte-order mark: see decode_text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError(source, "", f"not valid TOML: {exc}") from None
    except RecursionError:
        raise InputError(source, "", deep) from None
    stack = [(data, 1)]
    while stack:  # (iterative: the check itself must not recurse)
        obj, depth = stack.pop()
        if depth > MAX_TOML_DEPTH:
            raise InputError(source, "", deep)
        children = obj.values() if isinstance(obj, dict) else obj
        stack.extend((c, depth + 1) for c in children if isinstance(c, (dict, list)))
    if not data:  # (empty standard input was "reference.position_mm: missing required key")
        raise InputError(source, "", "empty: no TOML keys in it (nothing, or only blanks and comments)")
    return data


def read_toml(path: str | os.PathLike, what: str) -> dict:
    """The data of a user's TOML file.

    Parameters
    ----------
    path : str or os.PathLike
        The file.
    what : str
        What was expected, for messages.

    Returns
    -------
    dict
        The data.

    Raises
    ------
    linsense.errors.InputError
        Naming the file.
    """
    return parse_toml(read_text_file(path, what), str(path))


#: the reasons an output cannot be written, in words (an OSError showed ``[Errno 28]`` and the
#: temporary file's name)
_REASONS = {
    errno.EROFS: "read-only file system",
    errno.EACCES: "permission denied",
    errno.EPERM: "permission denied (operation not permitted)",
    errno.ENOSPC: "no space left on the device",
    errno.EDQUOT: "disk quota exceeded",
    errno.EFBIG: "file too large for the file system",
    errno.ENAMETOOLONG: "file name too long",
    errno.ENOTDIR: "a folder on its path is a file",
    errno.EIO: "input/output error of the device",
    errno.EPIPE: "broken pipe (its reader stopped reading)",
    errno.ELOOP: "a loop of symbolic links on its path",
}


# ------------------------------------------------------------------ paths: never normalised by text
#: the bytes of a file name on the usual file systems (ext4, XFS, btrfs, APFS, NTFS's 255 characters)
NAME_MAX = 255


def folder_of(path: str | os.PathLike) -> Path:
    """The folder a file's relative paths are taken from: its own, or, for a symbolic link to the
    file, the folder of the file it points to.

    The one rule of every reader of a file that names others (a scenario its motor and table, a
    motor file its tables, a sweep file its base scenario): ``ln -s real/scenarios/s.toml .`` then
    ``simulate s.toml`` reads ``motor = "../motors/m.toml"`` beside ``real/scenarios/``, where it
    was written, not beside the link. The path is never normalised by its text (``lk/..`` after a
    linked folder ``lk`` is its target's parent: the operating system resolves it).

    Parameters
    ----------
    path : str or os.PathLike
        The file.

    Returns
    -------
    Path
        Its folder.
    """
    p = Path(path)
    return Path(os.path.realpath(p)).parent if p.is_symlink() else p.parent


def out_target(out: str | os.PathLike) -> Path:
    """The real path an output (``--out``, a file or a folder) names: symbolic links followed.

    The one resolution of every output: a link to a file or a folder is followed (its target is
    written or replaced, the link kept), a dangling link names the path to create, a loop of links
    is refused naming it (it was "exists and is not a folder", "File exists" or "Too many levels of
    symbolic links").

    Parameters
    ----------
    out : str or os.PathLike
        The output as given.

    Returns
    -------
    Path
        The absolute path with every symbolic link resolved.

    Raises
    ------
    linsense.errors.OutputError
        A loop of symbolic links on the way.
    """
    from linsense.errors import OutputError

    try:
        return Path(os.path.realpath(os.fspath(out), strict=True))
    except FileNotFoundError:  # (a path to create, or a dangling link: resolved as far as it goes)
        pass
    except OSError as exc:
        if exc.errno == errno.ELOOP:
            raise OutputError(out, "a loop of symbolic links (a link that leads back to itself): fix or "
                                   "remove the link, or choose another output") from None
        # (another reason, a folder on the way not searchable: the write that follows names it)
    return Path(os.path.realpath(os.fspath(out)))


def working_folder() -> Path:
    """The working folder, or a refusal naming it when it was deleted (or moved) meanwhile.

    The one reader of the working folder (``Path.cwd()`` raised a bare FileNotFoundError: "No such
    file or directory", naming nothing); the CLI calls it before any command runs.

    Returns
    -------
    Path
        The working folder.

    Raises
    ------
    linsense.errors.InputError
        It no longer exists, named as the shell knows it (``$PWD``).
    """
    from linsense.errors import InputError

    try:
        return Path(os.getcwd())
    except FileNotFoundError:
        where = os.environ.get("PWD") or "the working folder"
        raise InputError(where, "", "the working folder was deleted (or moved) while the shell was in it: "
                                    "cd into an existing folder and run the command again") from None


def _shown(path: str | os.PathLike) -> Path:
    """The path the user named for ``path``: a file of an output set being written is shown in the
    set's ``--out`` folder, not in its temporary sibling."""
    p = Path(path)
    for s in _ACTIVE:
        if s.tmp is not None and (p == s.tmp or s.tmp in p.parents):
            return s.shown / p.relative_to(s.tmp)
        if p.parent == s.target.parent and p.name.startswith(f".{_stem(s.target)}."):
            return s.shown  # (its temporary or old sibling)
    return p


def output_error(path: str | os.PathLike, exc: OSError):
    """The :class:`~linsense.errors.OutputError` of an OSError met writing ``path``.

    The path the user named and the reason in words ("read-only file system", "no space left on the
    device", "permission denied: its folder is read-only"), no errno, no temporary file.

    Parameters
    ----------
    path : str or os.PathLike
        The path the user named.
    exc : OSError
        The error met.

    Returns
    -------
    OutputError
        The error to raise.
    """
    from linsense.errors import OutputError

    if str(path) == "-":  # (standard output: a broken pipe)
        return OutputError("<stdout>", f"cannot write: {os_reason(exc)}")
    shown = _shown(path)
    reason = os_reason(exc)
    if exc.errno in (errno.EACCES, errno.EPERM):
        folder = Path(os.path.realpath(shown)).parent  # (links followed, as the write followed them)
        while not folder.exists() and folder.parent != folder:
            folder = folder.parent
        if _umask() & 0o300:  # (the folders this run made are read-only, or closed, to their owner)
            reason += (f": the umask {_umask():04o} takes the owner's write permission away from the folders "
                       "it makes (umask 022 or 077)")
        elif not os.access(folder, os.W_OK):
            reason += ": its folder is read-only"
    return OutputError(shown, f"cannot write: {reason}")


def os_reason(exc: OSError) -> str:
    """The reason of an OSError in words, for a one-line message.

    "no space left on the device", not ``[Errno 28]`` and a file name (pyarrow's "Error writing
    bytes to file. Detail: [errno 28] ..." included); a message of the error's own that says more
    than its errno is kept in parentheses.

    Parameters
    ----------
    exc : OSError
        The error.

    Returns
    -------
    str
        The reason.
    """
    words = _REASONS.get(exc.errno)
    own = exc.strerror or ""
    if words is None:
        return own or str(exc) or type(exc).__name__
    if own and exc.errno is not None and os.strerror(exc.errno) not in own:
        words += f" ({own})"  # (a message of its own, e.g. the test hooks')
    elif own and "(injected at" in own:
        words += f" ({own})"
    return words


def write_atomic(path: str | os.PathLike, data: str | bytes) -> Path:
    """Write ``data`` to ``path`` through a temporary file in the same folder and a rename.

    Parameters
    ----------
    path : str or os.PathLike
        The file (``"-"``: standard output; see :func:`write_atomic_with`).
    data : str or bytes
        Its content (text encoded as UTF-8).

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    linsense.errors.OutputError
        When it cannot be written.
    """
    return write_atomic_with(path, lambda f: f.write(data.encode() if isinstance(data, str) else data))


def write_atomic_with(path: str | os.PathLike, writer: Callable) -> Path:
    """Call ``writer(binary_file)`` on a temporary file, then rename it onto ``path``.

    The parent folder is created if needed. On any exception the temporary file is removed
    and ``path`` is left as it was; an OSError (a read-only folder, a full disk) becomes an
    :class:`~linsense.errors.OutputError` naming ``path`` (:func:`output_error`). ``"-"`` writes
    to standard output; an existing target that is not a regular file (``/dev/null``, a FIFO,
    ``/dev/stdout``) is written in place, never replaced.
    Parameters
    ----------
    path : str or os.PathLike
        The file.
    writer : callable
        ``writer(binary_file)`` writes the content.

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    linsense.errors.OutputError
        When it cannot be written.
    """
    try:
        return _write_atomic_with(path, writer)
    except OSError as exc:
        raise output_error(path, exc) from None


def _umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


#: the mode of every file written: what ``open`` would give under the user's umask (0644 under the
#: usual 022), never mkstemp's 0600 (read once, at import: a sweep's threads write files)
FILE_MODE = 0o666 & ~_umask()


def write_all(f, data: bytes) -> int:
    """Write the whole of ``data`` to the binary file ``f``.

    A raw file's ``write`` may write part of it and say so only in its count (standard output
    unbuffered, ``PYTHONUNBUFFERED=1``, into a pipe whose reader went away: ``--out -`` exited 0
    with its output cut); the rest is written again, so a failure raises.

    Parameters
    ----------
    f : binary file
        Where to write.
    data : bytes-like
        What to write.

    Returns
    -------
    int
        ``len(data)``.

    Raises
    ------
    OSError
        The write failed (a broken pipe: :class:`BrokenPipeError`).
    """
    view = memoryview(data).cast("B")
    while view:
        n = f.write(view)
        if n is None:
            raise BlockingIOError(errno.EAGAIN, "standard output is non-blocking and full")
        if n <= 0:
            raise OSError(errno.EIO, "nothing written")
        view = view[n:]
    return len(data)


class _Whole:
    """A binary file whose ``write`` writes everything (:func:`write_all`)."""

    def __init__(self, f) -> None:
        self._f = f

    def write(self, data) -> int:
        return write_all(self._f, data)

    def __getattr__(self, name: str):
        return getattr(self._f, name)


def _write_atomic_with(path: str | os.PathLike, writer: Callable) -> Path:
    if str(path) == "-":
        sys.stdout.flush()
        writer(_Whole(sys.stdout.buffer))
        sys.stdout.buffer.flush()
        return Path("-")
    if str(path).endswith(("/", os.sep)) or os.path.isdir(path):
        # (`model --out newdir/` wrote a file named newdir)
        from linsense.errors import InputError

        raise InputError("--out", "", f"{str(path)!r} names a folder: give the file's name in it")
    path = Path(path)
    real = out_target(path)  # (a link to a file: its target written, the link kept)
    try:
        special = not stat.S_ISREG(os.stat(real).st_mode)
    except FileNotFoundError:
        special = False
    if special:
        with open(real, "wb") as f:
            writer(f)
        return path
    real.parent.mkdir(parents=True, exist_ok=True)
    # (the temporary's name bounded as the output sets' are: a 255-byte name was "file name too long")
    fd, tmp = tempfile.mkstemp(prefix=f".{_stem(real)}.", suffix=".tmp", dir=real.parent)
    try:
        with os.fdopen(fd, "wb") as f:
            writer(f)
            f.flush()
            os.fsync(f.fileno())
        os.chmod(tmp, FILE_MODE)  # (mkstemp makes it 0600)
        os.replace(tmp, real)
    except BaseException:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        raise
    if _ACTIVE:
        _written(real)
    return path


# ------------------------------------------------------------------ reproducible files
#: metrics that depend on the machine and the moment (wall-clock time): written to ``timing.json``,
#: kept out of ``metrics.json``, ``trace.mat`` and ``fea.json`` so that those are byte-reproducible
#: (the FEA's solve times made fea.json differ between two runs, and between --workers 1 and 2)
TIMING_KEYS = ("wall_s", "realtime_factor", "times_s", "solve_s")


def strip_timing(obj):
    """The wall-clock times of a nested structure, separated from the rest.

    For a file of many runs' metrics (``linsense reproduce``'s ``metrics.json``), whose wall-clock
    times go to ``timing.json``.

    Parameters
    ----------
    obj : object
        Dicts, lists and tuples nested, or a value.

    Returns
    -------
    kept : object
        ``obj`` without the :data:`TIMING_KEYS` at any depth.
    timing : object or None
        The removed values in the same nesting; None where nothing was removed.
    """
    if isinstance(obj, dict):
        keep, timing = {}, {}
        for k, v in obj.items():
            if k in TIMING_KEYS:
                timing[k] = v
                continue
            keep[k], t = strip_timing(v)
            if t is not None:
                timing[k] = t
        return keep, (timing or None)
    if isinstance(obj, (list, tuple)):
        pairs = [strip_timing(v) for v in obj]
        timing = [t for _, t in pairs]
        return [k for k, _ in pairs], (timing if any(t is not None for t in timing) else None)
    return obj, None


def split_timing(metrics: dict) -> tuple[dict, dict]:
    """The :data:`TIMING_KEYS` of one run's metrics moved to a second dict.

    Parameters
    ----------
    metrics : dict
        The metrics.

    Returns
    -------
    metrics : dict
        The reproducible metrics.
    timing : dict
        The wall-clock ones.
    """
    keep = {k: v for k, v in metrics.items() if k not in TIMING_KEYS}
    timing = {k: metrics[k] for k in TIMING_KEYS if k in metrics}
    if "sim_s" in metrics and timing:
        timing = {"sim_s": metrics["sim_s"], **timing}
    return keep, timing


# ------------------------------------------------------------------ names in file names
def safe_name(name: str, max_len: int = 64) -> str:
    """A file-name part made from a user-controlled name (e.g. the motor name in ``ls_lut_<name>.h``).

    Only ``A-Z a-z 0-9 _ -`` survive (accents are dropped, any run of other characters becomes one
    ``_``, so no ``/``, ``..``, NUL or leading ``-``/``.``); an empty result becomes ``unnamed``; a
    result longer than ``max_len`` is cut and ends with 8 hex digits of the name's SHA-1 (long
    names that differ anywhere stay distinct). Deterministic.
    Parameters
    ----------
    name : str
        The user's name.
    max_len : int, optional
        Longest result.

    Returns
    -------
    str
        The file-name part.
    """
    import hashlib
    import unicodedata

    raw = str(name)
    ascii_ = unicodedata.normalize("NFKD", raw).encode("ascii", "ignore").decode("ascii")
    s = re.sub(r"[^0-9A-Za-z_-]+", "_", ascii_).strip("_-") or "unnamed"
    if len(s) > max_len:
        digest = hashlib.sha1(raw.encode("utf-8", "surrogatepass")).hexdigest()[:8]
        s = s[: max_len - 9].rstrip("_-") + "_" + digest
    return s


# ------------------------------------------------------------------ output sets
#: the manifest of an output set: which command wrote it and every file it holds
MANIFEST = ".linsense-set.json"
#: test hooks: the stage at which a run kills itself (SIGKILL) or fails with an OSError
KILL_ENV = "LINSENSE_TEST_KILL_AT"
FAIL_ENV = "LINSENSE_TEST_FAIL_AT"
#: the stages, in order: the first file written, everything written (before the swap), one
#: foreign entry carried over, the old set renamed aside (between the swap's two renames), the new
#: set renamed in (before the old one is deleted)
STAGES = ("first-file", "before-swap", "carry", "mid-swap", "after-swap")


def _hook(stage: str, where: Path) -> None:
    if os.environ.get(KILL_ENV) == stage:
        os.kill(os.getpid(), signal.SIGKILL)
    if os.environ.get(FAIL_ENV) == stage and stage != "after-swap":  # the run has succeeded there
        raise OSError(errno.ENOSPC, f"{os.strerror(errno.ENOSPC)} (injected at {stage})", str(where))


def _stem(target: Path) -> str:
    """The name part of the sibling temporaries of ``target`` (bounded: file names <= 255 bytes)."""
    name = target.name
    if len(name.encode("utf-8", "surrogateescape")) <= 150:
        return name
    import hashlib

    return safe_name(name, 64) + "-" + hashlib.sha1(name.encode("utf-8", "surrogateescape")).hexdigest()[:16]


def _alive(pid: int) -> bool:
    """Whether process ``pid`` exists (someone else's included), on every platform (psutil: a
    signal 0 on POSIX, ``OpenProcess`` on Windows, where ``os.kill`` would terminate it). A number no
    process can have (beyond the platform's pid range) is not alive."""
    if pid == os.getpid():
        return True
    import psutil

    try:
        return psutil.pid_exists(pid)
    except (OverflowError, ValueError):  # (a number beyond the C pid type)
        return False


def _rmtree(p: Path, strict: bool = False) -> None:
    """Remove ``p``, a leftover of linsense's own (a temporary or old set).

    Its folders are made writable first (an old set whose folders were made read-only could not be
    emptied: it stayed beside ``--out`` for good). With ``strict``, what still cannot be removed
    raises its OSError; else it is left for the next run (:func:`recover`).
    """
    try:
        if p.is_symlink() or not p.is_dir():
            p.unlink(missing_ok=True)
            return
        _writable(p)
        for root, dirs, _ in os.walk(p):
            for d in dirs:
                _writable(os.path.join(root, d))
        shutil.rmtree(p)
    except FileNotFoundError:
        pass
    except OSError:
        if strict:
            raise


def _writable(d: str | os.PathLike) -> None:
    """Add the owner's rwx to folder ``d`` (not through a symbolic link) where it lacks them."""
    try:
        mode = os.lstat(d).st_mode
        if stat.S_ISDIR(mode) and mode & 0o700 != 0o700:
            os.chmod(d, stat.S_IMODE(mode) | 0o700)
    except OSError:  # (not ours: the removal says why)
        pass


def _leftover_error(path: Path, exc: OSError):
    """The :class:`~linsense.errors.OutputError` of a leftover that cannot be removed."""
    from linsense.errors import OutputError

    return OutputError(path, f"a leftover of an earlier linsense run that cannot be removed "
                             f"({os_reason(exc)}): remove it")


def _listed_files(folder: Path) -> list[str]:
    """Every non-folder entry under ``folder`` as a relative POSIX path (symlinks not followed)."""
    out = []

    def walk(d: Path, rel: str) -> None:
        for e in sorted(os.scandir(d), key=lambda e: e.name):
            r = f"{rel}{e.name}"
            if e.is_dir(follow_symlinks=False):
                walk(Path(e.path), r + "/")
            else:
                out.append(r)

    walk(folder, "")
    return out


def _manifest_files(tmp: Path) -> set[str]:
    try:
        return set(json.loads((tmp / MANIFEST).read_text(encoding="utf-8"))["files"])
    except (OSError, ValueError, KeyError, TypeError):
        return set()


def _restore(old: Path, tmp: Path, target: Path) -> None:
    """Undo an unfinished swap: the entries carried from ``old`` into ``tmp`` go back (they are
    the top-level entries of ``tmp`` its manifest does not list), ``old`` is renamed back onto
    ``target``, ``tmp`` is removed."""
    if tmp.is_dir():
        own = {f.split("/")[0] for f in _manifest_files(tmp)} | {MANIFEST}
        for e in os.listdir(tmp):
            if e not in own and not os.path.lexists(old / e):
                os.rename(tmp / e, old / e)
    os.rename(old, target)
    _rmtree(tmp)


def recover(out: str | os.PathLike) -> None:
    """Finish or undo what an interrupted run (its process is dead) left next to ``out``.

    ``.<name>.tmp-<pid>-<token>`` is a set being written (removed) and ``.<name>.old-<pid>-<token>``
    the previous set during the swap: restored onto ``out`` when ``out`` is missing (the run died
    between the two renames; what it had carried over goes back), removed when the new set is in
    place. Temporaries of live processes are left alone. Every command writing an output set calls
    this (under a lock on the parent folder) before it looks at ``out``. Leftovers are made writable
    before they are removed (a set made read-only is removed too).

    Parameters
    ----------
    out : str or os.PathLike
        The output folder.

    Raises
    ------
    linsense.errors.OutputError
        A leftover that cannot be removed all the same, naming it and why.
    """
    target = _target(out)
    with _locked(target.parent):
        _recover(target)


def _recover(target: Path) -> None:
    parent = target.parent
    pat = re.compile(re.escape(f".{_stem(target)}.") + r"(tmp|old)-(\d+)-([0-9a-f]{8})")
    tokens = set()
    try:
        names = os.listdir(parent)
    except FileNotFoundError:
        return
    for n in names:
        m = pat.fullmatch(n)
        if m and not _alive(int(m.group(2))):
            tokens.add(f"{m.group(2)}-{m.group(3)}")
    for tok in sorted(tokens):
        old, tmp = _sibling(target, "old", tok), _sibling(target, "tmp", tok)
        garbage = None
        if old.exists():
            if not os.path.lexists(target):
                _restore(old, tmp, target)
            elif not tmp.exists():
                garbage = old  # the swap finished: the old set is garbage
            # else: something else appeared at target meanwhile; touch nothing
        else:
            garbage = tmp
        if garbage is not None:
            try:
                _rmtree(garbage, strict=True)
            except OSError as exc:
                raise _leftover_error(garbage, exc) from None


def _sibling(target: Path, kind: str, token: str) -> Path:
    return target.parent / f".{_stem(target)}.{kind}-{token}"


def _target(out: str | os.PathLike) -> Path:
    """The real folder an ``--out`` names (:func:`out_target`: the swap replaces the folder the link
    points to, not the link)."""
    return out_target(out)


#: the lock file where a folder cannot be locked itself (Windows; filelock deletes it on release)
LOCK_FILE = ".linsense.lock"


class _Locked:
    """An exclusive lock on a folder, waited for: ``flock`` on the folder itself where the OS has it
    (POSIX: no lock file to leave behind), else (Windows) :class:`filelock.FileLock` on
    :data:`LOCK_FILE` in the folder."""

    #: False: always use filelock (what Windows runs; the tests check both on POSIX)
    use_flock = True

    def __init__(self, folder: Path, busy: str | None = None) -> None:
        self.folder = folder
        self.busy = busy  # (None: wait for the lock; else refuse at once with this message)
        self.fd: int | None = None
        self.filelock = None

    def _refuse(self):
        from linsense.errors import OutputError

        return OutputError(_shown(self.folder), self.busy)

    def __enter__(self) -> int | None:
        self.folder.mkdir(parents=True, exist_ok=True)
        try:
            import fcntl
        except ImportError:
            fcntl = None
        if fcntl is not None and self.use_flock:
            self.fd = os.open(self.folder, os.O_RDONLY)
            try:
                fcntl.flock(self.fd, fcntl.LOCK_EX | (fcntl.LOCK_NB if self.busy else 0))
            except BlockingIOError:
                os.close(self.fd)
                raise self._refuse() from None
            except BaseException:
                os.close(self.fd)
                raise
            return self.fd  # (also what commit fsyncs)
        from filelock import FileLock, Timeout

        self.filelock = FileLock(self.folder / LOCK_FILE)
        try:
            self.filelock.acquire(timeout=0 if self.busy else -1)
        except Timeout:
            raise self._refuse() from None
        return None

    def __exit__(self, *exc) -> None:
        if self.fd is not None:
            os.close(self.fd)  # releases the lock
        else:
            self.filelock.release()


def _locked(folder: Path) -> _Locked:
    """An exclusive lock on ``folder`` (see :class:`_Locked`)."""
    return _Locked(folder)


def held(folder: str | os.PathLike, busy: str) -> _Locked:
    """An exclusive lock on ``folder`` (made if missing) for a long work in it, refused at once when
    another process (or another call) holds it.

    The lock of a folder written in place (a sweep's: two sweeps into one folder at once deleted
    each other's partitions being written); output sets lock their parent folder for their swap
    only, and wait.

    Parameters
    ----------
    folder : str or os.PathLike
        The folder.
    busy : str
        The refusal's message (the folder is named before it).

    Returns
    -------
    context manager
        Holds the lock while entered.

    Raises
    ------
    linsense.errors.OutputError
        On entering, when the lock is held elsewhere.
    """
    return _Locked(Path(folder), busy)


def _check_existing(target: Path, shown: Path) -> list[str]:
    """The rule for an ``--out`` that exists; return its foreign top-level entries (kept).

    Accepted: a missing or empty folder, or a linsense output set (it has :data:`MANIFEST`). In a
    set, every file under a top-level entry the manifest names must be listed in it (else the user
    put something there: refused); top-level entries the manifest does not name are the user's
    and are carried over unchanged into the new set. Every folder the swap empties or moves must
    be writable (else refused before anything is computed, not left half-replaced).
    """
    from linsense.errors import OutputError

    if not os.path.lexists(target):
        return []
    if not target.is_dir():
        raise OutputError(shown, "exists and is not a folder")
    _check_writable(target, shown)
    entries = sorted(os.listdir(target))
    if not entries:
        return []
    if MANIFEST not in entries:
        raise OutputError(shown, f"not empty and not a linsense output folder (no {MANIFEST}): refusing to "
                                 "replace it; remove it or choose a new or empty folder")
    try:
        listed = json.loads((target / MANIFEST).read_text(encoding="utf-8"))["files"]
        if not (isinstance(listed, list) and all(isinstance(f, str) for f in listed)):
            raise TypeError
    except (OSError, ValueError, KeyError, TypeError):
        raise OutputError(shown / MANIFEST, "unreadable linsense manifest: refusing to replace the folder; "
                                            "remove it or choose a new or empty folder") from None
    listed_set = set(listed)
    owned = {f.split("/")[0] for f in listed}
    for e in entries:
        if e in owned:
            p = target / e
            found = [e] if p.is_symlink() or not p.is_dir() else [f"{e}/{r}" for r in _listed_files(p)]
            for f in found:
                if f not in listed_set:
                    raise OutputError(shown / f, f"not written by linsense (not in {MANIFEST}): refusing to "
                                                 "replace the folder; move it away")
            if p.is_dir() and not p.is_symlink():
                for d, _, _ in os.walk(p):
                    _check_writable(Path(d), shown / Path(d).relative_to(target))
        elif e != MANIFEST and (target / e).is_dir() and not (target / e).is_symlink():
            _check_writable(target / e, shown / e, "cannot carry it over into the new set")  # (moved)
    return [e for e in entries if e not in owned and e != MANIFEST]


def _check_not_working(target: Path, shown: Path, kept: list[str]) -> None:
    """Refuse an ``--out`` that is the working folder, or holds it in an entry the swap replaces
    (``--out .``: the working folder was renamed aside and deleted, exit 0, and the shell left in a
    deleted folder where ``ls`` shows nothing). A working folder inside an entry of the user's that
    the set carries over (``kept``) stays where it is."""
    from linsense.errors import OutputError

    try:
        here = Path(os.getcwd())
    except FileNotFoundError:  # (the CLI refused it before; from Python: nothing to protect)
        return
    if here == target or target in here.parents:
        inside = here.relative_to(target).parts
        if not inside or inside[0] not in kept:
            what = "is the working folder" + (" or holds it" if inside else "")
            raise OutputError(shown, f"{what}: an output set replaces its folder as a whole, which "
                                     "would leave you in a deleted folder; write into a sub-folder (--out "
                                     "run1), or run from another folder")


def _check_writable(folder: Path, shown: Path, what: str = "cannot replace") -> None:
    """Refuse a folder the swap must empty or move that is not writable (a read-only ``--out``: the
    run said it was done and left ``.DIR.old-*`` beside it for good), before anything is computed."""
    from linsense.errors import OutputError

    if not os.access(folder, os.W_OK | os.X_OK):
        raise OutputError(shown, f"{what}: permission denied: the folder is read-only (make it "
                                 "writable, or choose another --out)")


def _check_rel(rel: str) -> str:
    parts = str(rel).split("/")
    if any(p in ("", ".", "..") or "\0" in p or len(p.encode("utf-8", "surrogateescape")) > 255
           for p in parts) or parts[0] == MANIFEST:
        raise ValueError(f"not a file name inside an output set: {rel!r}")
    return "/".join(parts)


class OutputSet:
    """The files of one command run, written into a temporary sibling folder of ``out``.

    Swapped into place as a whole (see :func:`output_set`).

    Parameters
    ----------
    out : str or os.PathLike
        The output folder.
    command : str
        The command, recorded in the manifest.

    Raises
    ------
    linsense.errors.OutputError
        ``out`` is the root folder.
    """

    def __init__(self, out: str | os.PathLike, command: str) -> None:
        self.shown = Path(out)
        self.target = _target(out)
        if self.target.parent == self.target:
            from linsense.errors import OutputError

            raise OutputError(self.shown, "cannot replace the root folder")
        self.command = command
        self.tmp: Path | None = None
        self.token = ""
        self.any_written = False
        self._made: Path | None = None
        self.files: list[Path] = []  # after the swap: every file of the set, as shown to the user

    # -- writing
    def path(self, rel: str) -> Path:
        """Where to write the set's file (or folder) ``rel``; the folders above it exist.

        Parameters
        ----------
        rel : str
            A fixed name, ``/``-separated, or made with :func:`safe_name`.

        Returns
        -------
        Path
            In the temporary folder.
        """
        rel = _check_rel(rel)
        p = self.tmp / rel
        p.parent.mkdir(parents=True, exist_ok=True)
        return p

    @property
    def root(self) -> Path:
        """The set's temporary folder itself (for writers that take a folder)."""
        return self.tmp

    def write(self, rel: str, data: str | bytes) -> Path:
        """Write the set's file ``rel`` (:func:`write_atomic`).

        Parameters
        ----------
        rel : str
            Its name in the set.
        data : str or bytes
            Its content.

        Returns
        -------
        Path
            Where it was written (in the temporary folder).
        """
        return write_atomic(self.path(rel), data)

    def write_with(self, rel: str, writer: Callable) -> Path:
        """Write the set's file ``rel`` with ``writer`` (:func:`write_atomic_with`).

        Parameters
        ----------
        rel : str
            Its name in the set.
        writer : callable
            ``writer(binary_file)``.

        Returns
        -------
        Path
            Where it was written (in the temporary folder).
        """
        return write_atomic_with(self.path(rel), writer)

    # -- life cycle
    def open(self) -> None:
        """Recover what an interrupted run left, check ``out`` and make the temporary folder.

        Under a lock on the parent folder.

        Raises
        ------
        linsense.errors.OutputError
            ``out`` is not missing, empty or a previous output set.
        """
        missing = self.target.parent
        while not missing.parent.exists() and missing.parent != missing:
            missing = missing.parent
        self._made = None if missing.exists() else missing  # the first folder this run creates
        with _locked(self.target.parent):
            _recover(self.target)
            _check_not_working(self.target, self.shown, _check_existing(self.target, self.shown))
            while True:
                self.token = f"{os.getpid()}-{secrets.token_hex(4)}"
                tmp = _sibling(self.target, "tmp", self.token)
                try:
                    os.mkdir(tmp)
                    break
                except FileExistsError:  # pragma: no cover - a 32-bit token collision
                    continue
        self.tmp = tmp

    def abort(self) -> None:
        """Remove the temporary folder, and the folders above ``out`` this run created if still empty."""
        if self.tmp is not None:
            _rmtree(self.tmp)
        if self._made is not None:  # the folders above out this run created, if still empty
            d = self.target.parent
            while True:
                try:
                    os.rmdir(d)
                except OSError:
                    break
                if d == self._made:
                    break
                d = d.parent

    def commit(self) -> None:
        """Write the manifest and swap the set into place (see :func:`output_set`).

        Raises
        ------
        linsense.errors.OutputError
            An entry of the old folder that no linsense run wrote would be replaced.
        """
        from linsense.errors import OutputError
        from linsense.version import __version__

        files = _listed_files(self.tmp)
        doc = {"command": self.command, "files": files, "linsense": __version__}
        write_atomic(self.tmp / MANIFEST, json.dumps(doc, indent=1) + "\n")
        new_top = {f.split("/")[0] for f in files}
        target, tmp = self.target, self.tmp
        old = _sibling(target, "old", self.token)
        with _locked(target.parent) as fd:
            _recover(target)
            foreign = _check_existing(target, self.shown)
            clash = [e for e in foreign if e in new_top]
            if clash:
                raise OutputError(self.shown / clash[0], "exists and is not part of the previous linsense "
                                                         "output: refusing to replace it; move it away")
            _hook("before-swap", self.shown)
            if os.path.lexists(target):
                os.rename(target, old)
                try:
                    for e in foreign:
                        os.rename(old / e, tmp / e)
                        _hook("carry", self.shown)
                    _hook("mid-swap", self.shown)
                    os.rename(tmp, target)
                except BaseException:
                    _restore(old, tmp, target)
                    raise
                _hook("after-swap", self.shown)
                try:
                    _rmtree(old, strict=True)
                except OSError as exc:  # (the new set is in place: said, not reported as done)
                    raise OutputError(self.shown, f"written, but the previous set could not be removed "
                                      f"({os_reason(exc)}): remove {old}") from None
            else:
                os.rename(tmp, target)
            try:
                if fd is not None:  # (a folder cannot be opened, so not synced, on Windows)
                    os.fsync(fd)
            except OSError:  # pragma: no cover - folders that cannot be synced
                pass
        self.files = [self.shown / f for f in files]


@contextmanager
def output_set(out: str | os.PathLike, command: str) -> Iterator[OutputSet]:
    """Write a command's whole output set atomically into folder ``out``.

    Yields an :class:`OutputSet`; write every file through ``s.write(rel, data)`` or into
    ``s.path(rel)``. On success the set, with its manifest :data:`MANIFEST`, replaces ``out``:
    ``out`` is renamed aside to ``.<name>.old-<pid>-<token>``, the entries the previous set did not
    own are moved into the new one, the new folder ``.<name>.tmp-<pid>-<token>`` is renamed onto
    ``out``, and the old one is deleted. On any exception the temporary folder is removed and
    ``out`` is as it was. A SIGKILL leaves at most these two siblings: the next run on ``out``
    (:func:`recover`) puts the old set back or deletes what is garbage, so at every instant
    ``out`` holds the complete old or new set, or is recovered to the old one. ``out`` must be
    missing, empty or a previous output set (:func:`_check_existing`); else
    :class:`~linsense.errors.OutputError` (exit code 2) before anything is computed.
    Parameters
    ----------
    out : str or os.PathLike
        The output folder.
    command : str
        The command, recorded in the manifest.

    Yields
    ------
    OutputSet
        The set to write into.
    """
    s = OutputSet(out, command)
    try:
        s.open()
    except OSError as exc:
        raise output_error(s.shown, exc) from None
    _ACTIVE.append(s)
    try:
        try:
            yield s
            s.commit()
        except BaseException:
            s.abort()
            raise
    except OSError as exc:  # a read-only folder, a full disk: the user's path and the reason in words
        where = Path(exc.filename) if exc.filename is not None else None
        if where is not None and not (_under(where, s.target.parent) or _under(where, s.shown.parent)):
            raise  # (not the output's: an input's error)
        raise output_error(where if where is not None else s.shown, exc) from None
    finally:
        _ACTIVE.remove(s)


def _under(p: Path, folder: Path) -> bool:
    return p == folder or folder in p.parents


#: the output sets being written (for the ``first-file`` test hook of :func:`write_atomic_with`)
_ACTIVE: list[OutputSet] = []


def _written(path: Path) -> None:
    for s in _ACTIVE:
        if s.tmp is not None and s.tmp in path.parents and not s.any_written:
            s.any_written = True
            _hook("first-file", s.shown)
