"""The C library as a CMake package: ``csrc/CMakeLists.txt``'s target
``linsense::ctrl`` used by ``add_subdirectory`` and by ``find_package(linsense)`` after ``cmake
--install`` (the exported targets, the config and version files, the version from ls_types.h), the
double option carried to its users, the C tests registered with CTest in three variants.

Needs cmake and a C compiler (make tools installs cmake); skipped where they are missing.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
from pathlib import Path

import pytest

import linsense

ROOT = Path(__file__).resolve().parents[1]
CSRC = ROOT / "csrc"

pytestmark = pytest.mark.skipif(shutil.which("cmake") is None or shutil.which("cc") is None
                                or not (CSRC / "CMakeLists.txt").is_file(),
                                reason="needs cmake, a C compiler and the repository's csrc/")

#: a user's program: the library's version, its real type and a drive initialised from the defaults
APP = r"""
#include <stdio.h>
#include "linsense/ls_drive.h"

int main(void)
{
    static ls_drive d;
    ls_drive_cfg cfg;
    ls_drive_default_cfg(&cfg);
    printf("version %d.%d.%d real %u init %d\n", LS_VERSION_MAJOR, LS_VERSION_MINOR, LS_VERSION_PATCH,
           (unsigned)sizeof(LS_REAL), (int)ls_drive_init(&d, &cfg));
    cfg.lib_version = LS_VERSION + 1u;
    printf("other version %d\n", (int)ls_drive_init(&d, &cfg));
    return 0;
}
"""


def _run(*args, cwd: Path, ok: bool = True) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if not k.startswith(("CMAKE_", "LINSENSE"))}
    r = subprocess.run([str(a) for a in args], cwd=cwd, capture_output=True, text=True, env=env, timeout=600)
    if ok:
        assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    return r


def _app(folder: Path, body: str) -> Path:
    folder.mkdir(parents=True)
    (folder / "app.c").write_text(APP)
    (folder / "CMakeLists.txt").write_text(
        "cmake_minimum_required(VERSION 3.16)\nproject(app C)\n" + body +
        "add_executable(app app.c)\ntarget_link_libraries(app PRIVATE linsense::ctrl)\n")
    return folder


def _version_line() -> str:
    return f"version {linsense.__version__} "


@pytest.fixture(scope="module")
def installed(tmp_path_factory):
    """The library configured, built (Debug: quick) and installed into a prefix, not the one it was
    configured for (``cmake --install --prefix``, as docs/firmware.md shows it: the package and
    linsense.pc must follow)."""
    tmp = tmp_path_factory.mktemp("cmake")
    prefix = tmp / "prefix"
    _run("cmake", "-S", CSRC, "-B", tmp / "lib", "-DCMAKE_BUILD_TYPE=Debug",
         f"-DCMAKE_INSTALL_PREFIX={tmp / 'configured'}", cwd=tmp)
    _run("cmake", "--build", tmp / "lib", "-j", "2", cwd=tmp)
    _run("cmake", "--install", tmp / "lib", "--prefix", prefix, cwd=tmp)
    assert not (tmp / "configured").exists()
    return prefix


def test_install_holds_the_library_its_public_headers_and_the_package_files(installed):
    files = {p.relative_to(installed).as_posix() for p in installed.rglob("*") if p.is_file()}
    libdir = next(p.split("/")[0] for p in files if p.endswith("liblinsense_ctrl.a"))
    public = {f"include/linsense/{p.name}" for p in (CSRC / "include" / "linsense").glob("*.h")}
    assert public <= files
    assert not [f for f in files if f.startswith("include/") and f not in public]  # (no internal header)
    for f in ("liblinsense_ctrl.a", "pkgconfig/linsense.pc", "cmake/linsense/linsense-config.cmake",
              "cmake/linsense/linsense-config-version.cmake", "cmake/linsense/linsense-targets.cmake"):
        assert f"{libdir}/{f}" in files, f
    version = (installed / libdir / "cmake/linsense/linsense-config-version.cmake").read_text()
    assert f'set(PACKAGE_VERSION "{linsense.__version__}")' in version
    targets = (installed / libdir / "cmake/linsense/linsense-targets.cmake").read_text()
    assert "linsense::ctrl" in targets and "-ffp-contract=off" in targets and "LS_REAL_DOUBLE" not in targets


def test_find_package_after_install(installed, tmp_path):
    wanted = linsense.__version__.rsplit(".", 1)[0]  # (major.minor: SameMinorVersion)
    app = _app(tmp_path / "app", f"find_package(linsense {wanted} REQUIRED)\n")
    _run("cmake", "-S", app, "-B", app / "b", f"-DCMAKE_PREFIX_PATH={installed}", cwd=tmp_path)
    _run("cmake", "--build", app / "b", cwd=tmp_path)
    out = _run(app / "b" / "app", cwd=tmp_path).stdout
    assert out == f"{_version_line()}real 4 init 0\nother version 3\n"


@pytest.mark.skipif(shutil.which("pkg-config") is None, reason="needs pkg-config")
def test_pkg_config_after_install(installed, tmp_path):
    """Without CMake: ``pkg-config --cflags --libs linsense`` builds the same program."""
    pc = next(installed.rglob("pkgconfig/linsense.pc"))
    env = {**os.environ, "PKG_CONFIG_PATH": str(pc.parent)}
    def query(*what: str) -> str:
        return subprocess.run(["pkg-config", *what, "linsense"], capture_output=True, text=True, env=env,
                              check=True).stdout.strip()

    flags = query("--cflags", "--libs")
    assert query("--modversion") == linsense.__version__
    assert "-ffp-contract=off" in flags and "-llinsense_ctrl" in flags, flags
    assert "LS_REAL_DOUBLE" not in flags, flags
    (tmp_path / "app.c").write_text(APP)
    _run("cc", "-std=c99", "app.c", "-o", "app", *flags.split(), cwd=tmp_path)
    assert _run(tmp_path / "app", cwd=tmp_path).stdout == f"{_version_line()}real 4 init 0\nother version 3\n"


def test_find_package_refuses_another_version(installed, tmp_path):
    major = int(linsense.__version__.split(".")[0])
    app = _app(tmp_path / "app", f"find_package(linsense {major + 1}.0 REQUIRED)\n")
    r = _run("cmake", "-S", app, "-B", app / "b", f"-DCMAKE_PREFIX_PATH={installed}", cwd=tmp_path, ok=False)
    assert r.returncode != 0 and "linsense" in r.stderr and linsense.__version__ in r.stderr


def test_add_subdirectory_with_the_double_option(tmp_path):
    """add_subdirectory: LINSENSE_DOUBLE=ON makes LS_REAL double in the library and in its user."""
    app = _app(tmp_path / "app", f"add_subdirectory({CSRC.as_posix()} linsense)\n")
    _run("cmake", "-S", app, "-B", app / "b", "-DCMAKE_BUILD_TYPE=Debug", "-DLINSENSE_DOUBLE=ON",
         cwd=tmp_path)
    _run("cmake", "--build", app / "b", "-j", "2", cwd=tmp_path)
    out = _run(app / "b" / "app", cwd=tmp_path).stdout
    assert out == f"{_version_line()}real 8 init 0\nother version 3\n"
    # as a subdirectory it installs nothing of its own unless asked (LINSENSE_INSTALL)
    assert "linsense-config.cmake" not in "".join(p.name for p in (app / "b").rglob("*.cmake"))


def test_ctest_registers_every_c_test_in_three_variants(tmp_path):
    gen = tmp_path / "gen"
    gen.mkdir()
    needed = sorted({m for p in (CSRC / "tests").glob("*.c")
                     for m in re.findall(r'#include "(ls_lut_ecce2010\w*\.h)"', p.read_text())})
    assert "ls_lut_ecce2010.h" in needed
    b = tmp_path / "b"
    r = _run("cmake", "-S", CSRC, "-B", b, "-DLINSENSE_BUILD_TESTS=ON", f"-DLINSENSE_GEN_DIR={gen}",
             cwd=tmp_path, ok=False)
    assert r.returncode != 0 and "LINSENSE_GEN_DIR" in r.stderr  # (the generated headers are missing)
    for name in needed:
        (gen / name).write_text("")
    _run("cmake", "-S", CSRC, "-B", b, "-DLINSENSE_BUILD_TESTS=ON", f"-DLINSENSE_GEN_DIR={gen}", cwd=tmp_path)
    listed = set(re.findall(r"Test +#\d+: (\S+)", _run("ctest", "-N", cwd=b).stdout))
    tests = sorted(p.stem for p in (CSRC / "tests").glob("*test_*.c") if re.match(r"i?test_", p.stem))
    assert len(tests) >= 14
    assert listed == {f"{v}/{t}" for v in ("float-san", "double-san", "float-plain") for t in tests}


def test_the_project_version_is_ls_types_h(tmp_path):
    """One source: CMake's project version is read from ls_types.h, which agrees with version.py."""
    b = tmp_path / "b"
    _run("cmake", "-S", CSRC, "-B", b, cwd=tmp_path)
    version = (b / "linsense-config-version.cmake").read_text()
    assert f'set(PACKAGE_VERSION "{linsense.__version__}")' in version
