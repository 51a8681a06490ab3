#!/usr/bin/env bash
# make wheeltest: the wheel and the sdist of `make dist` (dist/) checked as a user gets them.
#
# 1. The wheel's file list (tests/test_dist.py, run with the build venv's pytest): the abi3 manylinux
#    tag, the extension, no build script, test or C source.
# 2. A fresh venv with NO C compiler reachable: PATH holds only the venv's bin (no cc, gcc, clang,
#    c99, ld), CC/CXX are /bin/false, pip takes binaries only (--only-binary :all:), so nothing can be
#    compiled; proven before installing (which/sysconfig's CC not found). The wheel and its
#    dependencies (from PyPI through pip's cache) are installed there, then
#    `linsense reproduce --quick`, `linsense model --motor small30` and `linsense simulate step3_lut`
#    (packaged examples, by name) are run.
# 3. The sdist's own tests: the sdist is unpacked and a subset of its tests/ is run from there in that
#    venv against the installed wheel (which `python -m build` compiled from this very sdist), see
#    SDIST_TESTS below.
set -euo pipefail
cd "$(dirname "$0")/.."
PYTHON=${PYTHON:-python3}
WORK=build/wheeltest
shopt -s nullglob
wheels=(dist/*-cp311-abi3-manylinux*.whl)
sdists=(dist/*.tar.gz)
[ ${#wheels[@]} -eq 1 ] && [ ${#sdists[@]} -eq 1 ] || { echo "wheeltest: expected one abi3 manylinux wheel and one sdist in dist/ (make dist)" >&2; exit 1; }
whl=$(realpath "${wheels[0]}"); sdist=$(realpath "${sdists[0]}")

# 1. what the wheel holds
LINSENSE_DIST_REQUIRED=1 .venv/bin/python -m pytest -q -p no:cacheprovider tests/test_dist.py

rm -rf "$WORK"; mkdir -p "$WORK"; WORK=$(realpath "$WORK")
$PYTHON -m venv "$WORK/venv"
V="$WORK/venv/bin"
# the only PATH of everything below: the venv's own bin
run() { env -i HOME="$HOME" PATH="$V" CC=/bin/false CXX=/bin/false LC_ALL=C.UTF-8 \
  PIP_CACHE_DIR="${PIP_CACHE_DIR:-$HOME/.cache/pip}" PIP_DISABLE_PIP_VERSION_CHECK=1 PYTHONWARNINGS=ignore \
  MPLBACKEND=Agg "$@"; }

# 2. no compiler reachable, then the install as a user does it
run "$V/python" - <<'EOF'
import shutil, sys, sysconfig
found = {c: shutil.which(c) for c in ("cc", "gcc", "clang", "c99", "c89", "tcc", "icx", "ld", "as")}
cc = (sysconfig.get_config_var("CC") or "cc").split()[0]
found[f"sysconfig CC ({cc})"] = shutil.which(cc)
reachable = {k: v for k, v in found.items() if v}
if reachable:
    sys.exit(f"wheeltest: a compiler is reachable: {reachable}")
print("wheeltest: no C compiler on PATH (" + ", ".join(found) + ": none found)")
EOF
t0=$(date +%s)
# WHEEL_EXTRAS: the extras installed with it (reproduce needs the sweep and report ones)
run "$V/python" -m pip install -q --no-compile --only-binary :all: "$whl[${WHEEL_EXTRAS:-all}]" "pytest>=8" "hypothesis>=6.90"
echo "wheeltest: installed $(basename "$whl") and its dependencies in $(( $(date +%s) - t0 )) s"
run "$V/python" -c "import linsense, linsense._ctrl as c, sys; assert '$WORK/venv' in linsense.__file__, linsense.__file__; print('wheeltest: linsense', linsense.__version__, 'from', c.__file__)"

cd "$WORK"
run "$V/linsense" reproduce --quick --out "$WORK/reproduce" > reproduce.log 2>&1 || { cat reproduce.log; exit 1; }
grep -E "^ecce2010: .* claims" reproduce.log
test -s "$WORK/reproduce/metrics.json" && test -s "$WORK/reproduce/report.html"
# packaged examples by name (linsense/examples), as the README's commands use them
run "$V/linsense" model --motor small30 --out "$WORK/model_small30.csv" > model.log 2>&1 || { cat model.log; exit 1; }
run "$V/linsense" simulate step3_lut --out "$WORK/simulate" --plot > simulate.log 2>&1 || { cat simulate.log; exit 1; }
tail -1 simulate.log
test -s "$WORK/simulate/metrics.json" && test -s "$WORK/simulate/sim.png"

# 3. the sdist's tests against the installed wheel. SDIST_TESTS: the C binding (test_ctrl_binding:
#    the extension's declarations, struct layouts, calls), every CLI command on the packaged presets
#    and scenarios (test_cli), the output files and their portable lock with real processes
#    (test_io, test_io_lock), the version, and `linsense firmware export` from the C library the wheel
#    ships (test_firmware_export; its builds skip there: no compiler): what a packaging mistake breaks (a missing module,
#    preset, template or dependency, an extension built wrong), in ~10 s of CPU. Not the rest: the
#    numerics are the same code as in `make pytest` (test_kills alone is 13 s of CPU), and the tests
#    of the build (test_binding_build, test_layers, test_dist) need a compiler, the dev tools or git.
mkdir -p sdist && tar -xzf "$sdist" -C sdist
cd sdist/*/
SDIST_TESTS="tests/test_io.py tests/test_io_lock.py tests/test_ctrl_binding.py tests/test_cli.py tests/test_version.py
  tests/test_firmware_export.py"
run "$V/python" -m pytest -q -p no:cacheprovider -m "not slow" $SDIST_TESTS
echo "wheeltest: OK"
