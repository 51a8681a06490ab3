"""``linsense firmware export``: a folder that builds the firmware with CMake alone.

The folder (docs/firmware.md, "The exported project")::

    CMakeLists.txt              the example's project: add_subdirectory(linsense), firmware_example
    main.c                      the example (src/linsense/examples/firmware/main.c)
    ls_cfg_<name>.h             the drive's configuration designed for the motor (tune --format c)
    ls_example.h                the example's names for it and its synthetic motor (generated)
    cmake/arm-none-eabi-m4f.cmake   the Cortex-M4F toolchain file
    linsense/                   the C library: CMakeLists.txt (linsense::ctrl), cmake/, include/, ctrl/
    README.md

``cmake -S DIR -B b && cmake --build b`` builds it on the host; with
``-DCMAKE_TOOLCHAIN_FILE=DIR/cmake/arm-none-eabi-m4f.cmake`` for the Cortex-M4F. Nothing in it
refers to a file outside the folder. The library's files are those the wheel ships
(:data:`LIBRARY_FILES` under :func:`library_root`: ``linsense/csrc`` in an installed package, the
repository's ``csrc`` in an editable install).

The configuration header carries its own tables (the compensation and gain tables and their
slopes in the resistance), so the folder needs no separate LUT header; every generated header is
stamped with the linsense version and the SHA-256 of the motor and drive data
(:mod:`linsense.compensation.stamp`), and ``ls_drive_init`` refuses a configuration of another
version.
"""

from __future__ import annotations

import dataclasses
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from linsense.compensation.lut import c_comment_text
from linsense.compensation.stamp import stamp_comment, stamp_macros
from linsense.errors import InputError
from linsense.tune.export import c_config_name
from linsense.version import __version__, docs

#: the C library's files (globs relative to :func:`library_root`) that the wheel ships and an export
#: copies: the CMake package, the public headers, the sources and their internal headers (not the
#: simulator, the tests or the Python binding's helpers)
LIBRARY_FILES = ("CMakeLists.txt", "cmake/*.cmake", "cmake/*.cmake.in", "include/linsense/*.h",
                 "ctrl/*.c", "ctrl/*.h")

#: the library's folder in an export
LIBRARY_DIR = "linsense"

#: the example's synthetic motor: held at this electrical angle (deg); the drive starts sensorless
#: :data:`EXAMPLE_START_ERROR_DEG` away and must converge within 0.5 deg in 0.25 s
EXAMPLE_THETA_DEG = 40.0
EXAMPLE_START_ERROR_DEG = 10.0
#: the example's run, s of PWM periods
EXAMPLE_DURATION = 0.25


def library_root() -> Path:
    """The folder of the C library's files: the parent of :func:`linsense.get_include`.

    Returns
    -------
    Path
        ``.../linsense/csrc`` (installed package) or the repository's ``csrc`` (editable install).
    """
    from linsense import get_include

    return Path(get_include()).parent


def library_files(root: Path | None = None) -> dict[str, Path]:
    """The library's files by their path relative to ``root``.

    Parameters
    ----------
    root : Path or None, optional
        The library's folder (default :func:`library_root`).

    Returns
    -------
    dict of str to Path
        ``"ctrl/ls_drive.c"``: its path, sorted by name.
    """
    root = library_root() if root is None else Path(root)
    found = {}
    for pattern in LIBRARY_FILES:
        for p in root.glob(pattern):
            if p.is_file():
                found[p.relative_to(root).as_posix()] = p
    return dict(sorted(found.items()))


def example_main() -> str:
    """The example's ``main.c`` (the packaged firmware example).

    Returns
    -------
    str
        Its text.
    """
    from linsense.examples import ROOT

    return (ROOT / "firmware" / "main.c").read_text(encoding="utf-8")


