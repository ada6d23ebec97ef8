# The two commands a newcomer needs are `make demo` and `make test`; each sets up .venv itself.
PYTHON ?= python3.11
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: demo test test-slow lint bench docs clean

$(STAMP): pyproject.toml
	@command -v $(PYTHON) >/dev/null || { echo "error: $(PYTHON) not found; install Python 3.11" >&2; exit 1; }
	@test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[dev]'
	@touch $@

demo: $(STAMP)
	@mkdir -p out
	$(BIN)/python -m tracer render -o out/default.png
	@echo "image: $(CURDIR)/out/default.png"

lint: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .

test: lint
	$(BIN)/python -m pytest -q

test-slow: $(STAMP)
	$(BIN)/python -m pytest -q -m slow

bench: $(STAMP)
	$(BIN)/python scripts/bench_tracer.py

REPORT_STAMP := $(VENV)/.installed-report

$(REPORT_STAMP): $(STAMP)
	$(BIN)/python -m pip install --quiet -e '.[dev,report]'
	@touch $@

docs: $(REPORT_STAMP)
	$(BIN)/python scripts/plot_step_response.py

clean:
	rm -rf $(VENV) out dist
