# Two commands on a fresh machine: `make run` (the demo) and `make test` (everything).
# Both bootstrap what they need: system packages, the virtualenv, the database.

PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
SYSTEM_STAMP := var/.system-packages
SYSTEM_PACKAGES := chromium libzbar0 redis-server libvips42 ffmpeg
MNI := content/brain_atlas/mni_icbm152_t1_tal_nlin_sym_09a.nii.gz
DEMO_VOLUME := var/volumes/mni152
NODE_MODULES := node_modules/.installed

.PHONY: run test lint bench system clean

run: $(STAMP) $(DEMO_VOLUME)/volume.json $(NODE_MODULES)
	$(BIN)/tagwall serve

# Tests run in a worker per core (pytest-xdist); PYTEST_WORKERS=1 runs them in one.
PYTEST_WORKERS ?= $(shell nproc 2>/dev/null || echo 2)

test: $(STAMP) $(SYSTEM_STAMP) $(NODE_MODULES) lint
	$(BIN)/pytest -q -n $(PYTEST_WORKERS) --dist loadgroup

lint: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/mypy

bench: $(STAMP)
	$(BIN)/python -m benchmarks

$(STAMP): pyproject.toml $(SYSTEM_STAMP)
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install --quiet --upgrade pip
	$(BIN)/pip install --quiet -e '.[dev]'
	touch $@

# The demo's volume: the MNI brain template as a brick store (seconds to build).
$(DEMO_VOLUME)/volume.json: $(MNI) $(STAMP)
	$(BIN)/tagwall volume build $(MNI) $(DEMO_VOLUME)

# From the npm registry, pinned by package-lock.json: CesiumJS, which the server serves
# from its own origin at /static/cesium (the census map's globe); axe-core, the
# accessibility audit the browser tests inject into pages (never served to users); and
# oidc-provider, the OpenID Provider the tests run with node to sign staff in through
# (tests/oidc/). npm comes with Node.js; Debian's npm package where it does not.
#
# One string of CesiumJS is replaced: the knockout it bundles (for widgets tagwall does
# not use) finds the global object with (0,eval)("this") as the module is imported,
# which the Content-Security-Policy of every page (no 'unsafe-eval') refuses, and the
# import fails. globalThis is what it finds; the recipe fails when the string is still
# there, or no longer there to replace (another CesiumJS: look again).
CESIUM_MODULE := node_modules/cesium/Build/Cesium/index.js
$(NODE_MODULES): package.json package-lock.json
	@command -v npm >/dev/null || $(MAKE) --no-print-directory system SYSTEM_PACKAGES=npm
	npm ci --no-audit --no-fund --ignore-scripts --loglevel=error
	grep -qF '(0,eval)("this")' $(CESIUM_MODULE)
	sed -i 's/(0,eval)("this")/globalThis/' $(CESIUM_MODULE)
	! grep -qF '(0,eval)("this")' $(CESIUM_MODULE)
	touch $@

# Debian packages: the browser for tests and kiosks, zbar for decoding QR codes, libvips
# for the image app's pyramids.
system $(SYSTEM_STAMP):
	@missing=""; \
	for pkg in $(SYSTEM_PACKAGES); do \
	  dpkg-query -W -f='$${Status}' $$pkg 2>/dev/null | grep -q "install ok installed" \
	    || missing="$$missing $$pkg"; \
	done; \
	if [ -n "$$missing" ]; then \
	  if [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null; then \
	    echo "installing Debian packages:$$missing"; \
	    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq $$missing >/dev/null; \
	  else \
	    echo "tagwall needs these Debian packages:$$missing"; \
	    echo "install them with: sudo apt-get install$$missing"; \
	    exit 1; \
	  fi; \
	fi
	@mkdir -p var && touch $(SYSTEM_STAMP)

clean:
	rm -rf $(VENV) var node_modules .pytest_cache .mypy_cache .ruff_cache
