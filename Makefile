# The two commands a newcomer needs: `make demo` and `make test`.
# Each sets up its own virtual environment in .venv (rebuilt when pyproject.toml changes).
PYTHON ?= python3
VENV ?= .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed

.PHONY: demo test venv browser node constraints clean

# constraints.txt pins every package (the tested set); pyproject.toml only declares ranges.
$(STAMP): pyproject.toml constraints.txt
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -c constraints.txt -e '.[test]'
	$(PY) -m pip check
	touch $(STAMP)

venv: $(STAMP)

demo: $(STAMP)
	$(PY) tools/demo_bench.py --out demo-report

# Two workers (pytest-xdist): the suite is written to pass on a busy 2-core machine, and takes
# about half the time (687-815 s here on 2026-12-02, see docs/benchmarks.md); `$(PY) -m pytest FILE`
# still runs in one process. Each module runs whole on one worker (loadscope): a module's tests
# may share its fixtures' state in file order (the browser tests' run; `--dist loadgroup` no
# longer groups under pytest 9.2, pytest-xdist issue 1386).
test: $(STAMP)
	OPENBLAS_NUM_THREADS=1 $(PY) -m pytest -n 2 --dist loadscope

# Headless Chromium + chromedriver for the bench page's browser tests (Debian packages).
# Best effort: without root or apt the browser tests skip and say why.
browser:
	@if [ -x /usr/bin/chromium ] && [ -x /usr/bin/chromedriver ]; then echo "chromium and chromedriver present"; \
	elif command -v apt-get >/dev/null && [ "$$(id -u)" = 0 ]; then \
		apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium chromium-driver >/dev/null \
		|| echo "could not install chromium: browser tests will skip"; \
	else echo "no root/apt-get: install chromium and chromium-driver yourself, or browser tests will skip"; fi

# The independent MCAP reader for tests/daq/test_run_file_viewer.py (TypeScript @mcap/core and
# fzstd, versions locked by tests/node/package-lock.json). Best effort: without node/npm those
# tests skip and say why.
node:
	@if command -v npm >/dev/null; then npm ci --prefix tests/node --no-audit --no-fund --loglevel=error \
		|| echo "npm ci failed: the independent-reader tests will skip"; \
	else echo "no npm: install nodejs and npm, or the independent-reader tests will skip"; fi

# Re-pin constraints.txt from the current .venv (after changing a range in pyproject.toml).
constraints: $(STAMP)
	{ sed -n '1,2p' constraints.txt; $(PY) -m pip freeze --exclude-editable | grep -v '^cartlab'; } > constraints.txt.new
	mv constraints.txt.new constraints.txt

clean:
	rm -rf $(VENV) demo-report demo-report.old .pytest_cache .mypy_cache
