"""The packaged examples: motors, scenarios, sweeps, FEA geometries, a bench file and the firmware
example, shipped in the wheel beside this module (``linsense examples DIR`` copies them out).

Every example is reachable by name wherever a file is taken: ``--motor small30``, ``linsense simulate
step3_lut``, ``linsense sweep injection``, ``linsense fea tubular56_bh``, ``linsense identify
ecce2010_56_1pct_seed1``, and a scenario's ``motor = "small30"``. A name resolves as: a path if it
exists, else a packaged example of that kind, else :class:`~linsense.errors.InputError` (exit code 2)
listing the names. The examples refer to each other by relative paths (a sweep's
``scenario = "../scenarios/step3_lut.toml"``), which hold both here and in a copied-out folder.
"""

from __future__ import annotations

import functools
import os
import shutil
from pathlib import Path

from linsense._check import choice, instance
from linsense.errors import InputError

#: the folder of the examples (the package's own: the wheel installs it unzipped)
ROOT = Path(__file__).resolve().parent

#: the kinds of example, each a sub-folder of :data:`ROOT`, with the suffix of its named files
KINDS = {"motors": ".toml", "scenarios": ".toml", "sweeps": ".toml", "fea": ".toml", "bench": ".csv",
         "firmware": None}

#: what a name of each kind is, for messages
WHAT = {"motors": "motor", "scenarios": "scenario", "sweeps": "sweep", "fea": "geometry",
        "bench": "bench", "firmware": "firmware"}


def _kind(kind, func: str) -> str:
    """``kind`` if it is one of :data:`KINDS`, else InputError naming the closest (``names("nope")``
    was a bare KeyError)."""
    return choice(kind, f"linsense.examples.{func}", "kind", KINDS, "kind of example")


def files() -> list[str]:
    """Every packaged example file (this module and Python caches excluded).

    Returns
    -------
    list of str
        Paths relative to :data:`ROOT` with ``/`` separators, sorted.
    """
    return list(_files())


@functools.cache
def _files() -> tuple[str, ...]:  # (the package's files do not change while it runs)
    out = []
    for kind in KINDS:
        for p in (ROOT / kind).rglob("*"):
            if p.is_file() and "__pycache__" not in p.parts:
                out.append(p.relative_to(ROOT).as_posix())
    return tuple(sorted(out))


def _is_motor(p: Path) -> bool:
    """A motor file: ``motor.toml`` (a folder's motor, with its tables) or a TOML with a ``[motor]``
    table (not, e.g., ``class/drives.toml``, the drive data of the class's motors)."""
    if p.name == "motor.toml":
        return True
    return any(line.strip() == "[motor]" for line in p.read_text(encoding="utf-8").splitlines())


@functools.cache
def _index(kind: str) -> dict[str, Path]:
    """``{name: path}`` of the examples of ``kind`` (a motor folder's ``motor.toml`` is named after
    the folder; the motors of a sub-folder such as ``class/`` by their own names)."""
    suffix = KINDS[kind]
    out: dict[str, Path] = {}
    if suffix is None:
        return out
    for rel in _files():
        p = ROOT / rel
        if not rel.startswith(kind + "/") or p.suffix != suffix:
            continue
        if kind == "motors":
            if not _is_motor(p):
                continue
            name = p.parent.name if p.name == "motor.toml" else p.stem
        else:
            name = p.stem
        if name in out:  # (a packaging error, caught by the tests)
            raise RuntimeError(f"two packaged {WHAT[kind]} examples named {name!r}: {out[name]}, {p}")
        out[name] = p
    return out


def names(kind: str) -> list[str]:
    """The names of the packaged examples of ``kind``, sorted.

    Parameters
    ----------
    kind : str
        One of :data:`KINDS`.

    Returns
    -------
    list of str
        The names.

    Raises
    ------
    InputError
        ``kind`` not one of :data:`KINDS` (the closest named).
    """
    return sorted(_index(_kind(kind, "names")))


def path(kind: str, name: str) -> Path | None:
    """The packaged example ``name`` of ``kind``, or None.

    Parameters
    ----------
    kind : str
        One of :data:`KINDS`.
    name : str
        The example's name.

    Returns
    -------
    Path or None
        Its file.

    Raises
    ------
    InputError
        ``kind`` not one of :data:`KINDS`, ``name`` not a str.
    """
    kind = _kind(kind, "path")
    instance(name, "linsense.examples.path", "name", str, "an example's name (a str)")
    return _index(kind).get(name)


