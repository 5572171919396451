# The course's commands. `make figures` and `make test` do all the set-up.
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed
MADE   := $(VENV)/.made-by-make
NBVAL  := --nbval --nbval-current-env --nbval-sanitize-with tests/nbval_sanitize.cfg --nbval-cell-timeout=300
# `make TARGET PY=<an interpreter>` runs with that interpreter as it is: make installs nothing
# into a venv it did not create. Without PY=, every target first sets up its own $(VENV).
SETUP  := $(if $(filter file,$(origin PY)),$(STAMP))
# matplotlib refuses an unknown MPLBACKEND at import; the course chooses its own backends
unexport MPLBACKEND
# numpy's AVX-512 code (its own arctan2, exp, log, ...) rounds some results differently in the
# last bit from the C library, which the AVX2 machines and numba's compiled code use: with it
# off, every target computes the same bytes (notebooks, stored studies) on a machine with
# AVX-512 as on one without. (A name numpy does not know is ignored with a hidden warning:
# harmless elsewhere; tests/test_makefile.py checks the effect.)
export NPY_DISABLE_CPU_FEATURES := X86_V4 AVX512_ICL AVX512_SPR

.PHONY: venv figures test lint unit nbval notebooks notebooks-failed check-notebooks book \
        student runs lab bench clean studies evidence association-study graph-study \
        graph-mrclam gate-study linearisation-study pdf grade mrclam-heldout

venv: $(STAMP)

# Only into a venv this recipe created ($(MADE)) or set up before ($(STAMP)), never another.
$(STAMP): environment.txt pyproject.toml
	@if [ -e $(VENV) ] && [ ! -e $(MADE) ] && [ ! -e $(STAMP) ]; then \
	    echo "make: $(VENV) exists and was not created by make: remove it, choose another" \
	         "VENV=<new folder>, or run with PY=<its python> to use it as it is" >&2; exit 1; fi
	test -e $(VENV)/bin/python || { $(PYTHON) -m venv $(VENV) && touch $(MADE); }
	$(VENV)/bin/python -m pip install --quiet --upgrade pip
	$(VENV)/bin/python -m pip install --quiet -r environment.txt
	$(VENV)/bin/python -m pip install --quiet --no-deps -e .
	touch $(STAMP)

## Regenerate every figure (the report's Figs. 2-8 and the course's own) into figures/
figures: $(SETUP)
	$(PY) -m slamlib.course.figures figures

## Lint, unit/property/consistency tests (the web edition in Chromium too), every notebook under
## nbval, and the proof that the committed notebooks are what `make notebooks` writes
test: lint unit nbval check-notebooks

lint: $(SETUP)
	$(PY) -m ruff check slamlib tests tools bench

unit: $(SETUP)
	$(PY) -m pytest tests

nbval: $(SETUP)
	$(PY) -m pytest $(NBVAL) notebooks

