# One-stop set-up on a fresh Debian machine: virtual environment, POV-Ray (apt, when root),
# the package with its C++ extension, then the job. `make test` and `make demo` are the two
# commands README.md promises.
PYTHON   ?= python3
VENV     ?= .venv
PY       := $(VENV)/bin/python
PIP      := $(PY) -m pip --disable-pip-version-check -q
BUILDDEPS := $(VENV)/.builddeps

.PHONY: test test-fast demo docs lint format install povray chromium opensubdiv venv clean

venv: $(PY)
$(PY):
	$(PYTHON) -m venv $(VENV)

# Build requirements go into the venv once, so the editable build can run without isolation
# (faster rebuilds, and CMake reuses build/ between runs).
$(BUILDDEPS): pyproject.toml | $(PY)
	$(PIP) install "scikit-build-core>=0.10" "nanobind>=2.0" "pytest>=8"
	touch $@

# Always re-run: scikit-build-core's incremental CMake build makes this a few seconds when
# nothing changed, and it is what picks up C++ edits.
# The bench extra (matplotlib) too, so the benchmark scripts the docs name run in this venv, and
# the docs extra (MkDocs) for `make docs`.
install: $(BUILDDEPS) opensubdiv
	$(PIP) install --no-build-isolation -e '.[test,bench,docs,lint]'

# The extension links OpenSubdiv (subdivision surfaces): the Debian package libosd-dev.
opensubdiv:
	@if [ -f /usr/include/opensubdiv/far/topologyRefiner.h ]; then :; \
	elif [ "$$(id -u)" = 0 ]; then \
	  echo "OpenSubdiv missing: installing the Debian package 'libosd-dev'"; \
	  apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq libosd-dev; \
	else \
	  echo "OpenSubdiv missing and not root: run 'sudo apt-get install libosd-dev' (the build needs it)"; exit 1; \
	fi

povray:
	@if command -v povray >/dev/null 2>&1; then :; \
	elif [ "$$(id -u)" = 0 ]; then \
	  echo "POV-Ray missing: installing the Debian package 'povray'"; \
	  apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq povray; \
	else \
	  echo "POV-Ray missing and not root: run 'sudo apt-get install povray' (POV-Ray tests will skip)"; \
	fi

# Headless Chromium takes the report's screenshot in the test suite (apt-get install: ~100 s,
# measured); without it that test skips.
chromium:
	@if command -v chromium >/dev/null 2>&1; then :; \
	elif [ "$$(id -u)" = 0 ]; then \
	  echo "Chromium missing: installing the Debian package 'chromium' (for the report screenshot test)"; \
	  apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium; \
	else \
	  echo "Chromium missing and not root: run 'sudo apt-get install chromium' (the report screenshot test will skip)"; \
	fi

# Style, checked by `make test` (CI fails on a violation); `make format` applies it. The tools
# are pinned in the lint extra, so the same code gives the same verdict on every machine.
CXX_SOURCES = $(wildcard backends/native/src/*.cpp backends/native/src/*.hpp) phongscene/cli/launcher.c

lint: install
	$(VENV)/bin/ruff check .
	$(VENV)/bin/ruff format --check .
	$(VENV)/bin/clang-format --dry-run -Werror $(CXX_SOURCES)

format: install
	$(VENV)/bin/ruff check --fix .
	$(VENV)/bin/ruff format .
	$(VENV)/bin/clang-format -i $(CXX_SOURCES)

# The documentation site, warnings as errors (a broken link fails), into out/site (seconds).
docs: install
	NO_MKDOCS_2_WARNING=1 $(PY) -m mkdocs build --strict --quiet

test: install povray chromium lint docs
	$(PY) -m pytest

# The quick loop while editing: every test but the heavy ones (markers in pyproject.toml: slow,
# dask, subprocess), in under a minute on 2 cores. No Chromium: its screenshot tests are slow.
# Two pytest-xdist workers: many of these tests wait on a POV-Ray or sandbox child, and a second
# worker fills those waits (measured 71 s serial -> 53 s with -n 2). `make test` stays serial: its
# signal and subprocess tests time their children and would race each other for the cores.
FAST := not slow and not dask and not subprocess
test-fast: install povray lint
	$(PY) -m pytest -n 2 -m "$(FAST)"

demo: install povray
	$(PY) examples/demo.py

clean:
	rm -rf build $(VENV) out
