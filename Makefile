# lanefinder: `make demo` and `make test` work on a fresh machine with Python >= 3.10.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed
CLIP   := data/clips/project_37-47s.mp4

.PHONY: install demo test test-fast lint bench eval eval-tune eval-unknown eval-events stills stills-synthetic truth check-videos clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[dev]'
	touch $(STAMP)

install: $(STAMP)

demo: $(STAMP)
	$(BIN)/lanefinder video $(CLIP) -o output/demo.mp4 --telemetry output/demo.csv \
		--contact-sheet output/demo_sheet.png
	$(BIN)/lanefinder plot output/demo.csv -o output/demo_plot.png
	$(BIN)/lanefinder image data/test_images -o output/images --stages output/stages
	@echo "demo outputs are in output/"

# Two processes (the machines have 2 cores); a test file stays in one process (its fixtures are shared),
# and files are handed out slowest first (tests/conftest.py, SLOWEST_FILES).
# The package is compiled first (compileall writes the bytecode even where PYTHONDONTWRITEBYTECODE
# is set, as on the CI machines, and Python reads it there): the suite's Python processes (Dask
# workers, `python -m lanefinder` runs, the fork server of tests/clirun.py) no longer each compile
# every module again (about 0.1 s a process).
test: $(STAMP)
	$(BIN)/python -m compileall -q src
	$(BIN)/python -m pytest -q -n 2 --dist loadfile --no-loadscope-reorder

# The unit tests and doctests (no full videos, no encoding, no subprocesses), on two processes: under 30 s.
test-fast: $(STAMP)
	$(BIN)/python -m compileall -q src
	$(BIN)/python -m pytest -q -m "not slow" -n 2 --dist loadfile

lint: $(STAMP)
	$(BIN)/ruff check .

bench: $(STAMP)
	$(BIN)/python benchmarks/bench.py $(if $(wildcard ../shared/data/udacity/videos/project_video.mp4),--memory ../shared/data/udacity/videos/project_video.mp4)

# Held-out seeds (never used for tuning), looks and cameras drawn from each seed; `eval-tune` the tuning seeds.
eval: $(STAMP)
	$(BIN)/python scripts/eval_synthetic.py --frames 50 --seeds 101 102

eval-tune: $(STAMP)
	$(BIN)/python scripts/eval_synthetic.py --frames 50 --seeds 0 1 2 --out output/eval-tune

# The same held-out scenes seen as a user with an unknown mount sees them: the lens only, no set-up.
eval-unknown: $(STAMP)
	$(BIN)/python scripts/eval_synthetic.py --frames 50 --seeds 101 102 --reuse --self-calibrate

# Lane events against synthetic truth (held-out seeds 101-103).
eval-events: $(STAMP)
	$(BIN)/python scripts/eval_events.py

# Blind stills (one a second) against the tracked videos: the single-image path.
stills: $(STAMP)
	$(BIN)/python scripts/stills_vs_video.py

# Blind stills of the held-out synthetic scenes (frames 10 and 35, default set-up) against their truth.
stills-synthetic: $(STAMP)
	$(BIN)/python scripts/stills_synthetic.py --seeds 101 102 --out output/eval

# The three videos' hand-labelled frames (data/truth/): the tracked video and blind stills against them.
truth: $(STAMP)
	$(BIN)/python scripts/video_truth.py

check-videos: $(STAMP)
	$(BIN)/python scripts/check_videos.py

clean:
	rm -rf output .pytest_cache