## Re-execute every notebook in place (outputs committed); unchanged notebooks stay byte-identical
notebooks: $(SETUP)
	$(PY) tools/execute_notebooks.py notebooks/*.ipynb

## Re-execute only the notebooks that failed (or timed out) in the last `make notebooks`
notebooks-failed: $(SETUP)
	$(PY) tools/execute_notebooks.py --failed

## Fail if `make notebooks` would change a committed notebook (outputs tagged nbval-ignore-output aside)
check-notebooks: $(SETUP)
	$(PY) tools/execute_notebooks.py --check notebooks/*.ipynb

## The web edition: static HTML of every chapter (committed outputs, not re-executed) in book/_build/html
book: $(SETUP)
	$(PY) tools/build_book.py

## The printed edition: the whole course as one PDF, book/_build/pdf/ekf-slam-aruco.pdf (Sphinx's
## LaTeX builder, XeLaTeX and latexmk: Debian's latexmk texlive-xetex texlive-latex-extra
## texlive-fonts-recommended fonts-freefont-otf, as .ci/run installs them)
pdf: $(STAMP)
	$(PY) tools/build_book.py --pdf

## Grade students' notebooks: make grade SUBMISSIONS=dir [TIMEOUT=seconds per cell, 120]. One folder
## per student in dir; writes dir/grades.csv and each student's feedback.md beside their work
grade: $(STAMP)
	@test -n "$(SUBMISSIONS)" || { echo "usage: make grade SUBMISSIONS=dir [TIMEOUT=120]" >&2; exit 2; }
	env -u MPLBACKEND $(PY) tools/grade.py "$(SUBMISSIONS)" --timeout $(or $(TIMEOUT),120)

## Student edition: notebooks with the solutions emptied, into student/
student: $(SETUP)
	$(PY) tools/make_student.py notebooks student

## Regenerate the recorded runs in data/runs (bit for bit the same for the same code)
runs: $(SETUP)
	$(PY) tools/make_runs.py

## Regenerate chapter 06's stored Monte-Carlo studies in data/studies (bit for bit; ~10 min)
studies: $(SETUP)
	$(PY) tools/make_studies.py --workers 2

## Chapter 06's study of every gated reading into data/studies/ch06_gate.json (bit for bit)
gate-study: $(SETUP)
	$(PY) tools/make_gate_study.py --workers 2

## Chapter 06's one-factor ablation of EKF SLAM's linearisation points into
## data/studies/ch06_linearisation.json (100 seeds, 2 slips, 13 filters; bit for bit; ~25 min)
linearisation-study: $(SETUP)
	$(PY) tools/make_linearisation_study.py --workers 2

## Chapter 09's Monte-Carlo of ids / NN / JCBB (100 seeds) into data/studies (bit for bit); also the
## drifted loops (association_drift.json) and the dense worlds (association_dense.json)
association-study: $(SETUP)
	$(PY) -m slamlib.course.association_study

## Regenerate the stored 100-seed studies in data/evidence (bit for bit; ~10 min on 2 cores)
evidence: $(SETUP)
	$(PY) tools/make_evidence.py --workers 2

.PHONY: chapter-studies
## Chapter 07's stored study in data/evidence (explore_fej: 100 explorations of one world,
## EKF SLAM and FEJ on the same runs)
chapter-studies: $(STAMP)
	$(PY) -m slamlib.course.studies_ch07_08 --workers 2

## Open the course in JupyterLab on 127.0.0.1:8888 with a token (as root too, e.g. in a container)
lab: $(SETUP)
	$(PY) -m jupyter lab --ip=127.0.0.1 --port=8888 --no-browser \
	    $(if $(filter 0,$(shell id -u)),--allow-root) notebooks

## Benchmarks (print numbers; never pass/fail)
bench: $(SETUP)
	$(PY) bench/bench_ekf.py
	$(PY) bench/bench_vision.py
	$(PY) bench/bench_monte_carlo.py --chapters
	$(PY) bench/bench_association.py
	$(PY) bench/bench_graph.py

## Remove what make made (the venv only if make created it)
clean:
	@if [ -e $(MADE) ] || [ -e $(STAMP) ]; then rm -rf $(VENV); \
	elif [ -e $(VENV) ]; then echo "make: not removing $(VENV): not created by make" >&2; fi
	rm -rf figures student book/_build .notebooks-failed .pytest_cache .hypothesis .ruff_cache

## Regenerate chapter 11's stored study data/studies/graph_arena.json (200 runs, 2 processes)
graph-study: $(SETUP)
	$(PY) -m slamlib.course.graph_study

## Chapter 11's EKF / iSAM2 / batch on the five MRCLAM robots into data/studies (bit for bit)
graph-mrclam: $(SETUP)
	$(PY) -m slamlib.course.graph_mrclam

## Chapter 10's held-out test of the noise identification into data/studies/mrclam_heldout.json
## (bit for bit; about 20 min on one core). Needs a full download of MRCLAM Dataset 6:
##   make mrclam-heldout MRCLAM=/path/to/MRCLAM_Dataset6
mrclam-heldout: $(SETUP)
	@test -n "$(MRCLAM)" || { echo "MRCLAM=/path/to/MRCLAM_Dataset6 (the full download) is needed"; exit 2; }
	$(PY) -m slamlib.course.mrclam_heldout "$(MRCLAM)"
