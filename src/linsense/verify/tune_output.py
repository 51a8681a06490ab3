"""What ``linsense tune`` writes: the scenario or C header, and its certificate's files beside it.

:func:`tune_to` runs :func:`~linsense.verify.tuning.tune` and writes its text to ``out`` and the
certificate as ``<stem>.verification.json`` and ``<stem>.verification.png`` beside it: a header
after its certificate's files (it is written only for a drive that passed), a scenario before its
certificate runs. A certificate names the output it certifies; one of another output is never
replaced, and one left by an earlier design of this output is deleted when none is run.
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable
from pathlib import Path

from linsense.errors import InputError
from linsense.io import NAME_MAX, Say, quiet, working_folder, write_atomic
from linsense.verify.tuning import TuneResult, tune

__all__ = ["certificate_paths", "own_certificate", "tune_to"]

#: ``figure(result, path)`` draws the certificate's figure (``<stem>.verification.png``) into ``path``
CertificateFigure = Callable[[TuneResult, Path], object]


def certificate_paths(out: str | Path) -> tuple[Path, Path]:
    """``<out stem>.verification.json`` and ``.png`` beside the output file (in the working folder
    for ``-`` or a device such as /dev/null).

    Parameters
    ----------
    out : str or Path
        The scenario or header written (``-``: standard output).

    Returns
    -------
    tuple of Path
        The certificate's JSON and figure.

    Raises
    ------
    InputError
        A certificate's file name beyond the longest file name (checked before the work).
    """
    out = str(out)
    p = Path(out)
    if out == "-" or (p.exists() and not p.is_file()):
        folder, stem = working_folder(), "tune"
    else:
        folder, stem = p.resolve().parent, p.stem
        name = f"{stem}.verification.json"
        if len(os.fsencode(name)) > NAME_MAX:  # (its write failed after the work, the scenario written)
            raise InputError("--out", "", f"{out!r}: the certificate written beside it, the name's stem and "
                             f"'.verification.json', would be a file name of {len(os.fsencode(name))} bytes, "
                             f"beyond the {NAME_MAX} bytes of a file name: give a shorter --out")
    return folder / f"{stem}.verification.json", folder / f"{stem}.verification.png"


def own_certificate(out: str | Path) -> None:
    """Refuse an output whose certificate files (``<stem>.verification.json``, ``.png``) are another
    output's.

    ``tune --format c --out a.h`` then ``tune --no-verify --out a.toml`` deleted the header's
    certificate, and a verified ``--out a.toml`` replaced it, without a word. A certificate names
    the output it certifies (its ``output``); one of another output is left alone. One without the
    key (an earlier linsense's) is this output's.

    Parameters
    ----------
    out : str or Path
        The scenario or header to be written (``-``: standard output).

    Raises
    ------
    InputError
        The certificate beside ``out`` is another output's.
    """
    out = str(out)
    json_path, _ = certificate_paths(out)
    try:
        owner = json.loads(json_path.read_text(encoding="utf-8")).get("output")
    except (OSError, ValueError, AttributeError):  # (none, or not a certificate: nothing to keep)
        return
    mine = Path(out).name if out != "-" else "-"
    if isinstance(owner, str) and owner != mine:
        raise InputError(str(json_path), "output", f"{owner!r}: this is the certificate of {owner}, which "
                         f"--out {out} would replace (or delete, with --no-verify): give --out another name "
                         f"than {owner}'s stem")


def _write_certificate(res: TuneResult, out: str, figure: CertificateFigure | None, say: Say) -> None:
    """Write the certificate's JSON (naming the ``out`` it certifies) and figure beside ``out``
    (appended to ``res.files``, each said)."""
    json_path, png_path = certificate_paths(out)
    text = json.dumps(res.certificate_doc(out), indent=1, sort_keys=True) + "\n"
    res.files.append(write_atomic(json_path, text))
    say(str(res.files[-1]))
    if figure is not None:
        figure(res, png_path)
        res.files.append(png_path)
        say(str(png_path))


def tune_to(out: str | Path, motor: str, *, figure: CertificateFigure | None = None, say: Say = quiet,
            **kwargs) -> TuneResult:
    """Design and verify the drive for a motor (:func:`~linsense.verify.tuning.tune`), and write the
    scenario or C header to ``out`` with its certificate's files beside it.

    Parameters
    ----------
    out : str or Path
        The scenario or header (``-``: standard output; the certificate then goes to the working
        folder as ``tune.verification.*``).
    motor : str
        The motor: a file, a preset or a packaged example's name.
    figure : callable or None, optional
        ``figure(result, path)`` draws the certificate's figure, e.g.
        :func:`linsense.report.verify_figures.write_certificate_figure` (the certificate is below the
        figures); None: no figure.
    say : callable, optional
        Called with each line of the report and each file written.
    **kwargs : dict
        :func:`~linsense.verify.tuning.tune`'s other arguments (``fmt``, ``quick``, ``verify``,
        ``unverified``, ``scenario``, ``drive``, ...; not ``out`` nor ``ready``).

    Returns
    -------
    TuneResult
        The design, the text, the certificate and the files written (:attr:`TuneResult.files`: the
        scenario or header first); nothing is written for a header refused
        (:attr:`TuneResult.refused`).

    Raises
    ------
    InputError
        What :func:`~linsense.verify.tuning.tune` refuses; a certificate beside ``out`` that is
        another output's (:func:`own_certificate`), before anything runs.
    """
    out = str(out)
    json_path, png_path = certificate_paths(out)  # (their names checked before the work)
    own_certificate(out)

    def ready(res: TuneResult) -> None:  # (a header after its certificate's files, a scenario before)
        if res.certificate is not None:
            _write_certificate(res, out, figure, say)
        res.files.insert(0, write_atomic(out, res.text))
        if out != "-":
            say(str(res.files[0]))

    res = tune(motor, out=out, say=say, ready=ready, **kwargs)
    if res.refused:
        return res
    if res.certificate is None:
        for p in (json_path, png_path):  # (a certificate of an earlier design would be stale)
            p.unlink(missing_ok=True)
    elif res.fmt == "toml":
        _write_certificate(res, out, figure, say)
    return res
