# bsrflow: two commands on a fresh machine (python3 + pip + make):
#   make demo   -> virtual environment, install, run the main job (tapped column), write figures
#   make test   -> the default test suite (on TEST_WORKERS = 2 processes, pytest-xdist)
PYTHON ?= python3
VENV   ?= .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed
OUT    ?= out
TEST_WORKERS ?= 2

.PHONY: demo test test-slow verify stability analysis compare bench install clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e ".[test]"
	touch $(STAMP)

install: $(STAMP)

demo: $(STAMP)
	$(BIN)/bsrflow demo --out $(OUT)

test: $(STAMP)
	$(BIN)/python -m pytest -q -n $(TEST_WORKERS)

test-slow: $(STAMP)
	$(BIN)/python -m pytest -q -m slow

verify: $(STAMP)
	mkdir -p $(OUT)
	$(BIN)/bsrflow verify --json $(OUT)/verify.json

stability: $(STAMP)
	mkdir -p $(OUT)
	$(BIN)/bsrflow stability --json $(OUT)/stability.json --figures $(OUT)/stability

# output folders are not created by bsrflow (their parent must exist): mkdir -p $(OUT) first
# all analysis figures and JSON of chapter 5 / Appendix A (stability, kinetic energy, wave speed)
analysis: $(STAMP)
	mkdir -p $(OUT)
	$(BIN)/bsrflow stability --json $(OUT)/stability.json --figures $(OUT)/stability
	$(BIN)/bsrflow energy --json $(OUT)/energy.json --figures $(OUT)/energy

compare: $(STAMP)
	mkdir -p $(OUT)
	$(BIN)/bsrflow compare --json $(OUT)/compare.json --figures $(OUT)/compare

bench: $(STAMP)
	$(BIN)/python bench/bench_step.py --json bench/results.json
	$(BIN)/python bench/bench_packing.py --json bench/results.json
	$(BIN)/python bench/bench_bed.py --json bench/results.json
	$(BIN)/python bench/bench_packing_nd.py --json bench/results.json
	$(BIN)/python bench/bench_schemes.py --json bench/results_schemes.json

clean:
	rm -rf $(VENV) $(OUT) build src/*.egg-info
