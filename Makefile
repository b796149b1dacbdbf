# Two commands do all set-up on a fresh machine (a C compiler, python3 >= 3.11 assumed):
#   make demo   builds the paper FMUs, runs earth/Mars/moon, writes CSV, a figure and the earth
#               run's animation (GIF and interactive HTML) to results/; the Gyrover closed
#               loop (earth, moon: turn and figure eight) with its plots and animations to
#               results/system/; the contact modes (ice_slide sliding, drop_bounce bouncing to rest): CSV
#               and a figure of height, slip and contact_mode to results/contact/
#   make test   installs what the tests need (Debian's chromium too, as root) and runs them all;
#               one builds the wheel and installs it into a fresh environment (pip, from PyPI)
#   make bench  the work-precision benchmark (results/bench/*.png, work_precision.md)
#   make realtime  the exported C in a 1 kHz fixed-step loop (results/c/realtime.md, docs/c_api.md)
#   make figures   every figure in docs/img and the records of the numbers the docs quote
#               (docs/figures.toml lists them with their commands)
PYTHON ?= python3
VENV   ?= .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed
SCENES := paper_earth paper_mars paper_moon

# Debian packages the C tests use: clang (the sources must build warning-free under gcc and
# clang), cmake (fmpy's build of an FMU's sources), valgrind (memory checks), tcc (a C99 compiler
# without GCC's extensions: the portable paths).  Installed when missing and we are root with
# apt-get (CI); otherwise named, and the tests needing them say so.
C_TOOLS := clang cmake valgrind tcc

.PHONY: demo test bench realtime figures venv browser clean c-tools tbb platform-tools

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
	$(PY) examples/contact_demo.py --out results/contact
	$(PY) -m gyrowheel animate results/system/closed_loop_earth_wheel.csv --fmu results/system/earth/gyrover_earth.fmu \
	    -o results/system/closed_loop_earth.gif --fps 10 --speed 4 --size 480x360 --trail 30
	$(PY) -m gyrowheel animate results/system/closed_loop_moon_wheel.csv --fmu results/system/moon/gyrover_moon.fmu \
	    -o results/system/closed_loop_moon.gif --fps 10 --speed 8 --size 480x360 --trail 60
	$(PY) -m gyrowheel animate results/paper_earth.csv --fmu results/fmus/paper_earth.fmu \
	    -o results/paper_earth.gif --fps 12 --speed 2 --size 480x360 --trail 5
	$(PY) -m gyrowheel animate results/paper_earth.csv --fmu results/fmus/paper_earth.fmu \
	    -o results/paper_earth.html --trail 5

