# The course's commands. `make figures` and `make test` do all the set-up.
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed
NBVAL  := --nbval --nbval-current-env --nbval-sanitize-with tests/nbval_sanitize.cfg --nbval-cell-timeout=300

.PHONY: venv figures test lint unit nbval notebooks student runs lab bench clean evidence

venv: $(STAMP)

$(STAMP): environment.txt pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -r environment.txt
	$(PY) -m pip install --quiet --no-deps -e .
	touch $(STAMP)

## Regenerate every figure (the report's Figs. 2-8 and the course's own) into figures/
figures: $(STAMP)
	$(PY) -m slamlib.figures figures

## Lint, unit/property/consistency tests, then every notebook under nbval
test: lint unit nbval

lint: $(STAMP)
	$(VENV)/bin/ruff check slamlib tests tools bench

unit: $(STAMP)
	$(PY) -m pytest tests

nbval: $(STAMP)
	env -u MPLBACKEND $(PY) -m pytest $(NBVAL) notebooks

## Re-execute every notebook in place (outputs committed); unchanged notebooks stay byte-identical
notebooks: $(STAMP)
	env -u MPLBACKEND $(PY) tools/execute_notebooks.py notebooks/*.ipynb

## Student edition: notebooks with the solutions emptied, into student/
student: $(STAMP)
	$(PY) tools/make_student.py notebooks student

## Regenerate the recorded runs in data/runs (bit for bit the same for the same code)
runs: $(STAMP)
	$(PY) tools/make_runs.py

## Regenerate the stored 100-seed studies in data/evidence (bit for bit; 20-60 min on 2 cores)
evidence: $(STAMP)
	$(PY) tools/make_evidence.py --workers 2

## Open the course in JupyterLab on localhost
lab: $(STAMP)
	$(VENV)/bin/jupyter lab --ip=127.0.0.1 notebooks

## Benchmarks (print numbers; never pass/fail)
bench: $(STAMP)
	$(PY) bench/bench_ekf.py
	$(PY) bench/bench_vision.py

clean:
	rm -rf $(VENV) figures student .pytest_cache .hypothesis .ruff_cache