def named(kind: str, spec):
    """``spec``, or the path of the packaged example of ``kind`` it names.

    ``spec`` unchanged, unless it is a str that is not an existing path but a packaged example's
    name: then that example's path (the API's lenient form of :func:`resolve`: a wrong path keeps its
    reader's own message).

    Parameters
    ----------
    kind : str
        One of :data:`KINDS`.
    spec : object
        What the caller gave.

    Returns
    -------
    object
        ``spec`` or the example's Path.

    Raises
    ------
    InputError
        ``kind`` not one of :data:`KINDS`.
    """
    kind = _kind(kind, "named")
    if isinstance(spec, str) and not Path(spec).exists():
        p = path(kind, spec)
        if p is not None:
            return p
    return spec


def resolve(kind: str, spec: str | Path, key: str = "", extra: tuple[str, ...] = ()) -> str:
    """A file argument: ``spec`` itself if it is an existing file, else the packaged example of
    ``kind`` it names, else :class:`~linsense.errors.InputError` listing the names.

    Parameters
    ----------
    kind : str
        One of :data:`KINDS`.
    spec : str or Path
        What the user gave.
    key : str
        The option or key it was given at, for the message (e.g. ``"--motor"``).
    extra : tuple of str
        Further valid names to list in the message (a command's own presets, resolved by it).

    Returns
    -------
    str
        The path to read.

    Raises
    ------
    InputError
        ``kind`` not one of :data:`KINDS`, ``spec`` neither a file nor an example's name (the names
        listed).
    """
    kind = _kind(kind, "resolve")
    instance(spec, "linsense.examples.resolve", "spec", str | os.PathLike, "a path or an example's name")
    s = str(spec)
    # (a file: a folder of the same name as an example, e.g. a sweep's --out, does not hide it)
    if Path(s).is_file() or s in extra:
        return s
    p = path(kind, s)
    if p is not None:
        return str(p)
    if Path(s).is_dir():  # (a folder where a file was meant: said so, as a motor's is)
        raise InputError(s, "", f"is a folder, not a {WHAT[kind]} file")
    if Path(s).suffix or any(sep in s for sep in "/\\"):  # (a path, not a name: the file is missing)
        raise InputError(s, "", f"no such {WHAT[kind]} file ({listing(kind, extra)})")
    raise InputError(key or WHAT[kind], "", unknown(kind, s, extra))


def unknown(kind: str, spec: str, extra: tuple[str, ...] = ()) -> str:
    """The one-line message for a ``spec`` that is neither a file nor a packaged example of ``kind``.

    Parameters
    ----------
    kind : str
        One of :data:`KINDS`.
    spec : str
        What the user gave.
    extra : tuple of str, optional
        Further valid names, listed too.

    Returns
    -------
    str
        The message.

    Raises
    ------
    InputError
        ``kind`` not one of :data:`KINDS`.
    """
    what = WHAT[_kind(kind, "unknown")]
    return f"unknown {what} {spec!r}: no such file, nor a packaged {what} ({listing(kind, extra)})"


def listing(kind: str, extra: tuple[str, ...] = ()) -> str:
    """The names of ``kind`` for a message, and how to copy the examples out.

    Parameters
    ----------
    kind : str
        One of :data:`KINDS`.
    extra : tuple of str, optional
        Further valid names, listed first.

    Returns
    -------
    str
        ``names: a, b, ...; `linsense examples DIR` copies the examples out``.

    Raises
    ------
    InputError
        ``kind`` not one of :data:`KINDS`.
    """
    kind = _kind(kind, "listing")
    return f"names: {', '.join([*extra, *names(kind)])}; `linsense examples DIR` copies the examples out"