@dataclass(frozen=True)
class FirmwareExport:
    """What :func:`firmware_files` made.

    Parameters
    ----------
    files : dict of str to bytes
        Each file's path in the folder (``/`` separators) and contents.
    name : str
        The configuration's C name (``ls_cfg_<name>.h``).
    motor : str
        The motor's name.
    digest : str
        SHA-256 of the motor and drive data (the headers' stamp).
    lines : list of str
        The design as a person reads it (one line each).
    design : Design
        The design (:func:`linsense.tune.design.design`), for its certificate.
    header : callable
        ``header(unverified: str, verified_by: str) -> str``: the configuration header
        (:meth:`certified`).
    warnings : list of str
        What the design could not meet, or doubts a measured table's fit raises
        (:func:`linsense.compensation.measured.fit_report`, as ``linsense tune`` says them).
    drive_design : DriveDesign
        The drive's design (:func:`linsense.tune.drive_design.design_drive`), for its certificate's
        scenario.
    """

    files: dict[str, bytes]
    name: str
    motor: str
    digest: str
    lines: list[str] = field(default_factory=list)
    design: object = None
    header: object = None
    warnings: list[str] = field(default_factory=list)
    drive_design: object = None

    def certified(self, unverified: str = "", verified_by: str = "") -> FirmwareExport:
        """The same files with the configuration header saying what verified it, or why it is
        written unverified.

        Parameters
        ----------
        unverified : str, optional
            The certificate's failed checks (``--unverified``).
        verified_by : str, optional
            The certificate it passed.

        Returns
        -------
        FirmwareExport
            A copy whose ``ls_cfg_<name>.h`` says so in its comment.
        """
        files = dict(self.files)
        files[f"ls_cfg_{self.name}.h"] = self.header(unverified, verified_by).encode()
        return dataclasses.replace(self, files=files)


def firmware_files(motor, drive=None, source: str = "<firmware export>", name: str | None = None,
                   points: int = 256, table=None, table_via: tuple[str, str, str] | None = None
                   ) -> FirmwareExport:
    """Design the drive for ``motor`` and make the exported folder's files.

    The design is ``linsense tune``'s (:func:`linsense.tune.design.design`, the start-up from the
    motor's saturation data when it has them), written as ``tune --format c`` writes it.

    Parameters
    ----------
    motor : Motor
        The motor.
    drive : DriveData or None, optional
        The drive (None: the defaults; a scenario's: :func:`linsense.sim.build.drive_data`).
    source : str, optional
        Named in messages (the motor or scenario given).
    name : str or None, optional
        The C name (default the motor's, made an identifier).
    points : int, optional
        Table points.
    table : str or None, optional
        A measured compensation table's file in place of the motor file's table
        (:func:`linsense.compensation.measured.read_measured_table`: checked against the motor and
        the designed injection, resampled to ``points``).
    table_via : tuple of str or None, optional
        Where ``table`` was named when a scenario named it (``(scenario, "observer.lut_file",
        value)``: a refusal of the table names them).

    Returns
    -------
    FirmwareExport
        The files and what they hold.

    Raises
    ------
    linsense.errors.InputError
        A drive whose injection is not the pulsating/elliptical one (the configuration header's),
        or a design refused (:func:`~linsense.tune.design.design`).
    linsense.errors.LinsenseError
        The library's files not found (:func:`linsense.get_include`).
    """
    from linsense.tune.design import DriveData
    from linsense.tune.drive_design import design_drive
    from linsense.tune.export import c_header, design_digest

    dd = drive if drive is not None else DriveData()
    if dd.shape != "pulsating":
        raise InputError(source, "injection.shape",
                         f"the firmware export configures the pulsating/elliptical injection (ls_cfg_*.h), "
                         f"not the {dd.shape} one: its C configuration is the simulator's "
                         f"(linsense.sim.drive_cfg; {docs('firmware')})")
    lib = _complete_library()
    made = design_drive(motor, dd, source=source, analyse=False, table=table, table_via=table_via,
                        points=points)
    dz, su, table = made.design, made.startup, made.table
    warnings = [f"{table.source}: {made.table_fit[1]}"] if table is not None and made.table_fit[1] else []
    sym = c_config_name(name, motor.name)
    digest = design_digest(motor, dd, points, table)
    cfg_name = f"ls_cfg_{sym}.h"

    def header(unverified: str = "", verified_by: str = "") -> str:
        return c_header(made, name=name, points=points, unverified=unverified, verified_by=verified_by)

    files = _library_copy(lib)
    files[cfg_name] = header().encode()
    files["ls_example.h"] = example_header(motor, dd, sym, digest).encode()
    files["main.c"] = example_main().encode()
    files["CMakeLists.txt"] = cmake_lists(sym).encode()
    files["README.md"] = readme(motor.name, sym, digest).encode()
    lines = [f"firmware for {motor.name}: {dd.v_dc:g} V bus, {dd.f_pwm:g} Hz PWM, injection "
             f"{dz.v_inj:.4g} V / {dz.f_inj:g} Hz (kappa {dz.quad:g}), observer {dz.observer_bw:.4g} Hz, "
             f"start-up {'designed' if su is not None else 'not designed (no saturation data)'}",
             f"  linsense {__version__}, data sha256 {digest}"]
    return FirmwareExport(files=files, name=sym, motor=motor.name, digest=digest, lines=lines, design=dz,
                          header=header, warnings=warnings, drive_design=made)


