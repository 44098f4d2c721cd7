# Two entry points: `make demo` (set up, then run the default demo) and `make test`
# (set up, then lint and run the test suite). Both create .venv on first use. `make docs`
# builds the documentation site into docs/_build/html, warnings counted as errors;
# `make docs-check` builds it afresh and checks every link inside it.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: demo test setup docs docs-check clean

# Bytecode compiled once, on all cores, at set-up (compileall): where the environment sets
# PYTHONDONTWRITEBYTECODE (CI machines do), Python never caches what it compiles, and every
# process (the test workers, the kernel compilation, a study's Dask workers, each command)
# would compile every module it imports again: grainlab's command line took 5.9 s to import
# without bytecode, 2.5 s with it.
BYTECODE := $(BIN)/python -m compileall -q -j 0 $(VENV)/lib src > /dev/null

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --no-compile -e ".[test]"
	$(BYTECODE)
	touch $(STAMP)

setup: $(STAMP)

demo: $(STAMP)
	$(BIN)/grainlab demo --out grainlab-demo

test: $(STAMP)
	$(BIN)/ruff check src tests benchmarks examples
	$(BIN)/python -m pytest -n auto --maxprocesses 4 --durations=15

DOCS_STAMP := $(VENV)/.docs-installed

$(DOCS_STAMP): $(STAMP)
	$(BIN)/python -m pip install --quiet --no-compile -e ".[docs]"
	$(BYTECODE)
	touch $(DOCS_STAMP)

docs: $(DOCS_STAMP)
	$(BIN)/sphinx-build -W --keep-going -b html docs docs/_build/html

# The documentation check: a fresh build (every tutorial and how-to executed), warnings as
# errors (broken references, pages outside the toctree, failing cells), then every link
# inside the built site followed to its file and anchor (offline).
docs-check: $(DOCS_STAMP)
	rm -rf docs/_build/html docs/_build/.jupyter_cache docs/reference/generated
	$(BIN)/sphinx-build -W --keep-going -b html docs docs/_build/html
	$(BIN)/python docs/_check_links.py docs/_build/html

clean:
	rm -rf $(VENV) grainlab-demo .pytest_cache docs/_build docs/reference/generated
