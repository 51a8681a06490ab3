# linsense: two commands on a fresh machine
#   make demo   creates .venv, installs, runs the main job into out/
#   make test   creates or reuses .venv, runs every C and Python test
# Also: make bench (benchmarks), make lint, make clean.

PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed
CC     ?= cc
BUILD  := build

CSTD     := -std=c99 -Wall -Wextra -Wpedantic -Werror
CLIBWARN := -Wdouble-promotion -Wconversion -Wshadow
SAN      := -fsanitize=address,undefined -fno-sanitize-recover=all -fno-omit-frame-pointer
CINC     := -Icsrc/include -Icsrc/tests -I$(BUILD)/gen
CTRL_SRC := $(wildcard csrc/ctrl/*.c)
SIM_SRC  := $(wildcard csrc/sim/*.c)
CTESTS   := $(patsubst csrc/tests/%.c,%,$(wildcard csrc/tests/test_*.c))
# tests of the simulator's internal (static) functions: they include csrc/sim/ls_sim.c themselves
ITESTS   := $(patsubst csrc/tests/%.c,%,$(wildcard csrc/tests/itest_*.c))
GEN_HDR  := $(BUILD)/gen/ls_lut_ecce2010.h $(BUILD)/gen/ls_lut_ecce2010_r.h $(BUILD)/gen/ls_lut_ecce2010_q.h
# variant name : extra flags
VARIANTS := float-san double-san float-plain

.PHONY: all install demo test ctest mcu example pytest lint bench tools clean

all: test

# the install compiles the C library into the cffi extension: rebuild when any of it changes
$(STAMP): pyproject.toml setup.py src/linsense/_build_ctrl.py $(wildcard csrc/ctrl/*.c csrc/sim/*.c csrc/include/linsense/*.h)
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	LINSENSE_NATIVE=1 $(PY) -m pip install -q -e '.[dev]'
	touch $@

install: $(STAMP)

demo: $(STAMP)
	$(VENV)/bin/linsense reproduce --motor ecce2010 --out out
	@for f in examples/scenarios/*.toml; do \
	  n=$$(basename $$f .toml); $(VENV)/bin/linsense simulate $$f --out out/sim/$$n || exit 1; \
	done

test: lint ctest mcu example pytest

GEN_DEPS := $(STAMP) $(wildcard src/linsense/compensation/*.py src/linsense/model/*.py src/linsense/analysis/*.py)
$(BUILD)/gen/ls_lut_ecce2010.h: $(GEN_DEPS)
	$(VENV)/bin/linsense lut --motor ecce2010 --points 360 --format c --out $@
$(BUILD)/gen/ls_lut_ecce2010_r.h: $(GEN_DEPS)
	$(VENV)/bin/linsense lut --motor ecce2010 --points 360 --format c --f-inj 1000 --quad 0 --symbol ls_lut_ecce2010_r --out $@
$(BUILD)/gen/ls_lut_ecce2010_q.h: $(GEN_DEPS)
	$(VENV)/bin/linsense lut --motor ecce2010 --points 360 --format c --f-inj 1000 --quad 0.9 --symbol ls_lut_ecce2010_q --out $@

# Build and run every C test in three variants: float and double under ASan+UBSan, and float
# without sanitizers. Library sources get the stricter warnings (-Wdouble-promotion ...).
ctest: $(GEN_HDR)
	@set -e; for v in $(VARIANTS); do \
	  case $$v in \
	    float-san)   flags="$(SAN) -O1 -g" ;; \
	    double-san)  flags="$(SAN) -O1 -g -DLS_REAL_DOUBLE" ;; \
	    float-plain) flags="-O2" ;; \
	  esac; \
	  dir=$(BUILD)/ctest/$$v; mkdir -p $$dir; objs=""; \
	  for src in $(CTRL_SRC); do \
	    obj=$$dir/$$(basename $$src .c).o; \
	    $(CC) $(CSTD) $(CLIBWARN) $$flags $(CINC) -c $$src -o $$obj; objs="$$objs $$obj"; \
	  done; \
	  cobjs="$$objs"; \
	  for src in $(SIM_SRC); do \
	    obj=$$dir/$$(basename $$src .c).o; \
	    $(CC) $(CSTD) -Wshadow $$flags $(CINC) -c $$src -o $$obj; objs="$$objs $$obj"; \
	  done; \
	  for t in $(ITESTS); do \
	    $(CC) $(CSTD) -Wshadow $$flags $(CINC) csrc/tests/$$t.c $$cobjs -lm -o $$dir/$$t; \
	    out=$$($$dir/$$t) && rc=0 || rc=$$?; printf '%s\n' "$$out" | sed "s/^/[$$v] /"; \
	    [ $$rc -eq 0 ] || exit $$rc; \
	  done; \
	  for t in $(CTESTS); do \
	    $(CC) $(CSTD) $$flags $(CINC) csrc/tests/$$t.c $$objs -lm -o $$dir/$$t; \
	    out=$$($$dir/$$t) && rc=0 || rc=$$?; printf '%s\n' "$$out" | sed "s/^/[$$v] /"; \
	    [ $$rc -eq 0 ] || exit $$rc; \
	  done; \
	done

pytest: $(STAMP)
	$(PY) -m pytest -q

lint: $(STAMP)
	$(VENV)/bin/ruff check src tests

# The firmware example: generated LUT header + library + host main, a few thousand steps
EXAMPLE := $(BUILD)/example
example: $(STAMP)
	@mkdir -p $(EXAMPLE)
	$(VENV)/bin/linsense tune --motor ecce2010 --format c --out $(EXAMPLE)/ls_cfg_ecce2010.h
	$(CC) $(CSTD) -O2 -Icsrc/include -I$(EXAMPLE) examples/firmware/main.c $(CTRL_SRC) -lm -o $(EXAMPLE)/firmware_example
	$(EXAMPLE)/firmware_example

# Cortex-M4F cross build of the library: warning-free, float only, no libc beyond math/string
mcu: tools
	tools/check_mcu.sh build/arm

# System tools the C checks need (Debian packages), installed when missing and possible
tools:
	@missing=""; \
	command -v arm-none-eabi-gcc >/dev/null || missing="$$missing gcc-arm-none-eabi libnewlib-arm-none-eabi"; \
	command -v valgrind >/dev/null || missing="$$missing valgrind"; \
	if [ -n "$$missing" ]; then \
	  if [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null; then \
	    echo "installing:$$missing"; \
	    (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq $$missing >/dev/null); \
	  else \
	    echo "please install:$$missing" >&2; exit 1; \
	  fi; \
	fi

bench: $(GEN_HDR) tools
	tools/bench.sh
	$(PY) tools/bench_sim.py
	$(PY) tools/bench_closed_loop.py

clean:
	rm -rf $(BUILD) out
