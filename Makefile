# Two commands for a fresh machine with Python >= 3.11 and make:
#   make demo   builds .venv, installs, reproduces the paper's cases into out/
#   make test   builds .venv, installs with test extras, runs the linters and the tests
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
PIP    := $(BIN)/python -m pip --disable-pip-version-check -q

.PHONY: demo test lint install install-test bench clean

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)

$(VENV)/.installed: $(BIN)/python pyproject.toml setup.py constraints.txt src/microimpact/engine/_ckernel.c
	$(PIP) install -c constraints.txt -e .
	@touch $@

$(VENV)/.installed-test: $(VENV)/.installed
	$(PIP) install -c constraints.txt -e ".[test]"
	@touch $@

install: $(VENV)/.installed
install-test: $(VENV)/.installed-test

demo: $(VENV)/.installed
	$(BIN)/microimpact reproduce --out out

lint: $(VENV)/.installed-test
	$(BIN)/ruff check setup.py src tests benchmarks docs/figures docs/examples docs/make_api.py
	$(BIN)/ruff format --check setup.py src tests benchmarks docs/figures docs/examples docs/make_api.py

test: lint
	$(BIN)/python -m pytest -n 2 -q

bench: $(VENV)/.installed-test
	$(BIN)/python benchmarks/run.py

clean:
	rm -rf $(VENV) out build *.egg-info src/*.egg-info src/microimpact/engine/*.so
	find src tests benchmarks -name __pycache__ -prune -exec rm -rf {} +
