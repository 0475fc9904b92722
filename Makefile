# Reproducible research compendium for optimal control.
#   make reproduce   set up, execute every notebook headless, regenerate figures/ data/derived/ and the HTML report
#   make test        set up, run the unit tests and nbval over the notebooks
#   make lab         JupyterLab on the same environment
#   make bench       timing benchmarks (tables in build/bench/)
#   make store       re-execute the notebooks in place (refresh the outputs nbval compares against)

PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
KERNEL := ocpkit
STAMP  := $(VENV)/.installed
NOTEBOOKS := $(sort $(wildcard notebooks/*.ipynb))
ORBIT     := notebooks/05_orbit_transfer.ipynb
# the full orbit-transfer run (all five thrusts, continuations from scratch, the whole 5 N horizon study);
# CI's nbval uses the fast defaults
ORBIT_PARAMS := -p thrusts None -p recompute True -p horizon_seeds "[1.3, 1.6, 1.75, 2.0]"

# One BLAS thread: the NLPs here are small and sparse, and idle BLAS threads only steal the second core.
export OPENBLAS_NUM_THREADS := 1
export OMP_NUM_THREADS := 1
export MPLBACKEND := Agg

.PHONY: setup reproduce notebooks report test unit nbval lab bench store clean

setup: $(STAMP)

$(STAMP): environment.txt pyproject.toml
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --disable-pip-version-check -q -r environment.txt
	$(PY) -m pip install --disable-pip-version-check -q --no-deps --no-build-isolation -e .
	$(PY) -c "import pathlib, sysconfig; pathlib.Path(sysconfig.get_paths()['purelib'], 'compendium.pth').write_text('$(CURDIR)/src\n')"
	$(PY) -m ipykernel install --sys-prefix --name $(KERNEL) --display-name "Python (ocpkit)"
	touch $@

reproduce: notebooks report

notebooks: setup
	$(PY) -m compendium.notebooks run $(filter-out $(ORBIT),$(NOTEBOOKS)) --output build/notebooks --kernel $(KERNEL)
	$(PY) -m compendium.notebooks run $(ORBIT) --output build/notebooks --kernel $(KERNEL) $(ORBIT_PARAMS)

report: notebooks
	$(PY) -m compendium.notebooks report build/notebooks --output build/report

test: unit nbval

unit: setup
	$(PY) -m pytest tests/

# nbval writes figures and tables under build/test-output, never over the tracked ones
nbval: setup
	OCPKIT_OUTPUT_DIR=$(CURDIR)/build/test-output $(PY) -m pytest --nbval-lax --nbval-kernel-name $(KERNEL) -p no:cacheprovider $(NOTEBOOKS)

lab: setup
	$(VENV)/bin/jupyter lab notebooks/

bench: setup
	$(PY) benchmarks/bench_hlgl.py
	$(PY) benchmarks/bench_multirate.py
	$(PY) benchmarks/bench_radau.py
	$(PY) benchmarks/bench_shooting.py
	$(PY) benchmarks/bench_orbit_transfer.py

# stored outputs use the default parameters; their figures and tables go to build/store-output,
# so storing never overwrites what make reproduce wrote to figures/ and data/derived/
store: setup
	OCPKIT_OUTPUT_DIR=$(CURDIR)/build/store-output $(PY) -m compendium.notebooks store $(NOTEBOOKS) --kernel $(KERNEL)

clean:
	rm -rf build