# tests/test_animate_html.py drives a real headless browser: Debian's chromium
browser:
	@command -v chromium >/dev/null 2>&1 || { \
	  if [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then \
	    echo "installing Debian's chromium (headless browser for tests/test_animate_html.py)"; \
	    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium >/dev/null; \
	  else \
	    echo "chromium is missing and apt-get is not usable here: install Debian's chromium for tests/test_animate_html.py"; \
	  fi; }

c-tools:
	@missing=""; for t in $(C_TOOLS); do command -v $$t >/dev/null 2>&1 || missing="$$missing $$t"; done; \
	if [ -n "$$missing" ]; then \
	    if [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then \
	        echo "installing$$missing"; apt-get update -qq && apt-get install -y -qq $$missing >/dev/null; \
	    else echo "make test: missing$$missing (Debian: apt-get install$$missing)"; fi; \
	fi

# ecospy (tests/test_importers.py, a co-simulation master) links Debian's libtbb12
tbb:
	@ldconfig -p 2>/dev/null | grep -q 'libtbb\.so\.12' || { \
	  if [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then \
	    echo "installing Debian's libtbb12 (for ecospy)"; \
	    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq libtbb12 >/dev/null; \
	  else \
	    echo "libtbb12 is missing and apt-get is not usable here: install Debian's libtbb12 for ecospy (tests/test_importers.py)"; \
	  fi; }

# Debian packages that run the FMU's binaries for other platforms (tests/test_platforms_run.py):
# qemu-user (qemu-aarch64; qemu-x86_64 for a CPU without AVX2), libc6-arm64-cross (the aarch64 C
# library qemu-aarch64 -L loads), wine and wine64 (the Windows binary).  Installed when missing
# and we are root with apt-get (CI); otherwise named, and the tests fail naming them.
platform-tools:
	@missing=""; \
	command -v qemu-aarch64 >/dev/null 2>&1 && command -v qemu-x86_64 >/dev/null 2>&1 || missing="$$missing qemu-user"; \
	[ -e /usr/aarch64-linux-gnu/lib/ld-linux-aarch64.so.1 ] || missing="$$missing libc6-arm64-cross"; \
	command -v wine >/dev/null 2>&1 || missing="$$missing wine"; \
	[ -e /usr/lib/wine/wine64 ] || command -v wine64 >/dev/null 2>&1 || missing="$$missing wine64"; \
	if [ -n "$$missing" ]; then \
	    if [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then \
	        echo "installing$$missing (tests/test_platforms_run.py)"; \
	        apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq $$missing >/dev/null; \
	    else echo "make test: missing$$missing (Debian: apt-get install$$missing)"; fi; \
	fi

# The suite on every core (pytest-xdist, one worker per logical CPU, at most 4).  --dist loadfile
# keeps a file's tests on one worker, so a module fixture is built once; the FMUs several files
# share are built once per run for all workers (tests/conftest.py, shared_build).  One file, no
# workers: .venv/bin/python -m pytest tests/test_cli.py.  TEST_WORKERS=0: the whole suite in one process.
# --max-worker-restart 0: a test that kills its worker (a crash in C) fails the run at once, named;
# restarting workers re-ran it until the limit, and a crash in mid-file hung --dist loadfile
# (pytest-xdist 3.8's scheduler; one process would have died without any report).
TEST_WORKERS ?= logical
test: $(STAMP) browser c-tools tbb platform-tools
	$(PY) -m pytest -q -n $(TEST_WORKERS) --maxprocesses 4 --dist loadfile --no-loadscope-reorder --max-worker-restart 0 --durations 20

bench: $(STAMP)
	$(PY) -m pip install --quiet -e ".[bench]"
	$(PY) benchmarks/work_precision.py --out results/bench

# the real-time figures of docs/c_api.md: the exported C in a fixed-step 1 kHz loop (a few minutes)
realtime: $(STAMP)
	$(PY) examples/c_realtime.py --out results/c

# Every figure in docs/img, by the commands docs/figures.toml lists (tests/test_docs_figures.py
# checks that the two agree).  The sweeps take a few minutes on 2 cores; sweep_cost.png and the
# work-precision figures are timings: run them on a quiet machine.
figures: $(STAMP)
	$(PY) -m pip install --quiet -e ".[bench]"
	$(PY) examples/paper_demo.py --out results --png docs/img/paper_trajectories.png
	$(PY) examples/sweeps/stability_map.py --workers 2 --png docs/img/sweep_stability.png
	$(PY) examples/sweeps/paper_figs_5_6.py --workers 2 --png docs/img/sweep_paper_figs_5_6.png --record docs/img/sweep_paper_figs_5_6.json
	$(PY) examples/sweeps/monte_carlo.py --workers 2 --png docs/img/sweep_monte_carlo.png --record docs/img/sweep_monte_carlo.json
	$(PY) examples/sweeps/monte_carlo.py --closed-loop --samples 300 --workers 2 --png docs/img/sweep_monte_carlo_closed_loop.png --record docs/img/sweep_monte_carlo_closed_loop.json
	$(PY) benchmarks/sweep_scaling.py --png docs/img/sweep_cost.png
	$(PY) benchmarks/work_precision.py --scenarios paper long near_flat --peers heyoka plain --repeat 5 --out results/bench --png-dir docs/img
	$(PY) benchmarks/work_precision.py --scenarios stiff --out results/bench/stiff --png-dir docs/img

clean:
	rm -rf results build dist .pytest_cache
