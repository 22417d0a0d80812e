# Two commands on a fresh machine with only python3 and make:
#   make build   set up .venv, install hwgen, build out/prototype/ from params/prototype.yaml
#   make test    same set-up, then the whole test suite
#   make test-fast  the tests that build no part with the CAD kernel (under a minute)
#   make docs    the documentation site into site/ (open site/index.html)
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

.PHONY: build test test-fast bench stability docs docs-images clean venv clients slicer-check bytecode viewer

venv: $(STAMP)

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e ".[test,docs]"
	touch $(STAMP)

# hwgen's modules compiled ahead (as pip compiles an installed package): every process a build
# starts (the command, the workers' server, the renderer, the gear checks) then reads them compiled,
# also where Python is told not to write bytecode (PYTHONDONTWRITEBYTECODE), which would compile
# them again in each process (about a tenth of a second each); stale ones are compiled again here.
# The numba kernels too (hwgen/sim/kernels.py: about 22 s of CPU on a fresh checkout, a second once
# on disk), which the first build or test worker to call them would otherwise compile, and each
# xdist worker that gets there before the other has written them
bytecode: $(STAMP)
	@$(BIN)/python -m compileall -q hwgen
	@$(BIN)/python -m hwgen.sim.kernels

build: $(STAMP) bytecode viewer
	$(BIN)/hwgen build params/prototype.yaml --out out

# The viewer inlined in view.html: three.js from npm (the versions package-lock.json pins) and
# hwgen/outputs/webview.js, bundled by esbuild into the environment, never into the repository
# (node_modules/ and the bundle are not committed). Without npm, or if the install fails, view.html
# is written without its 3D view (it lists the parts, checks and stiffness and says so); the
# browser tests then skip, except under CI=true.
VIEWER := $(VENV)/share/hwgen/webview.js
viewer: $(VIEWER)

$(VIEWER): $(STAMP) package.json package-lock.json hwgen/outputs/webview.js
	@if command -v npm >/dev/null; then \
	  { npm ci --no-audit --no-fund --loglevel=error && mkdir -p $(@D) && \
	    node_modules/.bin/esbuild hwgen/outputs/webview.js --bundle --minify --format=iife --log-level=warning \
	      --banner:js="/* hwgen viewer: three $$(node -p 'require("./node_modules/three/package.json").version') (npm), bundled by esbuild $$(node_modules/.bin/esbuild --version) */" \
	      --outfile=$@; } || echo "warning: the viewer was not built: view.html is written without its 3D view"; \
	else echo "npm not found: view.html is written without its 3D view (install Node.js and npm, then make viewer)"; fi

# The programs the tests open the files in (PrusaSlicer: the plates; FreeCAD: assembly.step's
# names; Chromium: view.html). Installed from Debian's packages where they are missing and apt-get
# can (as root); elsewhere install prusa-slicer, freecad and chromium yourself, or their tests skip
# (never with CI=true).
CLIENTS := prusa-slicer freecadcmd chromium
clients:
	@missing=""; for c in $(CLIENTS); do command -v $$c >/dev/null || missing="$$missing $$c"; done; \
	if [ -n "$$missing" ]; then \
	  if [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null; then \
	    echo "installing prusa-slicer, freecad and chromium (missing:$$missing)"; \
	    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
	      prusa-slicer freecad chromium >/dev/null; \
	  else echo "not installed:$$missing (apt-get install prusa-slicer freecad chromium); their tests will skip"; fi; fi

# pytest keeps each test module as rewritten for its asserts in tests/__pycache__ (as Python keeps
# a compiled module), unless Python is told not to write bytecode (PYTHONDONTWRITEBYTECODE, set in
# some CI images and shells): then every xdist worker rewrites all of tests/ on every run, about
# 3 s of CPU each. The suite's pytest writes it whatever the caller's setting; hwgen's own modules
# are compiled ahead by make bytecode either way
PYTEST := PYTHONDONTWRITEBYTECODE= $(BIN)/python -m pytest

# one pytest worker per core (pytest-xdist); the tests that share a module's build run in one
# worker, and the workers share one part cache; the work is handed out in the order
# tests/conftest.py sorts it (LONGEST: the longest first), not the groups with the most tests first
# the clients' install (apt-get: minutes, mostly downloading) runs beside the environment's (pip,
# npm) rather than before it; its output is shown once it ends
test:
	@$(MAKE) --no-print-directory clients > .clients.log 2>&1 & clients=$$!; \
	  $(MAKE) --no-print-directory $(STAMP) bytecode viewer; made=$$?; \
	  wait $$clients; installed=$$?; cat .clients.log; rm -f .clients.log; \
	  [ $$made = 0 ] && [ $$installed = 0 ]
	$(PYTEST) -q -n auto --dist loadgroup --no-loadscope-reorder

# every print plate sliced in PrusaSlicer as the process prints it (SLA: minutes per plate); not in make test
slicer-check: $(STAMP) clients
	$(BIN)/hwgen plates params/prototype.yaml --out out -q
	$(BIN)/python -m tests.slicer_check out/prototype

# one pytest worker per core (pytest-xdist): the CAD-free tier is many small tests that do not share a build
test-fast: $(STAMP) bytecode
	$(PYTEST) -q -m "not slow" -n auto --dist loadgroup --no-loadscope-reorder

# the benchmark times the disks against OpenSCAD (Debian's openscad, installed here when missing and apt-get can)
bench: $(STAMP) bytecode viewer
	@command -v openscad >/dev/null || { [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null && \
	  apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends openscad >/dev/null; } || \
	  echo "openscad not installed: the benchmark's OpenSCAD row says so"
	$(BIN)/python -m hwgen.bench

# 100 robots drawn as a lab writes them, each built whole: a table of exit codes and failed checks;
# then the schema-wide Hypothesis draw of tests/test_any_design.py to 5 000 designs (make test: 1 500)
stability: $(STAMP) bytecode
	$(BIN)/python -m tests.stability --robots 100
	HWGEN_ANY_DESIGN_EXAMPLES=5000 $(BIN)/python -m pytest -q -p no:xdist tests/test_any_design.py -k many_more

# the pictures of the README and the site (docs/images/), from fresh builds of the prototype (with
# its MuJoCo model) and of the twenty-disk robot, which fails checks (exit 1) and marks them in its
# pictures, and the prototype's view.html in headless Chromium with a disk clicked (tests/browser.py);
# docs/pictures.py names them and keeps each small
docs-images: $(STAMP) viewer
	rm -rf .docs-build
	$(BIN)/hwgen build params/prototype.yaml --out .docs-build -q
	$(BIN)/hwgen sim params/prototype.yaml --out .docs-build -q
	$(BIN)/hwgen experiment params/prototype.yaml --out .docs-build -q
	$(BIN)/hwgen build params/twenty-disks.yaml --out .docs-build -q || [ $$? -eq 1 ]
	$(BIN)/python -m tests.browser .docs-build/prototype/view.html .docs-build/prototype/view.png disk_06
	$(BIN)/python docs/pictures.py .docs-build docs/images
	rm -rf .docs-build

# the documentation site into site/ (open site/index.html): every link and anchor must resolve, the
# parameter reference is written from the schema, and every check of the code must have its row
docs: $(STAMP)
	NO_MKDOCS_2_WARNING=1 $(BIN)/mkdocs build --strict --site-dir site

clean:
	rm -rf out/*/ .pytest_cache
