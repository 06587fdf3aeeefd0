# The two commands a newcomer needs: `make demo` and `make test`.
# Each sets up its own virtual environment in .venv (rebuilt when pyproject.toml changes).
PYTHON ?= python3
VENV ?= .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed

.PHONY: demo test venv clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[test]'
	touch $(STAMP)

venv: $(STAMP)

demo: $(STAMP)
	$(PY) tools/demo_bench.py --out demo-report

test: $(STAMP)
	$(PY) -m pytest

clean:
	rm -rf $(VENV) demo-report .pytest_cache .mypy_cache
