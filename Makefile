# Two commands do all the set-up on a fresh machine: `make demo` and `make test`.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: demo test test-fast lint bench clean

# torch goes in first, the CPU build where PyTorch's CPU index answers: pip ranks its
# 2.13.0+cpu above the public index's 2.13.0, which on Linux is the multi-GB CUDA build.
# Where that index cannot be reached, pip gives up on it within seconds (--retries 0
# --timeout 5; 1.8 s measured on a machine that reaches only the public index) and takes
# the public index's build. Then the `torch>=2.3` requirement is already met.
TORCH_CPU_INDEX := https://download.pytorch.org/whl/cpu
# --no-compile: byte-compiling all of torch at install costs ~15 s; Python compiles the
# modules it imports on first use instead.
PIP := $(BIN)/python -m pip install -q --no-compile
$(STAMP): pyproject.toml
	test -d $(VENV) || $(PYTHON) -m venv $(VENV)
	$(PIP) --upgrade pip
	$(PIP) torch==2.13.0 --extra-index-url $(TORCH_CPU_INDEX) --retries 0 --timeout 5 \
		|| $(PIP) 'torch>=2.3'
	$(PIP) -e '.[dev,raptor]'
	touch $(STAMP)

demo: $(STAMP)
	$(BIN)/quad-dob paper --out results
	$(BIN)/quad-dob evaluate --out results/evaluation

# two test workers, one per core of CI's machine (pytest-xdist); TEST_WORKERS=0 runs the
# suite in this process, as before
TEST_WORKERS ?= 2
test: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/python -m pytest -q -n $(TEST_WORKERS)

# the edit-test loop: ruff, then every test not marked slow (pyproject.toml's markers)
test-fast: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/python -m pytest -q -n $(TEST_WORKERS) -m "not slow"

lint: $(STAMP)
	$(BIN)/ruff check .

bench: $(STAMP)
	$(BIN)/python benchmarks/throughput.py

clean:
	rm -rf $(VENV) results .pytest_cache .ruff_cache