def _complete_library() -> dict[str, Path]:
    """The C library's files (:func:`library_files`), refused when the ones every build needs are missing.

    Raises
    ------
    linsense.errors.LinsenseError
        A file every build needs is missing (a broken installation).
    """
    lib = library_files()
    missing = [p for p in ("CMakeLists.txt", "include/linsense/ls_drive.h", "ctrl/ls_drive.c")
               if p not in lib]
    if missing:
        from linsense.errors import LinsenseError

        raise LinsenseError(f"the C library's files are incomplete under {library_root()}: "
                            f"{', '.join(missing)} missing (a broken installation: reinstall linsense)")
    return lib


def _library_copy(lib: dict[str, Path]) -> dict[str, bytes]:
    """The exported folder's copy of the C library: each file under :data:`LIBRARY_DIR`, and the
    Cortex-M4F toolchain file at the folder's top as well (empty when the library has none)."""
    files = {f"{LIBRARY_DIR}/{rel}": path.read_bytes() for rel, path in lib.items()}
    toolchain = "cmake/arm-none-eabi-m4f.cmake"
    files[toolchain] = lib[toolchain].read_bytes() if toolchain in lib else b""
    return files


def example_header(motor, drive, sym: str, digest: str) -> str:
    """``ls_example.h``: the example's names for the configuration and its synthetic motor.

    The motor's alpha-beta inductance at :data:`EXAMPLE_THETA_DEG` (its HF model), its resistance,
    the bus voltage and PWM frequency of the drive.

    Parameters
    ----------
    motor : Motor
        The motor.
    drive : DriveData
        The drive.
    sym : str
        The configuration's C name.
    digest : str
        The stamp's digest.

    Returns
    -------
    str
        The header's text.
    """
    L = np.asarray(motor.inductance.L_ab(np.radians(EXAMPLE_THETA_DEG)), dtype=float)
    up = sym.upper()
    steps = max(int(round(EXAMPLE_DURATION * drive.f_pwm)), 1)
    shown = c_comment_text(motor.name)
    name_literal = '"' + motor.name.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if not name_literal.isascii() or any(ch in motor.name for ch in "\n\r"):
        name_literal = f'"{sym}"'
    return (
        f"/* Generated by linsense {__version__} (`linsense firmware export`): do not edit.\n"
        f" *\n"
        f" * The firmware example's view of the configuration ls_cfg_{sym}.h, and its synthetic motor:\n"
        f" * {shown} held at {EXAMPLE_THETA_DEG:g} electrical degrees, its HF model's alpha-beta inductance\n"
        f" * there and its resistance; the drive's bus voltage and PWM frequency.\n"
        + stamp_comment(digest) +
        f" */\n"
        f"#ifndef LS_EXAMPLE_H\n"
        f"#define LS_EXAMPLE_H\n\n"
        f"#include \"ls_cfg_{sym}.h\"\n\n"
        + stamp_macros("LS_EXAMPLE", digest) +
        f"#define EX_MOTOR {name_literal}\n"
        f"#define EX_CFG ls_cfg_{sym}\n"
        f"#define EX_LEN {up}_LEN\n"
        f"#define EX_COMP ls_cfg_{sym}_comp\n"
        f"#define EX_GAIN ls_cfg_{sym}_gain\n"
        f"#define EX_COMP_R ls_cfg_{sym}_comp_r\n"
        f"#define EX_GAIN_R ls_cfg_{sym}_gain_r\n\n"
        f"#define EX_THETA_DEG {EXAMPLE_THETA_DEG!r} /* deg (electrical), the armature's position */\n"
        f"#define EX_L_AA {float(L[0, 0])!r} /* H, L_alpha there */\n"
        f"#define EX_L_BB {float(L[1, 1])!r} /* H, L_beta */\n"
        f"#define EX_L_AB {float(L[0, 1])!r} /* H, their mutual inductance */\n"
        f"#define EX_R_S {float(motor.R_s)!r} /* ohm, phase resistance */\n"
        f"#define EX_V_DC {float(drive.v_dc)!r} /* V, DC bus */\n"
        f"#define EX_F_PWM {float(drive.f_pwm)!r} /* Hz, PWM = control rate */\n"
        f"#define EX_STEPS {steps}L /* PWM periods run ({EXAMPLE_DURATION:g} s) */\n\n"
        f"#endif /* LS_EXAMPLE_H */\n"
    )


