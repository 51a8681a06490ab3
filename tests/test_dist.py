"""What `make dist` puts in dist/: a cp311-abi3 manylinux wheel holding the package and
nothing of the build (no build script, test, or C source but the controller library's, which ships as
package data for `linsense firmware export`), and an sdist holding what the build and the
tests need.

The distributions are built by `make dist` (tools/wheeltest.sh runs this file first, with
``LINSENSE_DIST_REQUIRED=1``: there a missing wheel fails); a plain pytest run without dist/ skips the
checks of the files, never the check of the rule itself.
"""

from __future__ import annotations

import os
import re
import subprocess
import tarfile
import zipfile
from pathlib import Path, PurePosixPath

import pytest

ROOT = Path(__file__).resolve().parents[1]
DIST = ROOT / "dist"

#: what the wheel must hold besides the Python modules (package data read at run time)
REQUIRED = ["linsense/_ctrl.abi3.so", "linsense/model/presets/ecce2010.toml",
            "linsense/fea/presets/tubular56.toml", "linsense/report/templates/report.html.j2",
            "linsense/reproduce/scenarios/paper_step3_lut.toml",
            "linsense/reproduce/sweeps/stability_map.toml"]


#: the C library's files the wheel ships (setup.py's C_LIBRARY, under linsense/csrc/): the CMake
#: package, the public headers, the sources and their internal headers
SHIPPED_C = (r"CMakeLists\.txt", r"cmake/[\w.-]+\.cmake(\.in)?", r"include/linsense/\w+\.h",
             r"ctrl/\w+\.[ch]")


def forbidden(names: list[str]) -> list[str]:
    """The entries of a wheel that have no place in it: anything outside ``linsense/`` and its ``.dist-info``;
    a build script (``build_ctrl.py``, ``_build_ctrl.py``, ``build_flags.py``), a test (``tests/``,
    ``test_*.py``, ``conftest.py``), a C source or header but the controller library's, a tool; a compiled
    module other than the abi3 extension; grafted libraries (``linsense.libs/``: the extension needs none).
    The controller library ships as package data under ``linsense/csrc/`` (:data:`SHIPPED_C`: ``ctrl/``,
    ``include/linsense/``, its CMake files), never the simulator (``csrc/sim``), the C tests or the binding's
    helpers (``csrc/py``). The packaged firmware example (``linsense/examples/firmware/*.c``, what ``linsense
    examples`` copies out) is an example, not a source of the build."""
    bad = []
    for n in names:
        p = PurePosixPath(n)
        top = p.parts[0]
        rel = "/".join(p.parts[2:])
        shipped_c = p.parts[:2] == ("linsense", "csrc") and (
            any(re.fullmatch(r, rel) for r in SHIPPED_C)
            or (n.endswith("/") and rel in ("", "cmake", "ctrl", "include", "include/linsense")))  # (folders)
        if not (top == "linsense" or re.fullmatch(r"linsense-[^/]+\.dist-info", top)):
            bad.append(n)
        elif (re.search(r"build_(ctrl|flags)", p.name) or {"tests", "tools"} & set(p.parts)
              or ("csrc" in p.parts and not shipped_c)
              or re.fullmatch(r"test_.*\.py|conftest\.py", p.name)
              or (p.suffix in (".c", ".h", ".o") and not shipped_c
                  and p.parts[:3] != ("linsense", "examples", "firmware"))
              or (p.suffix in (".so", ".pyd", ".dylib")
                  and not re.fullmatch(r"_ctrl\.(abi3\.so|pyd)", p.name))):
            bad.append(n)
    return bad


def test_the_rule_names_every_kind_of_forbidden_file():
    clean = ["linsense/__init__.py", "linsense/_ctrl.abi3.so", "linsense/model/presets/ecce2010.toml",
             "linsense-0.1.0.dist-info/METADATA", "linsense-0.1.0.dist-info/licenses/LICENSE",
             "linsense/examples/firmware/main.c", "linsense/csrc/ctrl/ls_pi.c",
             "linsense/csrc/ctrl/ls_drive_internal.h", "linsense/csrc/include/linsense/ls_drive.h",
             "linsense/csrc/CMakeLists.txt", "linsense/csrc/cmake/arm-none-eabi-m4f.cmake",
             "linsense/csrc/cmake/linsense-config.cmake.in", "linsense/csrc/",
             "linsense/csrc/include/linsense/"]
    assert forbidden(clean) == []
    bad = ["linsense/_build_ctrl.py", "tools/build_ctrl.py", "linsense/tools/build_ctrl.py",
           "linsense/build_flags.py",
           "tests/test_io.py", "linsense/tests/conftest.py", "linsense/test_x.py", "csrc/ctrl/ls_pi.c",
           "linsense/ls_drive.h", "linsense/csrc/sim/ls_sim.c", "linsense/csrc/sim/ls_sim.h",
           "linsense/csrc/tests/test_drive.c", "linsense/csrc/tests/ls_test.h", "linsense/csrc/py/ls_py.c",
           "linsense/csrc/ctrl/ls_pi.o", "linsense/csrc/ctrl/sub/ls_x.c", "linsense/csrc/include/ls_x.h",
           "linsense/csrc/cmake/notes.txt", "linsense/csrc/sim/", "linsense/csrc/tests/",
           "linsense/_other.cpython-311-x86_64-linux-gnu.so", "linsense.libs/libm-1234.so.6", "setup.py"]
    assert forbidden(clean + bad) == bad


