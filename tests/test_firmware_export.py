"""``linsense firmware export``: a folder that builds the firmware with CMake
alone, on the host and for the Cortex-M4F; the C library's files from the package
(``linsense.get_include()``); every generated header stamped with the linsense version and the
SHA-256 of its motor and drive data; ``ls_drive_init`` refusing a configuration of another version.

The builds need cmake and a C compiler (the M4F's arm-none-eabi-gcc): skipped where they are
missing (make tools installs them; the wheel's test venv has no compiler).
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
from pathlib import Path

import pytest

import linsense
from linsense.compensation.lut import build_lut, to_c_header
from linsense.compensation.stamp import data_digest, version_number
from linsense.firmware.project import LIBRARY_DIR, firmware_files, library_files, library_root

ROOT = Path(__file__).resolve().parents[1]
HAVE_HOST = shutil.which("cmake") is not None and shutil.which("cc") is not None
HAVE_M4F = shutil.which("cmake") is not None and shutil.which("arm-none-eabi-gcc") is not None


def _c_version(include: Path) -> tuple[int, int, int]:
    text = (include / "linsense" / "ls_types.h").read_text()
    return tuple(int(re.search(rf"#define LS_VERSION_{k} (\d+)", text)[1])
                 for k in ("MAJOR", "MINOR", "PATCH"))


# ---------------------------------------------------------------------------------- the sources
def test_get_include_names_the_headers_of_this_version():
    inc = Path(linsense.get_include())
    assert inc.is_absolute() and (inc / "linsense" / "ls_drive.h").is_file()
    pkg = Path(linsense.__file__).resolve().parent
    # the wheel's copy (linsense/csrc/include) or, in an editable install, the repository's csrc/include
    assert inc in (pkg / "csrc" / "include", pkg.parents[1] / "csrc" / "include")
    assert ".".join(map(str, _c_version(inc))) == linsense.__version__
    assert library_root() == inc.parent


def test_library_files_are_the_library_only():
    files = library_files()
    assert "ctrl/ls_drive.c" in files and "ctrl/ls_drive_internal.h" in files
    assert "include/linsense/ls_drive.h" in files and "CMakeLists.txt" in files
    assert "cmake/arm-none-eabi-m4f.cmake" in files and "cmake/linsense-config.cmake.in" in files
    assert not [r for r in files if r.split("/")[0] in ("sim", "tests", "py")]
    ctrl = {p.name for p in (library_root() / "ctrl").glob("*.c")}
    assert {r.split("/")[1] for r in files if r.startswith("ctrl/") and r.endswith(".c")} == ctrl


# ---------------------------------------------------------------------------------- the folder
def test_export_writes_a_self_contained_folder(run_cli, tmp_path):
    out = tmp_path / "fw"
    r = run_cli("firmware", "export", out, "--motor", "ecce2010", "--json")
    assert r.code == 0, r.err
    doc = json.loads(r.out)
    assert doc["command"] == "firmware export" and doc["ok"] is True and doc["name"] == "ecce2010"
    assert re.fullmatch(r"[0-9a-f]{64}", doc["digest"])
    written = sorted(p.relative_to(out).as_posix() for p in out.rglob("*") if p.is_file()
                     and not p.name.startswith("."))
    lib = [f"{LIBRARY_DIR}/{rel}" for rel in library_files()]
    assert written == sorted(["CMakeLists.txt", "README.md", "main.c", "ls_cfg_ecce2010.h", "ls_example.h",
                              "cmake/arm-none-eabi-m4f.cmake", *lib])
    assert sorted(str(Path(f).relative_to(out).as_posix()) for f in doc["files"]) == written
    for rel in library_files():
        assert (out / LIBRARY_DIR / rel).read_bytes() == (library_root() / rel).read_bytes()
    # nothing in it names a file outside the folder
    for p in out.rglob("*"):
        if p.is_file():
            text = p.read_text(encoding="utf-8", errors="replace")
            assert str(ROOT) not in text and str(library_root()) not in text, p
            assert not re.search(r'#include\s+"\.\./', text), p
    cfg = (out / "ls_cfg_ecce2010.h").read_text()
    assert f"linsense {linsense.__version__}" in cfg and doc["digest"] in cfg
    assert "cfg->lib_version = LS_CFG_ECCE2010_LIB_VERSION;" in cfg
    assert f"#define LS_CFG_ECCE2010_LIB_VERSION 0x{version_number():06x}u" in cfg
    assert "ECCE2010_LEN" in (out / "ls_example.h").read_text()


def test_export_takes_a_scenarios_drive_and_refuses_what_it_cannot_write(run_cli, tmp_path):
    r = run_cli("firmware", "export", tmp_path / "a", "--motor", "small30", "--scenario", "step3_lut")
    assert r.code == 0, r.err
    r2 = run_cli("firmware", "export", tmp_path / "b", "--motor", "small30", "--name", "axis_2")
    assert r2.code == 0, r2.err
    assert (tmp_path / "b" / "ls_cfg_axis_2.h").is_file()
    run_cli("firmware", "export", tmp_path / "q", "--motor", "ecce2010", "--scenario",
            "hold_square").refused("injection.shape", "square")
    assert not (tmp_path / "q").exists()
    run_cli("firmware", "export", tmp_path / "n", "--motor", "nosuch").refused("nosuch")
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine" / "notes.txt").write_text("mine")
    run_cli("firmware", "export", tmp_path / "mine", "--motor", "ecce2010").refused()
    assert (tmp_path / "mine" / "notes.txt").read_text() == "mine"


def test_the_design_is_tunes(run_cli, tmp_path):
    """The exported ls_cfg header is what `linsense tune --format c --quick` writes for the same
    motor (both passed the quick certificate, and say so)."""
    hdr = tmp_path / "ls_cfg_small30.h"
    assert run_cli("tune", "--quick", "--motor", "small30", "--format", "c", "--out", hdr).code == 0
    from linsense.model.motor import load_motor
    from linsense.verify.certificate import VERIFIED_BY

    made = firmware_files(load_motor("small30")).certified("", VERIFIED_BY[True])  # (what the export writes)
    assert made.files["ls_cfg_small30.h"].decode() == hdr.read_text()
    assert "Verified: the quick certificate" in hdr.read_text()


# ---------------------------------------------------------------------------------- the stamps
def test_generated_headers_state_the_version_and_the_datas_digest(ecce, tmp_path):
    from linsense.model.motor import load_motor, motor_to_toml
    from linsense.tune import DriveData, design_drive
    from linsense.tune.export import c_header

    text = to_c_header(build_lut(ecce, 64, f_inj=1000.0))
    d = build_lut(ecce, 64, f_inj=1000.0).digest
    assert re.fullmatch(r"[0-9a-f]{64}", d) and d in text and f"linsense {linsense.__version__}" in text
    assert f"#define LS_LUT_ECCE2010_LIB_VERSION 0x{version_number():06x}u" in text
    assert f'#define LS_LUT_ECCE2010_DATA_SHA256 "{d}"' in text
    # the digest follows the data, not where it came from
    copy = tmp_path / "elsewhere" / "m.toml"
    copy.parent.mkdir()
    copy.write_text(motor_to_toml(ecce))
    assert build_lut(load_motor(copy), 64, f_inj=1000.0).digest == d
    hotter = copy.with_name("hot.toml")
    hotter.write_text(motor_to_toml(ecce).replace("R_s = 9.0", "R_s = 9.5"))
    assert "R_s = 9.5" in hotter.read_text()
    assert build_lut(load_motor(hotter), 64, f_inj=1000.0).digest != d
    assert build_lut(ecce, 64, f_inj=1200.0).digest != d and build_lut(ecce, 65, f_inj=1000.0).digest != d
    # the configuration header: the motor and the drive data
    dd = DriveData()
    h1 = c_header(design_drive(ecce, dd, analyse=False, startup=False))
    dd2 = DriveData(v_dc=80.0)
    h2 = c_header(design_drive(ecce, dd2, analyse=False, startup=False))
    d1, d2 = data_digest(motor=ecce, drive=dd, points=256), data_digest(motor=ecce, drive=dd2, points=256)
    assert d1 != d2 and d1 in h1 and d2 in h2 and f"linsense {linsense.__version__}" in h1


def test_stamp_version_is_the_c_librarys():
    major, minor, patch = _c_version(Path(linsense.get_include()))
    assert version_number() == (major << 16) | (minor << 8) | patch
    with pytest.raises(ValueError):
        version_number("1.2")


def test_ls_drive_init_refuses_a_configuration_of_another_version():
    from linsense.ctrl import drive_default_cfg, ffi, lib

    cfg = drive_default_cfg()
    major, minor, patch = (int(p) for p in linsense.__version__.split("."))
    assert cfg.lib_version == (major << 16) | (minor << 8) | patch
    d = ffi.new("ls_drive *")
    assert lib.ls_drive_init(d, cfg) == lib.LS_OK
    for other in (cfg.lib_version + 1, cfg.lib_version - 1 if cfg.lib_version else 1 << 16, 0):
        cfg.lib_version = other
        assert lib.ls_drive_init(d, cfg) == lib.LS_ERR_VERSION == 3
        assert not d.initialised


# ---------------------------------------------------------------------------------- the builds
def _cmake(*args, cwd: Path) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if not k.startswith(("CMAKE_", "LINSENSE"))}
    r = subprocess.run(["cmake", *map(str, args)], cwd=cwd, capture_output=True, text=True, env=env,
                       timeout=600)
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    return r


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    from linsense.firmware.project import write_firmware
    from linsense.model.motor import load_motor

    out = tmp_path_factory.mktemp("export") / "fw"
    write_firmware(out, firmware_files(load_motor("ecce2010")))
    return out


@pytest.mark.skipif(not HAVE_HOST, reason="needs cmake and a C compiler (make tools)")
def test_the_exported_folder_builds_and_runs_on_the_host(exported, tmp_path):
    """`cmake -S DIR -B b && cmake --build b`, from a copy of the folder elsewhere (nothing refers
    back to this repository or to the first place); the example converges. Then a configuration
    header of another version: ls_drive_init refuses it and the example says so."""
    src = tmp_path / "copy"
    shutil.copytree(exported, src)
    b = tmp_path / "b"
    _cmake("-S", src, "-B", b, "-DCMAKE_EXPORT_COMPILE_COMMANDS=ON", cwd=tmp_path)
    _cmake("--build", b, "-j", "2", cwd=tmp_path)
    commands = (b / "compile_commands.json").read_text()
    assert str(ROOT) not in commands and str(exported) not in commands
    assert "-ffp-contract=off" in commands and "-std=c99" in commands
    r = subprocess.run([b / "firmware_example"], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stdout + r.stderr
    assert re.search(r"ecce2010: converged to [\d.]+ deg, -?0\.\d+ deg from the true position", r.stdout)
    hdr = src / "ls_cfg_ecce2010.h"
    text = hdr.read_text()
    hdr.write_text(re.sub(r"(#define LS_CFG_ECCE2010_LIB_VERSION) 0x[0-9a-f]+u", r"\1 0x7f0000u", text))
    _cmake("--build", b, cwd=tmp_path)
    r = subprocess.run([b / "firmware_example"], capture_output=True, text=True, timeout=120)
    assert r.returncode == 2 and "LS_ERR_VERSION" in r.stderr, r.stdout + r.stderr


@pytest.mark.skipif(not HAVE_M4F, reason="needs cmake and arm-none-eabi-gcc (make tools)")
def test_the_exported_folder_builds_for_the_cortex_m4f(exported, tmp_path):
    b = tmp_path / "m4f"
    toolchain = exported / "cmake" / "arm-none-eabi-m4f.cmake"
    _cmake("-S", exported, "-B", b, f"-DCMAKE_TOOLCHAIN_FILE={toolchain}", cwd=tmp_path)
    r = _cmake("--build", b, cwd=tmp_path)
    elf = b / "firmware_example"
    assert elf.read_bytes()[:4] == b"\x7fELF" and elf.read_bytes()[18] == 40  # (e_machine EM_ARM)
    flags = (b / LIBRARY_DIR / "CMakeFiles" / "linsense_ctrl.dir" / "flags.make").read_text()
    for flag in ("-mcpu=cortex-m4", "-mthumb", "-mfpu=fpv4-sp-d16", "-mfloat-abi=hard", "-Os",
                 "-Wdouble-promotion", "-Werror", "-ffp-contract=off"):
        assert flag in flags, flag
    assert "text" in r.stdout  # (the size printed after the link)
