# Reproducible research compendium for optimal control.
#   make reproduce   set up, execute every notebook headless, regenerate figures/ data/derived/ and the HTML report
#   make test        set up, lint, run the unit tests and nbval over the notebooks, compare their outputs with the
#                    published record (figures/, data/derived/)
#   make lab         JupyterLab on the repository, on the compendium's kernel (as root too)
#   make bench       timing benchmarks (tables in build/bench/)
#   make store       re-execute the notebooks in place (refresh the outputs nbval compares against)

PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
KERNEL := ocpkit
STAMP  := $(VENV)/.installed
NOTEBOOKS := $(sort $(wildcard notebooks/*.ipynb))

# One BLAS thread: the NLPs here are small and sparse, and idle BLAS threads only steal the second core.
export OPENBLAS_NUM_THREADS := 1
export OMP_NUM_THREADS := 1

.PHONY: setup reproduce notebooks report test lint unit nbval guard lab bench store clean

setup: $(STAMP)

$(STAMP): environment.txt pyproject.toml
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --disable-pip-version-check -q -r environment.txt
	$(PY) -m pip install --disable-pip-version-check -q --no-deps --no-build-isolation -e .
	$(PY) -c "import pathlib, sysconfig; pathlib.Path(sysconfig.get_paths()['purelib'], 'compendium.pth').write_text('$(CURDIR)/src\n')"
	$(PY) -m ipykernel install --sys-prefix --name $(KERNEL) --display-name "Python (ocpkit)"
	touch $@

# the published runs, then whether they reproduce the committed record by its contract (notebooks/contract.toml)
reproduce: notebooks report
	@if git rev-parse --verify -q HEAD >/dev/null 2>&1; then \
		$(PY) -m compendium.guard . --reference-commit HEAD || { \
		echo "make reproduce: the regenerated record (figures/, data/derived/) differs from the committed one beyond"; \
		echo "its contract (above). If the change is intended, review it with git diff and commit it."; exit 1; }; \
	else echo "make reproduce: not a git checkout, so nothing to compare the regenerated record with"; fi

# the published runs: each notebook with the parameters notebooks/published.toml gives it (the orbit transfer's
# full run; the others' defaults), writing figures/ and data/derived/ when each completes
notebooks: setup
	$(PY) -m compendium.notebooks reproduce $(NOTEBOOKS) --output build/notebooks --kernel $(KERNEL)

report: notebooks
	$(PY) -m compendium.notebooks report build/notebooks --output build/report

test: lint unit nbval guard

lint: setup
	$(VENV)/bin/ruff check .
	$(VENV)/bin/ruff format --check .

unit: setup
	$(PY) -m pytest tests/

# nbval writes figures and tables under build/test-output, never over the tracked ones
nbval: setup
	rm -rf build/test-output
	OCPKIT_OUTPUT_DIR=$(CURDIR)/build/test-output OCPKIT_PROGRESS=off $(PY) -m pytest --nbval-lax --nbval-kernel-name $(KERNEL) \
		--nbval-sanitize-with notebooks/nbval_sanitize.cfg -p no:cacheprovider $(NOTEBOOKS)

# what nbval's runs wrote, against the committed figures/ and data/derived/
guard: nbval
	$(PY) -m compendium.guard build/test-output

lab: setup
	$(PY) -m compendium.lab

bench: setup
	$(PY) benchmarks/bench_hlgl.py
	$(PY) benchmarks/bench_multirate.py
	$(PY) benchmarks/bench_fast_slow.py
	$(PY) benchmarks/bench_radau.py
	$(PY) benchmarks/bench_shooting.py
	$(PY) benchmarks/bench_orbit_transfer.py
	$(PY) benchmarks/bench_constraints.py
	$(PY) benchmarks/bench_refinement.py
	$(PY) benchmarks/bench_process.py
	$(PY) benchmarks/bench_many_solves.py
	$(PY) benchmarks/bench_sweep.py
	$(PY) benchmarks/bench_quasi_newton.py

# stored outputs use the default parameters; where those are a notebook's published ones its figures and tables
# are the published record (identical when nothing changed: review `git status`), otherwise they go to build/runs/
store: setup
	$(PY) -m compendium.notebooks store $(NOTEBOOKS) --kernel $(KERNEL)

clean:
	rm -rf build
