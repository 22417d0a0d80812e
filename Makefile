# Two commands on a fresh machine with only python3 and make:
#   make build   set up .venv, install hwgen, build out/prototype/ from params/prototype.yaml
#   make test    same set-up, then the whole test suite
#   make test-fast  the tests that build no part with the CAD kernel (under a minute)
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

.PHONY: build test test-fast bench stability docs-images clean venv

venv: $(STAMP)

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e ".[test]"
	touch $(STAMP)

build: $(STAMP)
	$(BIN)/hwgen build params/prototype.yaml --out out

test: $(STAMP)
	$(BIN)/python -m pytest -q

test-fast: $(STAMP)
	$(BIN)/python -m pytest -q -m "not slow"

bench: $(STAMP)
	$(BIN)/python -m hwgen.bench

# 100 robots drawn as a lab writes them, each built whole: a table of exit codes and failed checks
stability: $(STAMP)
	$(BIN)/python -m tests.stability --robots 100

# the README's pictures, from a fresh build of the prototype
docs-images: $(STAMP)
	rm -rf .docs-build
	$(BIN)/hwgen build params/prototype.yaml --out .docs-build -q
	cp .docs-build/prototype/exploded.png docs/images/prototype-exploded.png
	cp .docs-build/prototype/bent.png docs/images/prototype-bent.png
	rm -rf .docs-build

clean:
	rm -rf out/*/ .pytest_cache
