"""The compiler flags have one home each: the Cortex-M4F's in the CMake toolchain file
(``csrc/cmake/arm-none-eabi-m4f.cmake``, read by ``tools/check_mcu.sh`` and ``tools/pil.py``), the
extension's in ``tools/build_flags.py`` (``COMPILE_ARGS``, ``PLANT_ARGS``, ``NATIVE_ARGS``: tables
only, read by ``tools/build_ctrl.py``, ``setup.py`` and ``tools/pil.py``'s host recorder, none of which
loads another's build). No tool or module of the package restates them."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
TOOLCHAIN = ROOT / "csrc" / "cmake" / "arm-none-eabi-m4f.cmake"
BUILD_FLAGS = ROOT / "tools" / "build_flags.py"
#: the readers of the flag tables
READERS = ("tools/build_ctrl.py", "setup.py", "tools/pil.py")

#: the firmware's flags (the toolchain file's), each a sign of a copy wherever else it is written
M4F_FLAGS = ("-mcpu=cortex-m4", "-mfpu=fpv4-sp-d16", "-mfloat-abi=hard", "--specs=nano.specs",
             "--specs=nosys.specs")
#: the extension's flags that only build_flags.py writes (the replays' -O2 -ffp-contract=off are theirs)
EXTENSION_FLAGS = ("-O3", "-march=native", "-ffp-contract=fast")


def _sources() -> list[Path]:
    files = [*(ROOT / "tools").glob("*.py"), *(ROOT / "tools").glob("*.sh"), *(ROOT / "src").rglob("*.py"),
             ROOT / "setup.py"]
    return sorted(p for p in files if p != BUILD_FLAGS and "__pycache__" not in p.parts)


def _copies(flags: tuple[str, ...], files: list[Path]) -> list[str]:
    """``file:line`` of each flag written as a literal (quoted, or a shell word) outside a comment."""
    found = []
    for path in files:
        for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            code = line.split("#", 1)[0]
            for flag in flags:
                if re.search(rf"""["'\s]{re.escape(flag)}(?=["'\s]|$)""", code):
                    found.append(f"{path.name}:{n}: {flag}")
    return found


def test_the_firmware_flags_are_the_toolchain_files():
    text = TOOLCHAIN.read_text(encoding="utf-8")
    assert all(flag in text for flag in M4F_FLAGS), "the toolchain file lost a flag: update M4F_FLAGS"
    assert not _copies(M4F_FLAGS, _sources()), "the Cortex-M4F flags restated (read the toolchain file)"


def test_the_extension_flags_are_build_flags():
    text = BUILD_FLAGS.read_text(encoding="utf-8")
    assert all(f'"{flag}"' in text for flag in EXTENSION_FLAGS), "build_flags.py lost a flag: update the test"
    assert not _copies(EXTENSION_FLAGS, _sources()), "the extension's flags restated (read build_flags.py)"


def test_the_flag_tables_are_read_from_their_home_and_nothing_else_is_loaded_for_them():
    """build_flags.py is tables only (no cffi, no compile: importing it is free); each reader names it,
    and none loads the cffi build script (setup.py did, a second run of build_ctrl.py, for its flags)."""
    imports = re.findall(r"^(?:import|from) (\w+)", BUILD_FLAGS.read_text(encoding="utf-8"), re.M)
    assert set(imports) <= {"__future__", "os"}, imports
    for rel in READERS:
        text = (ROOT / rel).read_text(encoding="utf-8")
        assert "build_flags" in text, f"{rel} does not read tools/build_flags.py"
        assert not re.search(r"import build_ctrl|\"build_ctrl\.py\"\)", text), f"{rel} loads build_ctrl.py"


@pytest.mark.parametrize("text", ['base = ["-std=c99", "-O3", "-march=native"]', "cc -mcpu=cortex-m4 -c x.c",
                                  '    flags = ["-ffp-contract=fast"]  # the plant'])
def test_a_copy_is_found(tmp_path, text):
    path = tmp_path / "tool.py"
    path.write_text(text + "\n", encoding="utf-8")
    assert _copies(M4F_FLAGS + EXTENSION_FLAGS, [path])
