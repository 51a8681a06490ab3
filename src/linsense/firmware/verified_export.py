"""The firmware export of a verified drive: design, quick certificate, folder (``linsense firmware export``).

:func:`export_firmware` is what the command runs, so that Python reaches it too: the folder's files
(:func:`~linsense.firmware.project.firmware_files`, the design of
:func:`~linsense.tune.drive_design.design_drive`), then the quick certificate of the same drive
(switching inverter with dead time, :mod:`linsense.verify.certificate`), then the folder, written
only for a drive that passes unless ``unverified`` (its configuration header then says why).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from linsense.errors import InputError, as_given
from linsense.firmware.project import FirmwareExport, firmware_files, write_firmware
from linsense.io import Say, quiet, working_folder
from linsense.tune.design import DriveData
from linsense.tune.export import c_config_name, scenario_dict
from linsense.verify.certificate import (
    VERIFIED_BY,
    Certificate,
    certificate_base,
    failed_summary,
    motor_ref,
    prepare,
)


@dataclass
class ExportResult:
    """What :func:`export_firmware` made.

    Parameters
    ----------
    export : FirmwareExport
        The folder's files, the configuration header saying what verified it (or why it is
        unverified).
    certificate : Certificate
        The quick certificate of the drive.
    reason : str
        The certificate's failed checks, ``""`` when it passed.
    files : list of Path
        The files written (empty when the drive failed and ``unverified`` was not given).
    """

    export: FirmwareExport
    certificate: Certificate
    reason: str = ""
    files: list[Path] = field(default_factory=list)

    @property
    def written(self) -> bool:
        """Whether the folder was written."""
        return bool(self.files)


def export_firmware(folder: str | Path, motor, drive: DriveData | None = None, *, motor_spec: str,
                    source: str | None = None, name: str | None = None, table: str | None = None,
                    table_via: tuple[str, str, str] | None = None, unverified: bool = False,
                    say: Say = quiet, warn: Say = quiet,
                    refusal: Callable[[InputError], InputError] = as_given) -> ExportResult:
    """Design the drive, prove it with the quick certificate and write the firmware folder.

    docs/firmware.md, "Export"; the command ``linsense firmware export`` wraps it.

    Parameters
    ----------
    folder : str or Path
        The folder: missing, empty or an earlier output of linsense.
    motor : Motor
        The motor.
    drive : DriveData or None, optional
        The drive and application (None: the defaults).
    motor_spec : str
        How the motor was named (a preset or a file), for the certificate's scenarios.
    source : str or None, optional
        Where the drive data came from, named in refusals (None: ``motor_spec``).
    name : str or None, optional
        The configuration's C name (``ls_cfg_<name>.h``; None: the motor's).
    table : str or None, optional
        A measured table's file (``lut_measured.json``): the drive's compensation table.
    table_via : tuple of str or None, optional
        Where that table was named (a scenario's key), for the design's messages.
    unverified : bool, optional
        Write the folder even if the certificate fails (its header says why).
    say, warn : callable, optional
        Called with each line of the design and the certificate, and with each warning.
    refusal : callable, optional
        Maps a refusal of the design to the one raised (the command names the option typed).

    Returns
    -------
    ExportResult
        The files, the certificate and what was written.

    Raises
    ------
    linsense.errors.InputError
        A drive the design refuses, or a name that is no C identifier, before anything runs.
    """
    dd = drive if drive is not None else DriveData()
    c_config_name(name, motor.name, "--name")  # (checked before anything is designed)
    try:
        made = firmware_files(motor, dd, source or motor_spec, name, table=table, table_via=table_via)
    except InputError as exc:
        raise refusal(exc) from None
    for line in made.lines:
        say(line)
    for w in made.warnings:
        warn(w)
    cert = _quick_certificate(motor_spec, motor, dd, made, table)
    lines = cert.lines()
    if cert.passed:  # (the export's own check: the quick certificate; tune --format c runs the full one)
        lines[-1] = ("quick certificate passed: written (linsense tune --format c runs the full "
                     "certificate of the same drive)")
    for line in lines:
        say(line)
    reason = "" if cert.passed else failed_summary(cert)
    if reason and not unverified:
        return ExportResult(made, cert, reason)
    made = made.certified(reason, "" if reason else VERIFIED_BY[True])
    return ExportResult(made, cert, reason, write_firmware(folder, made))


def _quick_certificate(motor_spec: str, motor, dd: DriveData, made: FirmwareExport,
                       table: str | None) -> Certificate:
    """The quick certificate of the exported drive (the design ``made`` holds, with its table)."""
    spec = motor_ref(motor_spec)
    table = None if table is None else str(Path(table).resolve())
    base = certificate_base(scenario_dict(made.drive_design, motor_ref=spec, table=table))
    return prepare(motor, spec, base, str(working_folder()), v_max=dd.v_max, a_max=dd.a_max,
                   load=made.design.load, travel=dd.travel, quick=True)()