def cmake_lists(sym: str) -> str:
    """The exported folder's CMakeLists.txt.

    Parameters
    ----------
    sym : str
        The configuration's C name.

    Returns
    -------
    str
        Its text.
    """
    return f"""# Generated by linsense {__version__} (`linsense firmware export`).
#
#   cmake -S . -B build && cmake --build build && build/firmware_example          (host)
#   cmake -S . -B build-m4f -DCMAKE_TOOLCHAIN_FILE=cmake/arm-none-eabi-m4f.cmake
#   cmake --build build-m4f                                                        (Cortex-M4F)
#
# linsense/ is the controller library (target linsense::ctrl; -DLINSENSE_DOUBLE=ON for double);
# ls_cfg_{sym}.h the drive's configuration; main.c the example. In your own project:
# add_subdirectory(linsense) and target_link_libraries(your_firmware PRIVATE linsense::ctrl).
cmake_minimum_required(VERSION 3.16)
project(linsense_firmware_{sym} C)

if(NOT CMAKE_BUILD_TYPE AND NOT CMAKE_CONFIGURATION_TYPES)
  if(NOT LINSENSE_DEFAULT_BUILD_TYPE)  # (the M4F toolchain file's: MinSizeRel)
    set(LINSENSE_DEFAULT_BUILD_TYPE Release)
  endif()
  set(CMAKE_BUILD_TYPE ${{LINSENSE_DEFAULT_BUILD_TYPE}} CACHE STRING "build type" FORCE)
endif()

add_subdirectory(linsense)

add_executable(firmware_example main.c)
set_target_properties(firmware_example PROPERTIES
  C_STANDARD 99 C_STANDARD_REQUIRED ON C_EXTENSIONS OFF)
target_include_directories(firmware_example PRIVATE ${{CMAKE_CURRENT_SOURCE_DIR}})
target_link_libraries(firmware_example PRIVATE linsense::ctrl)
if(CMAKE_C_COMPILER_ID MATCHES "GNU|Clang")
  target_compile_options(firmware_example PRIVATE -Wall -Wextra -Wpedantic
                         $<$<BOOL:${{LINSENSE_WERROR}}>:-Werror>)
endif()
if(CMAKE_CROSSCOMPILING AND CMAKE_SIZE)
  add_custom_command(TARGET firmware_example POST_BUILD
                     COMMAND ${{CMAKE_SIZE}} $<TARGET_FILE:firmware_example>)
endif()
"""


def readme(motor_name: str, sym: str, digest: str) -> str:
    """The exported folder's README.md.

    Parameters
    ----------
    motor_name : str
        The motor's name.
    sym : str
        The configuration's C name.
    digest : str
        The stamp's digest.

    Returns
    -------
    str
        Its text.
    """
    return f"""# linsense firmware for {motor_name}

Written by `linsense firmware export` (linsense {__version__}; sha256 of the motor and drive data
`{digest}`). Everything here builds with CMake alone:

```sh
cmake -S . -B build && cmake --build build && build/firmware_example
cmake -S . -B build-m4f -DCMAKE_TOOLCHAIN_FILE=cmake/arm-none-eabi-m4f.cmake && cmake --build build-m4f
```

* `linsense/`: the controller library, CMake target `linsense::ctrl` (C99, float; `-DLINSENSE_DOUBLE=ON`
  for double). Use it with `add_subdirectory(linsense)`, or install it (`cmake --install`) and
  `find_package(linsense)`.
* `ls_cfg_{sym}.h`: the drive's configuration designed for the motor (gains, limits, the compensation
  and gain tables). `ls_drive_init` refuses it (`LS_ERR_VERSION`) with a library of another version.
* `main.c`, `ls_example.h`: the example, a PWM interrupt around `ls_drive_step` on a synthetic motor
  (the armature held; the drive starts sensorless 10 degrees off and must converge).
* `cmake/arm-none-eabi-m4f.cmake`: the Cortex-M4F toolchain file (arm-none-eabi-gcc, hard float,
  newlib-nano). The example's image has no linker script for a part: your project brings its own.

Documentation: the firmware guide, {docs("firmware")}.
"""


def write_firmware(folder: str | os.PathLike, export: FirmwareExport) -> list[Path]:
    """Write an export into ``folder`` as one output set (:func:`linsense.io.output_set`).

    Parameters
    ----------
    folder : str or os.PathLike
        The folder: missing, empty or an earlier output set of linsense (entries it did not write,
        e.g. a build folder, are kept).
    export : FirmwareExport
        The files (:func:`firmware_files`).

    Returns
    -------
    list of Path
        The files written.
    """
    from linsense.io import output_set

    with output_set(folder, "firmware export") as s:
        for rel, data in export.files.items():
            s.write(rel, data)
    return list(s.files)
