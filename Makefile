# Quick start: `make demo` and `make test` work on a fresh machine (they create .venv).
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed
NATIVE := aquafish_gym/native/_aquafish_step.so

.PHONY: demo test test-all bench install native clean

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip

$(STAMP): $(BIN)/python pyproject.toml
	$(BIN)/python -m pip install --quiet "torch==2.13.0"
	$(BIN)/python -m pip install --quiet -e ".[test,rl,cluster]"
	touch $(STAMP)

# The compiled simulator step (aquafish_gym/native): needs a C++ compiler and, once, the
# PyBullet source distribution's headers from the package index.
$(NATIVE): $(STAMP) aquafish_gym/native/aquafish_step.cpp aquafish_gym/native/build.py
	$(BIN)/python -m aquafish_gym.native.build --force

install: $(STAMP) $(NATIVE)

native: $(NATIVE)

demo: $(STAMP) $(NATIVE)
	$(BIN)/aquafish case-study --preset quick --out demo_out

test: $(STAMP) $(NATIVE)
	AQUAFISH_REQUIRE_NATIVE=1 $(BIN)/python -m pytest -n 2 -q

test-all: $(STAMP) $(NATIVE)
	AQUAFISH_REQUIRE_NATIVE=1 $(BIN)/python -m pytest -n 2 -q -m ""

bench: $(STAMP) $(NATIVE)
	$(BIN)/python -m benchmarks.sim_throughput

clean:
	rm -rf $(VENV) demo_out .pytest_cache aquafish_gym/native/_aquafish_step.so aquafish_gym/native/include
