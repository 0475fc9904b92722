# Reproducible research compendium for optimal control.
#   make reproduce   set up, execute every notebook headless, regenerate figures/ data/derived/ and the HTML report
#   make test        set up, lint, run the unit tests and nbval over the notebooks, compare their outputs with the
#                    published record (figures/, data/derived/), and build the documentation site (make docs)
#   make check       the library's own tests, the fast tier (no Lab, browser, kernel, Sphinx or venv): a change's loop
#   make lab         JupyterLab on the repository, on the compendium's kernel (as root too)
#   make docs        the documentation site (build/docs/index.html)
#   make bench       timing benchmarks (tables in build/bench/)
#   make store       re-execute the notebooks in place (refresh the outputs nbval compares against)
#   make dist        the library's sdist and wheel (dist/), their metadata checked

PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
KERNEL := ocpkit
STAMP  := $(VENV)/.installed
NOTEBOOKS := $(sort $(wildcard notebooks/*.ipynb))

# One BLAS thread: the NLPs here are small and sparse, and idle BLAS threads only steal the second core. The runner
# sets the same for every kernel it starts (compendium.provenance.ONE_THREAD), the ocpkit kernel is registered with
# them (bootstrap.py's KERNEL_ENV), and only a run with them publishes.
export OPENBLAS_NUM_THREADS := 1
export OMP_NUM_THREADS := 1

# make check, make unit and make nbval run over JOBS processes (pytest-xdist; auto: one per core), each test module
# and each notebook whole in one of them (its module fixtures and its kernel started once); make reproduce and make
# notebooks run JOBS notebooks at once, the longest first. JOBS=0 runs them in this process, one after another
JOBS ?= auto
XDIST := -n $(JOBS) --dist loadfile

.PHONY: setup reproduce notebooks report test check lint unit nbval guard docs lab bench store dist clean

# -- setup ---------------------------------------------------------------------------------------------------------
# environment.txt is resolved for Python 3.11. PYTHON_MIN is the oldest 3.11 it is installed and tested on: Debian
# 12's python3 (soupsieve is pinned below 3.0 for it, 3.0.2 and later need 3.11.5); tests/test_setup.py checks that
# every pin admits it.
PYTHON_MIN := 3.11.2

# Run by $(PYTHON) before anything is created: a Python 3.11, PYTHON_MIN or later, that can make a virtual
# environment with pip in it (Debian and Ubuntu ship venv's ensurepip apart from python3). Plain enough for any
# Python, 2 included, to print this message rather than a syntax error.
define CHECK_PYTHON
import sys
found = "%d.%d.%d" % tuple(sys.version_info[:3])
need = tuple(int(part) for part in "$(PYTHON_MIN)".split("."))
series = "%d.%d" % need[:2]
it = "PYTHON=%s is Python %s (%s)" % (sys.argv[1], found, sys.executable)
if not need <= tuple(sys.version_info[:3]) < (need[0], need[1] + 1):
    sys.stderr.write("setup: %s, but the compendium needs Python %s (%s or a later %s release).\n"
                     "Name one with PYTHON=, e.g. make setup PYTHON=python%s (or PYTHON=/path/to/python%s)\n"
                     % (it, series, "$(PYTHON_MIN)", series, series, series))
    sys.exit(3)
try:
    import ensurepip, venv
    ensurepip.version()
except Exception as exc:
    sys.stderr.write("setup: %s, but it cannot create a virtual environment with pip in it (%s: %s).\n"
                     "On Debian or Ubuntu install the package python3-venv (apt-get install python3-venv; it is "
                     "python%s-venv for this python%s), or name another Python with PYTHON=\n"
                     % (it, type(exc).__name__, exc, series, series))
    sys.exit(3)
print("  %s: ok" % it)
endef

setup: $(STAMP)

# The interpreter is checked first (CHECK_PYTHON), before anything is created. Then src/compendium/bootstrap.py, run
# by it, makes .venv, all of it or nothing half-made (its docstring says how): a .venv of an earlier setup is rebuilt
# from scratch when environment.txt or pyproject.toml changed, and comes back from .venv.previous if the rebuild
# fails or is interrupted; uv, which installs the pins, shows what it resolves and downloads, then a summary. The
# script writes the stamp, last: .PRECIOUS keeps make from deleting it on Ctrl-C (the script alone says which .venv
# is whole).
.PRECIOUS: $(STAMP)
$(STAMP): export SETUP_CHECK_PYTHON = $(CHECK_PYTHON)
$(STAMP): environment.txt pyproject.toml
	@echo "setup [1/5] checking the interpreter PYTHON=$(PYTHON)"
	@[ -n "$(strip $(PYTHON))" ] && command -v $(firstword $(PYTHON)) >/dev/null 2>&1 || { \
	  echo "setup: PYTHON=$(PYTHON) is neither a command on PATH nor an executable file. Install Python 3.11" \
	       "($(PYTHON_MIN) or later) and name it, e.g. make setup PYTHON=python3.11 (or PYTHON=/path/to/python3.11)" >&2; \
	  exit 1; }
	@$(PYTHON) -c "$$SETUP_CHECK_PYTHON" "$(PYTHON)" || { status=$$?; [ $$status = 3 ] || \
	  echo "setup: PYTHON=$(PYTHON) could not run the interpreter check (exit status $$status): is it a Python?" >&2; \
	  exit 1; }
	@exec $(PYTHON) -P src/compendium/bootstrap.py --venv $(VENV) --stamp $@ --requirements environment.txt \
	  --kernel $(KERNEL) --display-name "Python (ocpkit)" --root "$(CURDIR)" --changed "$?"

# the published runs and their report, then whether they reproduce the committed record by its contract
# (notebooks/contract.toml). A notebook that fails publishes nothing and stops nothing: the others run, the report
# is built with the failure on its page, and then make reproduce fails, naming it, without the comparison.
reproduce: setup mathjax
	$(PY) -m compendium.notebooks reproduce $(NOTEBOOKS) --output build/notebooks --report build/report --kernel $(KERNEL) \
		--jobs $(JOBS)
	@if git rev-parse --verify -q HEAD >/dev/null 2>&1; then \
		$(PY) -m compendium.guard . --reference-commit HEAD || { \
		echo "make reproduce: the regenerated record (figures/, data/derived/) differs from the committed one beyond"; \
		echo "its contract (above). If the change is intended, review it with git diff and commit it."; exit 1; }; \
	else echo "make reproduce: not a git checkout, so nothing to compare the regenerated record with"; fi

# the published runs: each notebook with the parameters notebooks/published.toml gives it (the orbit transfer's
# full run; the others' defaults), each run copied into figures/ and data/derived/ when it completes; the executed
# notebooks replace those of an earlier run in build/notebooks
notebooks: setup
	$(PY) -m compendium.notebooks reproduce $(NOTEBOOKS) --output build/notebooks --kernel $(KERNEL) --jobs $(JOBS)

# the notebooks make notebooks or make reproduce executed into build/notebooks, as an HTML report
# (src/compendium/report.py; it runs none), readable offline: equations in MathJax's TeX fonts (make mathjax), figures
# inline, no request leaves the machine
report: setup mathjax
	$(PY) -m compendium.notebooks report build/notebooks --output build/report

test: lint dist unit nbval guard docs

# the documentation site (docs/, Sphinx with myst-nb; the notebooks from their stored outputs, never executed here)
# into build/docs/index.html; every warning is an error, and -n (nitpicky) makes every cross-reference one that must
# resolve: a broken link or reference, a docstring that does not parse
docs: setup mathjax
	rm -rf build/docs
	$(PY) -m sphinx -n -W --keep-going -q -b html docs build/docs
	@echo "the documentation site: build/docs/index.html"

lint: setup
	$(VENV)/bin/ruff check .
	$(VENV)/bin/ruff format --check .
	$(PY) -m mypy  # src/ocpkit, configured in pyproject.toml

# Headless Chromium for the browser tests of tests/test_lab.py: nothing to do when one is installed (the names the
# tests look for), else Debian's chromium and chromium-driver (/usr/bin/chromium) from apt-get, as root or via sudo.
# Under `make unit` a missing Chromium fails those tests rather than skipping them unseen (OCPKIT_REQUIRE_BROWSER);
# OCPKIT_REQUIRE_BROWSER=0 (e.g. `make test OCPKIT_REQUIRE_BROWSER=0`) installs nothing and lets them skip.
CHROMIUM_BIN := /usr/bin/chromium
.PHONY: chromium
chromium:
	@set -e; \
	if [ -x $(CHROMIUM_BIN) ] || command -v chromium >/dev/null 2>&1 || command -v chromium-browser >/dev/null 2>&1; \
	then :; \
	elif [ "$(OCPKIT_REQUIRE_BROWSER)" = 0 ]; then \
	  echo "chromium: none installed, and OCPKIT_REQUIRE_BROWSER=0: the browser tests of tests/test_lab.py will skip"; \
	else \
	  how="install one (Debian: apt-get install chromium chromium-driver), or let those tests skip:"; \
	  how="$$how make test OCPKIT_REQUIRE_BROWSER=0"; \
	  if ! command -v apt-get >/dev/null 2>&1; then \
	    echo "chromium: the browser tests need Chromium ($(CHROMIUM_BIN), or chromium or chromium-browser on PATH)," \
	         "and there is no apt-get here to install it: $$how" >&2; exit 1; \
	  elif [ "$$(id -u)" = 0 ]; then as=; \
	  elif command -v sudo >/dev/null 2>&1; then as=sudo; \
	  else echo "chromium: the browser tests need Chromium; apt-get can install it as root only, this is user" \
	            "$$(id -un) and there is no sudo: $$how" >&2; exit 1; \
	  fi; \
	  echo "chromium: none installed: apt-get installs Debian's chromium and chromium-driver$${as:+ (with sudo)}"; \
	  $$as apt-get update -q; \
	  $$as env DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends chromium chromium-driver; \
	  test -x $(CHROMIUM_BIN) || { echo "chromium: apt-get finished, but there is no $(CHROMIUM_BIN)" >&2; exit 1; }; \
	fi

# MathJax 2 and its TeX web fonts for the report's equations offline (src/compendium/mathjax.py): nothing to do when
# they are installed where python -m compendium.mathjax looks (its TEX_FONT_ROOTS: Debian's, Fedora's, Arch's), else
# Debian's libjs-mathjax and fonts-mathjax from apt-get, as root or via sudo. Where neither works this says so and
# goes on: the report then takes jupyter-server-mathjax's STIX-Web fonts (and says so too), and under `make unit` the
# report's font test fails (OCPKIT_REQUIRE_BROWSER, as for Chromium above).
.PHONY: mathjax
mathjax: setup
	@set -e; \
	err=$$(mktemp); found=0; $(PY) -m compendium.mathjax >/dev/null 2>$$err || found=$$?; \
	if [ $$found != 0 ] && [ $$found != 3 ]; then cat $$err >&2; rm -f $$err; \
	  echo "mathjax: python -m compendium.mathjax failed (exit status $$found), above" >&2; exit 1; fi; \
	rm -f $$err; \
	if [ $$found = 0 ]; then :; \
	else \
	  how="the report's equations fall back to jupyter-server-mathjax's STIX-Web fonts (Debian: apt-get install"; \
	  how="$$how libjs-mathjax fonts-mathjax)"; \
	  if ! command -v apt-get >/dev/null 2>&1; then \
	    echo "mathjax: no MathJax with TeX fonts, and no apt-get here to install it: $$how"; exit 0; \
	  elif [ "$$(id -u)" = 0 ]; then as=; \
	  elif command -v sudo >/dev/null 2>&1; then as=sudo; \
	  else echo "mathjax: no MathJax with TeX fonts; apt-get can install it as root only, this is" \
	            "user $$(id -un) and there is no sudo: $$how"; exit 0; \
	  fi; \
	  echo "mathjax: none installed: apt-get installs Debian's libjs-mathjax and fonts-mathjax$${as:+ (with sudo)}"; \
	  { $$as apt-get update -q && \
	    $$as env DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends libjs-mathjax fonts-mathjax; } \
	    || { echo "mathjax: apt-get could not install them: $$how"; exit 0; }; \
	  $(PY) -m compendium.mathjax >/dev/null || { echo "mathjax: apt-get finished, but still: $$how"; exit 0; }; \
	fi

# tests/test_lab.py's browser tests fail rather than skip without Chromium (see chromium above); tests/test_report.py
# builds the report of the stored notebooks (nbval keeps no executed notebooks to build it from) and opens it there
# the fast tier of the tests (tests/conftest.py): the library's own tests, and the compendium's modules called as
# functions, but those marked slow (several seconds each); the integration tier (Lab, Chromium, notebook kernels,
# Sphinx, pip) and the slow tests run under make unit
check: setup
	$(PY) -m pytest tests/ -m "not integration and not slow" -q -p no:cacheprovider $(XDIST)

# the site's browser tests (tests/test_site.py) read the site make docs builds first (OCPKIT_SITE): make test builds
# it once
unit: export OCPKIT_REQUIRE_BROWSER ?= 1
unit: export OCPKIT_SITE = $(CURDIR)/build/docs
unit: setup chromium mathjax docs
	$(PY) -m pytest tests/ $(XDIST)

# nbval writes figures and tables under build/test-output, never over the tracked ones
nbval: setup
	rm -rf build/test-output
	OCPKIT_OUTPUT_DIR=$(CURDIR)/build/test-output OCPKIT_PROGRESS=off $(PY) -m pytest --nbval-lax --nbval-kernel-name $(KERNEL) \
		--nbval-sanitize-with notebooks/nbval_sanitize.cfg -p no:cacheprovider $(XDIST) $(NOTEBOOKS)

# what nbval's runs wrote, against the committed figures/ and data/derived/
guard: nbval
	$(PY) -m compendium.guard build/test-output

lab: setup
	$(PY) -m compendium.lab

bench: setup
	$(PY) benchmarks/bench_hlgl.py
	$(PY) benchmarks/bench_scale.py
	$(PY) benchmarks/bench_evaluations.py
	$(PY) benchmarks/bench_multirate.py
	$(PY) benchmarks/bench_fast_slow.py
	$(PY) benchmarks/bench_radau.py
	$(PY) benchmarks/bench_orderings.py
	$(PY) benchmarks/bench_delta3.py
	$(PY) benchmarks/bench_fatrop.py
	$(PY) benchmarks/bench_shooting.py
	$(PY) benchmarks/bench_orbit_transfer.py
	$(PY) benchmarks/bench_constraints.py
	$(PY) benchmarks/bench_refinement.py
	$(PY) benchmarks/bench_moving_knot.py
	$(PY) benchmarks/bench_moving_knot.py --scheme radau
	$(PY) benchmarks/bench_process.py
	$(PY) benchmarks/bench_many_solves.py
	$(PY) benchmarks/bench_sweep.py
	$(PY) benchmarks/bench_quasi_newton.py
	$(PY) benchmarks/bench_explorer.py

# stored outputs use the default parameters; where those are a notebook's published ones the run is also copied into
# the published record (identical when nothing changed: review `git status`); every run's own folder is build/runs/
store: setup
	$(PY) -m compendium.notebooks store $(NOTEBOOKS) --kernel $(KERNEL)

# the library alone (pyproject.toml; MANIFEST.in keeps the compendium out of the sdist): its sdist, then its wheel
# built from that sdist, so a missing file fails here; twine checks their metadata and that the description renders.
# Without build isolation: the build backend is the one pinned in environment.txt, and nothing is downloaded.
dist: setup
	rm -rf dist
	$(PY) -m build --quiet --no-isolation --outdir dist .
	$(PY) -m twine check --strict dist/*

clean:
	rm -rf build dist
