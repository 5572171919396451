# The course's commands. `make figures` and `make test` do all the set-up.
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed
NBVAL  := --nbval --nbval-current-env --nbval-sanitize-with tests/nbval_sanitize.cfg --nbval-cell-timeout=300

.PHONY: venv figures test lint unit nbval notebooks notebooks-failed check-notebooks book \
        student runs lab bench clean studies evidence association-study graph-study \
        graph-mrclam gate-study

venv: $(STAMP)

$(STAMP): environment.txt pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -r environment.txt
	$(PY) -m pip install --quiet --no-deps -e .
	touch $(STAMP)

## Regenerate every figure (the report's Figs. 2-8 and the course's own) into figures/
figures: $(STAMP)
	$(PY) -m slamlib.course.figures figures

## Lint, unit/property/consistency tests (the web edition in Chromium too), every notebook under
## nbval, and the proof that the committed notebooks are what `make notebooks` writes
test: lint unit nbval check-notebooks

lint: $(STAMP)
	$(VENV)/bin/ruff check slamlib tests tools bench

unit: $(STAMP)
	$(PY) -m pytest tests

nbval: $(STAMP)
	env -u MPLBACKEND $(PY) -m pytest $(NBVAL) notebooks

## Re-execute every notebook in place (outputs committed); unchanged notebooks stay byte-identical
notebooks: $(STAMP)
	env -u MPLBACKEND $(PY) tools/execute_notebooks.py notebooks/*.ipynb

## Re-execute only the notebooks that failed (or timed out) in the last `make notebooks`
notebooks-failed: $(STAMP)
	env -u MPLBACKEND $(PY) tools/execute_notebooks.py --failed

## Fail if `make notebooks` would change a committed notebook (outputs tagged nbval-ignore-output aside)
check-notebooks: $(STAMP)
	env -u MPLBACKEND $(PY) tools/execute_notebooks.py --check notebooks/*.ipynb

## The web edition: static HTML of every chapter (committed outputs, not re-executed) in book/_build/html
book: $(STAMP)
	$(PY) tools/build_book.py

## Student edition: notebooks with the solutions emptied, into student/
student: $(STAMP)
	$(PY) tools/make_student.py notebooks student

## Regenerate the recorded runs in data/runs (bit for bit the same for the same code)
runs: $(STAMP)
	$(PY) tools/make_runs.py

## Regenerate chapter 06's stored Monte-Carlo studies in data/studies (bit for bit; ~10 min)
studies: $(STAMP)
	$(PY) tools/make_studies.py --workers 2

## Chapter 06's study of every gated reading into data/studies/ch06_gate.json (bit for bit)
gate-study: $(STAMP)
	$(PY) tools/make_gate_study.py --workers 2

## Chapter 09's Monte-Carlo of ids / NN / JCBB (100 seeds) into data/studies (bit for bit); also the
## drifted loops (association_drift.json) and the dense worlds (association_dense.json)
association-study: $(STAMP)
	$(PY) -m slamlib.course.association_study

## Regenerate the stored 100-seed studies in data/evidence (bit for bit; ~10 min on 2 cores)
evidence: $(STAMP)
	$(PY) tools/make_evidence.py --workers 2

.PHONY: chapter-studies
## Chapter 07's stored study in data/evidence (explore_fej: 100 explorations of one world,
## EKF SLAM and FEJ on the same runs)
chapter-studies: $(STAMP)
	$(PY) -m slamlib.course.studies_ch07_08 --workers 2

## Open the course in JupyterLab on 127.0.0.1:8888 with a token (as root too, e.g. in a container)
lab: $(STAMP)
	$(VENV)/bin/jupyter lab --ip=127.0.0.1 --port=8888 --no-browser \
	    $(if $(filter 0,$(shell id -u)),--allow-root) notebooks

## Benchmarks (print numbers; never pass/fail)
bench: $(STAMP)
	$(PY) bench/bench_ekf.py
	$(PY) bench/bench_vision.py
	env -u MPLBACKEND $(PY) bench/bench_monte_carlo.py --chapters
	$(PY) bench/bench_association.py
	$(PY) bench/bench_graph.py

clean:
	rm -rf $(VENV) figures student book/_build .notebooks-failed .pytest_cache .hypothesis .ruff_cache

## Regenerate chapter 11's stored study data/studies/graph_arena.json (200 runs, 2 processes)
graph-study: $(STAMP)
	$(PY) -m slamlib.course.graph_study

## Chapter 11's EKF / iSAM2 / batch on the five MRCLAM robots into data/studies (bit for bit)
graph-mrclam: $(STAMP)
	$(PY) -m slamlib.course.graph_mrclam