def test_the_shipped_c_library_is_the_exporters():
    """The rule's C files are what linsense firmware export copies (LIBRARY_FILES over csrc/), and
    setup.py copies the same globs (its C_LIBRARY)."""
    from linsense.firmware.project import LIBRARY_FILES, library_files

    expected = library_files(ROOT / "csrc")
    assert {"ctrl/ls_drive.c", "include/linsense/ls_drive.h", "CMakeLists.txt",
            "cmake/arm-none-eabi-m4f.cmake", "cmake/linsense-config.cmake.in",
            "cmake/linsense.pc.cmake.in"} <= set(expected)
    assert forbidden([f"linsense/csrc/{rel}" for rel in expected]) == []
    setup_globs = re.search(r"C_LIBRARY = \(([^)]*)\)", (ROOT / "setup.py").read_text())[1]
    assert tuple(re.findall(r'"([^"]+)"', setup_globs)) == LIBRARY_FILES


def _one(pattern: str) -> Path:
    found = sorted(DIST.glob(pattern)) if DIST.is_dir() else []
    if not found:
        if os.environ.get("LINSENSE_DIST_REQUIRED") == "1":
            pytest.fail(f"no {pattern} in {DIST} (make dist)")
        pytest.skip(f"no {pattern} in {DIST}: run make dist")
    assert len(found) == 1, f"more than one {pattern} in {DIST}: {found}"
    return found[0]


def test_the_wheel_is_abi3_manylinux_and_holds_the_package_only():
    whl = _one("linsense-*.whl")
    assert re.fullmatch(r"linsense-[^-]+-cp311-abi3-manylinux_\d+_\d+_\w+(\.manylinux_\d+_\d+_\w+)*\.whl",
                        whl.name), whl.name
    names = zipfile.ZipFile(whl).namelist()
    assert forbidden(names) == []
    assert not [n for n in REQUIRED if n not in names], "package data missing from the wheel"
    # the C library, whole: every file the exporter copies from a source tree, nothing more
    from linsense.firmware.project import library_files

    shipped = {n.removeprefix("linsense/csrc/") for n in names
               if n.startswith("linsense/csrc/") and not n.endswith("/")}
    assert shipped == set(library_files(ROOT / "csrc")), "the wheel's C library differs from csrc/'s"
    sources = {p.relative_to(ROOT / "src").as_posix() for p in (ROOT / "src" / "linsense").rglob("*.py")}
    assert not sources - set(names), "modules missing from the wheel (or dist/ is stale: make dist)"
    wheel_meta = zipfile.ZipFile(whl).read(next(n for n in names if n.endswith(".dist-info/WHEEL"))).decode()
    assert "Root-Is-Purelib: false" in wheel_meta and re.search(r"Tag: cp311-abi3-manylinux", wheel_meta)


def test_the_sdist_holds_what_the_build_and_the_tests_need():
    sdist = _one("linsense-*.tar.gz")
    with tarfile.open(sdist) as tar:
        names = {n.split("/", 1)[1] for n in tar.getnames() if "/" in n}
    needed = {"setup.py", "pyproject.toml", "MANIFEST.in", "LICENSE", "README.md", "tools/build_ctrl.py",
              "tools/build_flags.py",
              "tests/conftest.py", "tests/test_dist.py", "tools/wheeltest.sh"}
    assert not needed - names
    try:  # every tracked source of the build and of the tests (in a git checkout)
        tracked = subprocess.run(["git", "ls-files", "csrc", "src", "tests", "docs"], cwd=ROOT,
                                 capture_output=True, text=True, check=True).stdout.split()
    except (OSError, subprocess.CalledProcessError):
        pytest.skip("not a git checkout")
    tracked = [t for t in tracked if "fuzz_corpus/" not in t and "fuzz_coverage/" not in t]
    missing = sorted(set(tracked) - names)
    assert not missing, f"tracked files missing from the sdist (or dist/ is stale: make dist): {missing[:10]}"
    assert not [n for n in names if "__pycache__" in n or n.endswith((".so", ".pyc", ".o"))]