def copy_to(dest: str | Path, force: bool = False) -> list[Path]:
    """Copy every packaged example into ``dest`` (created if needed), keeping the sub-folders.

    All or nothing: the files are copied into a temporary folder inside ``dest`` first, then renamed
    into place; a failure on the way (a full disk, a read-only folder) undoes every step (the files
    ``--force`` replaced put back, the folders made removed) and says which of ``dest``'s files could
    not be written and why (a full disk was a raw errno naming the package's own file, and left the
    files copied so far).

    Parameters
    ----------
    dest : str or Path
        The folder to copy into.
    force : bool
        Overwrite files that exist; without it an existing file refuses the whole copy, before
        anything is written.

    Returns
    -------
    list of Path
        The files written, in :func:`files` order.

    Raises
    ------
    InputError
        ``dest`` is a file, holds a folder where a file goes, or (without ``force``) holds one of
        the files already.
    linsense.errors.OutputError
        A file or folder could not be written (nothing copied).
    """
    import secrets

    from linsense.io import out_target

    dest = Path(dest)
    if dest.is_symlink():  # (a link followed, a dangling one made, a loop refused)
        dest = out_target(dest)
    if dest.exists() and not dest.is_dir():
        raise InputError(str(dest), "", "exists and is not a folder")
    targets = [(rel, dest / rel) for rel in files()]
    _refuse_existing(targets, force)
    folders = _folders_to_make(dest, targets)
    stage = dest / f".linsense-examples.tmp-{os.getpid()}-{secrets.token_hex(4)}"
    made: list[Path] = []  # the folders made, parents first
    moved: list[tuple[Path, Path | None]] = []  # (placed file, the file it replaced, set aside)
    at = dest
    try:
        for d in folders:  # (every folder first: a read-only one refuses before a file is copied)
            at = next(t for _, t in targets if d in t.parents)  # (named: "its folder is read-only")
            if not d.is_dir():
                d.mkdir()
                made.append(d)
            elif not os.access(d, os.W_OK | os.X_OK):
                raise PermissionError(13, "Permission denied", str(d))
        at = stage
        stage.mkdir()
        for rel, t in targets:
            at = t
            (stage / rel).parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(ROOT / rel, stage / rel)
        for rel, t in targets:
            at = t
            aside = None
            if t.exists() or t.is_symlink():
                aside = stage / ".replaced" / rel
                aside.parent.mkdir(parents=True, exist_ok=True)
                os.replace(t, aside)
            moved.append((t, aside))
            os.replace(stage / rel, t)
    except OSError as exc:
        _undo(moved, made, stage)
        from linsense.io import output_error

        err = output_error(at if at != stage else dest, exc)
        raise type(err)(err.source, f"{err.message}; nothing copied") from None
    shutil.rmtree(stage, ignore_errors=True)
    return [t for _, t in targets]


def _refuse_existing(targets: list[tuple[str, Path]], force: bool) -> None:
    """Refuse a folder where a file of ``targets`` goes, and (without ``force``) a file there."""
    there = [t for _, t in targets if t.exists() or t.is_symlink()]
    folder = next((t for t in there if t.is_dir() and not t.is_symlink()), None)
    if folder is not None:  # (--force replaced it with the file and deleted the folder with its files)
        raise InputError(str(folder), "", "exists and is a folder: not replaced, even with --force; nothing "
                                          "copied (move it away)")
    if not force and there:
        more = f" and {len(there) - 1} more" if len(there) > 1 else ""
        raise InputError(str(there[0]), "", f"exists{more}: nothing copied (--force overwrites)")


def _folders_to_make(dest: Path, targets: list[tuple[str, Path]]) -> list[Path]:
    """The folders the copy needs, parents first: ``dest``, the missing ones above it, and the
    sub-folders of ``targets``."""
    folders = sorted({t.parent for _, t in targets} | {dest}, key=lambda d: len(d.parts))
    up = dest.parent
    while not up.exists() and up.parent != up:  # (the missing folders above dest too)
        folders.insert(0, up)
        up = up.parent
    return folders


def _undo(moved: list[tuple[Path, Path | None]], made: list[Path], stage: Path) -> None:
    """Undo an unfinished :func:`copy_to`: each file placed removed (the one it replaced put back),
    the temporary folder removed, then the folders it made, deepest first."""
    for t, aside in reversed(moved):
        try:
            if aside is not None:
                os.replace(aside, t)
            else:
                t.unlink(missing_ok=True)
        except OSError:
            pass
    shutil.rmtree(stage, ignore_errors=True)
    for d in reversed(made):
        try:
            d.rmdir()
        except OSError:
            pass
