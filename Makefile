# gpmegen: two commands for a new user, `make demo` and `make test`.
# Both create the virtual environment .venv when missing and install the package into it.

PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: venv demo test check-c snapshots bench clean animation docs

venv: $(STAMP)

# setuptools prints an "Editable installation" notice as a warning on every editable install
# (its advice: a folder named like the package in the working directory can shadow it; here that
# folder is the package itself). Only that notice is filtered; pip's own warnings still show.
EDITABLE_QUIET := PYTHONWARNINGS="ignore:Editable installation"

$(STAMP): pyproject.toml
	@echo "installing gpmegen and its dependencies into $(VENV) (about a minute)"
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(EDITABLE_QUIET) $(BIN)/python -m pip install --quiet -e ".[test]"
	touch $(STAMP)

demo: venv
	$(BIN)/gpmegen demo --overwrite

# On two processes (pytest-xdist): each has its own temporary folders, and the C cache they share
# is keyed by hash and written by rename. The long tests run in check-c. Python's bytecode caches
# (__pycache__, ignored by git) are written even where PYTHONDONTWRITEBYTECODE is set: without them
# each worker rewrites the test modules' assertions again (8 s of CPU) and each of the hundreds of
# commands the tests start compiles the package again.
TEST_ENV := PYTHONDONTWRITEBYTECODE=

# The import contracts of pyproject.toml (the layers, every import counted, those inside functions
# too; under a second), said only when one is broken; so are the types of the public modules
# ([tool.mypy] in pyproject.toml; 3 s of CPU with no cache, 0.2 s with its cache .mypy_cache).
test: venv
	$(BIN)/ruff check gpmegen tests benchmarks
	@report=$$($(BIN)/lint-imports --no-cache 2>&1) || { echo "$$report"; exit 1; }
	@report=$$($(BIN)/mypy 2>&1) || { echo "$$report"; exit 1; }
	$(TEST_ENV) $(BIN)/python -m pytest -q -n 2 -m "not sanitizers and not long"

# The generated C of a spread of models under AddressSanitizer and UndefinedBehaviorSanitizer,
# and as compiled for use (tests/test_c_sanitizers.py); and the long tests (marked long): the
# random-chain oracle, the convergence studies, the documentation's longer examples
# (tests/test_docs.py) and every test of more than a few seconds of CPU whose behaviour a cheaper
# test in make test also checks (the other parameters of the same test, or one a comment names).
# CI runs it after make test.
check-c: venv
	$(TEST_ENV) $(BIN)/python -m pytest -q -n 2 -m "sanitizers or long"

# A generated module imported with bytecode writing on leaves a __pycache__ beside it, which a
# forced build refuses to write over (a folder it did not make); it is never part of a snapshot.
snapshots: venv
	find generated -name __pycache__ -prune -exec rm -rf {} +
	$(BIN)/gpmegen build --nrfe 1 --force
	$(BIN)/gpmegen build --nrfe 5 --force

# The README's animations, small in bytes (10 frames per second, 70 dpi): the reference arm
# (n_rfe 5) over the paper's 10 s, its deformation magnified 3 times; the flexible Panda (needs
# example-robot-data) over two turns of its circle, from its constrained statics, magnified 100 times;
# and the model files' page's stills of the gripper (a tree) at four times, magnified 300 times,
# and of Baxter (two arms, a flexible upper arm each; needs example-robot-data) at three.
animation: venv
	$(BIN)/gpmegen simulate --nrfe 5 --t-end 10 --out results/animation_nrfe5.npz --overwrite
	$(BIN)/gpmegen animate results/animation_nrfe5.npz --out docs/figures/arm_nrfe5.gif --magnify 3 --fps 10 --dpi 70
	$(BIN)/gpmegen simulate examples/panda_flexible.toml --statics constrained --t-end 4 --out results/panda_flexible.npz --overwrite
	$(BIN)/gpmegen animate results/panda_flexible.npz --out docs/figures/panda_flexible.gif --magnify 100 --fps 10 --dpi 70 --view 30,-40
	$(BIN)/gpmegen simulate examples/flexible_gripper.toml --t-end 0.3 --dt 1e-4 --save-every 10 --out results/flexible_gripper.npz --overwrite
	$(BIN)/gpmegen animate results/flexible_gripper.npz --still 0,0.1,0.2,0.3 --magnify 300 --dpi 80 --out docs/figures/flexible_gripper.png --overwrite
	$(BIN)/gpmegen simulate examples/baxter_flexible.toml --statics constrained --t-end 2 --out results/baxter_flexible.npz --overwrite
	$(BIN)/gpmegen animate results/baxter_flexible.npz --still 0,1,2 --magnify 300 --dpi 80 --out docs/figures/baxter_flexible.png --overwrite

# The command line's reference page, made from its parser and help pages (tests/test_docs.py fails
# when the committed page differs).
docs: venv
	$(BIN)/python -m gpmegen.cli_docs > docs/command-line.md

bench: venv
	$(BIN)/python benchmarks/build_time.py

clean:
	rm -rf $(VENV) results figures build *.egg-info
