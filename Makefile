# trigint: `make test` and `make reproduce` work on a fresh machine with Python 3.11 and Rust.
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
OUT    ?= reproduction

.PHONY: all install test test-rust test-python lint reproduce docs bench bench-deps bench-smoke wheel wheel-test clean

all: test

$(PY):
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip

# Builds the Rust extension (release profile) and installs the package with its test extras.
install: $(PY)
	@echo "trigint: installing; the first build of the Rust core (release) takes 5-15 minutes on 2 cores,"
	@echo "trigint: later ones seconds. cargo's progress follows."
	$(PY) scripts/install_progress.py test

# The Rust tests build (debug profile) beside the package's release build, which leaves a core
# idle while a single crate's front end runs. The Python tests then run on every core, a test
# file per worker (their module fixtures are built once).
test:
	$(MAKE) --no-print-directory -j2 test-rust test-python

# The debug profile: a minute faster to build than release here, and with overflow checks.
# The unit and integration tests, then the doctests; the examples are left to `make lint`
# (which checks them): building them here cost 30 s. No incremental cache: a fresh build
# writes one it never reads.
test-rust:
	env -u MAKEFLAGS -u MFLAGS CARGO_INCREMENTAL=0 cargo test -p trigint-core --lib --tests
	env -u MAKEFLAGS -u MFLAGS CARGO_INCREMENTAL=0 cargo test -p trigint-core --doc

test-python: install
	$(PY) -m pytest -n auto --dist loadfile tests --doctest-modules python/trigint -p no:cacheprovider --durations=12
	$(PY) examples/fpu_energy.py $(VENV)/example-output

lint: install
	cargo fmt --all --check
	cargo clippy --release --workspace --all-targets -- -D warnings
	RUSTDOCFLAGS="-D warnings" cargo doc --release -p trigint-core --no-deps
	$(VENV)/bin/ruff check python tests examples benchmarks

# The main job: the paper's Figures 1-5 at full resolution, their data and the measured claims.
reproduce: install
	$(VENV)/bin/trigint reproduce all --out $(OUT)

# The documentation site into docs/_build/html; warnings are errors. The gallery scripts run,
# and the reproduction page runs the paper's figures (about 25 s on 2 cores; TRIGINT_DOCS_QUICK=1 for the
# reduced versions).
docs: install
	$(PY) -c "import tomllib; print(*tomllib.load(open('pyproject.toml', 'rb'))['project']['optional-dependencies']['docs'], sep='\n')" > $(VENV)/docs-requirements.txt
	$(PY) -m pip install --quiet -r $(VENV)/docs-requirements.txt
	MPLBACKEND=Agg $(VENV)/bin/sphinx-build -W --keep-going -b html docs docs/_build/html
	$(PY) docs/check_pages.py docs/_build/html

bench-deps: install
	$(PY) -m pip install --quiet -e '.[test,bench]'

bench: bench-deps
	$(PY) benchmarks/run.py

bench-smoke: bench-deps
	$(PY) benchmarks/run.py --smoke

# A wheel (abi3: one file for every CPython >= 3.11) into dist/, and its test: installed into a
# fresh environment with no Rust toolchain involved, the shipped specs and the CLI must work.
wheel: $(PY)
	$(PY) -m pip install --quiet 'maturin>=1.9.4,<2'
	rm -rf dist
	$(VENV)/bin/maturin build --release --out dist

wheel-test: wheel
	rm -rf .venv-wheel
	$(PYTHON) -m venv .venv-wheel
	.venv-wheel/bin/python -m pip install --quiet dist/*.whl
	cd /tmp && $(CURDIR)/.venv-wheel/bin/python $(CURDIR)/.ci/installed_wheel.py

# Everything the targets above create, the generated documentation included (its reproduction
# run in docs/_generated is reused by later builds until removed).
clean:
	rm -rf $(VENV) .venv-wheel target dist benchmarks/build
	rm -rf docs/_build docs/_generated docs/generated docs/auto_examples docs/reproduction.md \
		docs/sg_execution_times.rst
