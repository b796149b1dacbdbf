# Two commands do all set-up on a fresh machine (a C compiler, python3 >= 3.11 assumed):
#   make demo   builds the paper FMUs, runs earth/Mars/moon, writes CSV and a figure to results/;
#               the Gyrover closed loop (earth, moon) to results/system/
#   make test   installs what the tests need and runs them all
#   make bench  the work-precision benchmark (results/bench/*.png, work_precision.md)
PYTHON ?= python3
VENV   ?= .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed
SCENES := paper_earth paper_mars paper_moon

.PHONY: demo test bench venv clean

$(VENV)/bin/python:
	$(PYTHON) -m venv $(VENV)

$(STAMP): pyproject.toml | $(VENV)/bin/python
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e ".[test]"
	touch $(STAMP)

venv: $(STAMP)

demo: $(STAMP)
	$(PY) examples/paper_demo.py --out results
	$(PY) examples/gyrover_control.py --out results/system

test: $(STAMP)
	$(PY) -m pytest -q

bench: $(STAMP)
	$(PY) benchmarks/work_precision.py --out results/bench

clean:
	rm -rf results build .pytest_cache
