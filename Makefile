# Two commands on a fresh machine with only python3 and make:
#   make build   set up .venv, install hwgen, build out/prototype/ from params/prototype.yaml
#   make test    same set-up, then the whole test suite
#   make test-fast  the tests that build no part with the CAD kernel (under a minute)
#   make docs    the documentation site into site/ (open site/index.html)
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

.PHONY: build test test-fast bench stability docs docs-images clean venv clients slicer-check bytecode

venv: $(STAMP)

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e ".[test,docs]"
	touch $(STAMP)

# hwgen's modules compiled ahead (as pip compiles an installed package): every process a build
# starts (the command, the workers' server, the renderer, the gear checks) then reads them compiled,
# also where Python is told not to write bytecode (PYTHONDONTWRITEBYTECODE), which would compile
# them again in each process (about a tenth of a second each); stale ones are compiled again here
bytecode: $(STAMP)
	@$(BIN)/python -m compileall -q hwgen

build: $(STAMP) bytecode
	$(BIN)/hwgen build params/prototype.yaml --out out

# The programs the tests open the files in (PrusaSlicer: the plates; FreeCAD: assembly.step's
# names). Installed from Debian's packages where they are missing and apt-get can (as root);
# elsewhere install prusa-slicer and freecad yourself, or their tests skip (never with CI=true).
CLIENTS := prusa-slicer freecadcmd
clients:
	@missing=""; for c in $(CLIENTS); do command -v $$c >/dev/null || missing="$$missing $$c"; done; \
	if [ -n "$$missing" ]; then \
	  if [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null; then \
	    echo "installing prusa-slicer and freecad (missing:$$missing)"; \
	    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
	      prusa-slicer freecad >/dev/null; \
	  else echo "not installed:$$missing (apt-get install prusa-slicer freecad); their tests will skip"; fi; fi

# one pytest worker per core (pytest-xdist); the tests that share a module's build run in one
# worker, and the workers share one part cache (tests/conftest.py)
test: $(STAMP) clients bytecode
	$(BIN)/python -m pytest -q -n auto --dist loadgroup

# every print plate sliced in PrusaSlicer as the process prints it (SLA: minutes per plate); not in make test
slicer-check: $(STAMP) clients
	$(BIN)/hwgen plates params/prototype.yaml --out out -q
	$(BIN)/python -m tests.slicer_check out/prototype

# one pytest worker per core (pytest-xdist): the CAD-free tier is many small tests that do not share a build
test-fast: $(STAMP) bytecode
	$(BIN)/python -m pytest -q -m "not slow" -n auto --dist loadgroup

# the benchmark times the disks against OpenSCAD (Debian's openscad, installed here when missing and apt-get can)
bench: $(STAMP) bytecode
	@command -v openscad >/dev/null || { [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null && \
	  apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends openscad >/dev/null; } || \
	  echo "openscad not installed: the benchmark's OpenSCAD row says so"
	$(BIN)/python -m hwgen.bench

# 100 robots drawn as a lab writes them, each built whole: a table of exit codes and failed checks
stability: $(STAMP) bytecode
	$(BIN)/python -m tests.stability --robots 100

# the pictures of the README and the site (docs/images/), from fresh builds of the prototype (with
# its MuJoCo model) and of the twenty-disk robot, which fails checks (exit 1) and marks them in its
# pictures; docs/pictures.py names them and keeps each small
docs-images: $(STAMP)
	rm -rf .docs-build
	$(BIN)/hwgen build params/prototype.yaml --out .docs-build -q
	$(BIN)/hwgen sim params/prototype.yaml --out .docs-build -q
	$(BIN)/hwgen experiment params/prototype.yaml --out .docs-build -q
	$(BIN)/hwgen build params/twenty-disks.yaml --out .docs-build -q || [ $$? -eq 1 ]
	$(BIN)/python docs/pictures.py .docs-build docs/images
	rm -rf .docs-build

# the documentation site into site/ (open site/index.html): every link and anchor must resolve, the
# parameter reference is written from the schema, and every check of the code must have its row
docs: $(STAMP)
	NO_MKDOCS_2_WARNING=1 $(BIN)/mkdocs build --strict --site-dir site

clean:
	rm -rf out/*/ .pytest_cache
