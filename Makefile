# Quick start: `make demo` and `make test` work on a fresh machine (they create .venv).
# They install the project the way a user does (`pip install -e .`), which also compiles the
# simulator step (aquafish_gym/native) with the system C++ compiler, with no download.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed
DOCS_STAMP := $(VENV)/.installed-docs
NATIVE_SOURCES := setup.py aquafish_gym/native/aquafish_step.cpp aquafish_gym/native/pybullet_abi.h \
                  aquafish_gym/native/build.py

.PHONY: demo test test-all bench docs install native doctor clean

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip

# Re-run when the C++ changes too: the editable install rebuilds the step in place.
$(STAMP): $(BIN)/python pyproject.toml $(NATIVE_SOURCES)
	$(BIN)/python -m pip install --quiet "torch==2.13.0"
	$(BIN)/python -m pip install --quiet -e ".[test,rl,cluster,video]"
	touch $(STAMP)

install: $(STAMP)

native: $(STAMP)

doctor: $(STAMP)
	$(BIN)/aquafish doctor

demo: $(STAMP)
	$(BIN)/aquafish case-study --budget quick --damage reversed_left_pectoral --seed 0 --out demo_out

test: $(STAMP)
	AQUAFISH_REQUIRE_NATIVE=1 $(BIN)/python -m pytest -n 2 -q

test-all: $(STAMP)
	AQUAFISH_REQUIRE_NATIVE=1 $(BIN)/python -m pytest -n 2 -q -m ""

bench: $(STAMP)
	$(BIN)/python -m aquafish.benchmarks.sim_throughput

# The API reference reads the source without importing it, so only the [docs] extra's own
# requirements are installed (read from pyproject.toml), not the project and its dependencies.
$(DOCS_STAMP): $(BIN)/python pyproject.toml
	$(BIN)/python -c 'import tomllib; print("\n".join(tomllib.load(open("pyproject.toml", "rb"))["project"]["optional-dependencies"]["docs"]))' > $(VENV)/docs-requirements.txt
	$(BIN)/python -m pip install --quiet -r $(VENV)/docs-requirements.txt
	touch $(DOCS_STAMP)

# The site from docs/ and the docstrings (mkdocs.yml) into site/; --strict: a broken link fails.
docs: $(DOCS_STAMP)
	$(BIN)/mkdocs build --strict --site-dir site

clean:
	rm -rf $(VENV) build site demo_out .pytest_cache aquafish_gym/native/_aquafish_step.so aquafish_gym/native/include
