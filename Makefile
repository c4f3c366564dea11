# gpmegen: two commands for a new user, `make demo` and `make test`.
# Both create the virtual environment .venv when missing and install the package into it.

PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: venv demo test check-c snapshots bench clean

venv: $(STAMP)

$(STAMP): pyproject.toml
	@echo "installing gpmegen and its dependencies into $(VENV) (about a minute)"
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e ".[test]"
	touch $(STAMP)

demo: venv
	$(BIN)/gpmegen demo

test: venv
	$(BIN)/ruff check gpmegen tests benchmarks
	$(BIN)/python -m pytest -q -m "not sanitizers"

# The generated C of a spread of models under AddressSanitizer and UndefinedBehaviorSanitizer,
# and as compiled for use (tests/test_c_sanitizers.py).
check-c: venv
	$(BIN)/python -m pytest -q -m sanitizers

snapshots: venv
	$(BIN)/gpmegen build --nrfe 1 --force
	$(BIN)/gpmegen build --nrfe 5 --force

bench: venv
	$(BIN)/python benchmarks/build_time.py

clean:
	rm -rf $(VENV) results figures build *.egg-info
