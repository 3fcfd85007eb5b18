# Set-up and the two main commands. Installs the pinned CPU torch wheel first: a bare "torch"
# requirement would pull a multi-GB CUDA build.
VENV ?= .venv
PY := $(VENV)/bin/python
# Ray RLlib pins gymnasium exactly (ray 2.60: gymnasium==1.2.2), so the [distributed] extra gets a
# venv of its own: the main one keeps the newest gymnasium, and RLlib is tested as its users run it.
RAY_VENV ?= .venv-ray
RAY_PY := $(RAY_VENV)/bin/python
TORCH := torch==2.13.0

.PHONY: install install-distributed run test test-all test-fast lint docs bench lock clean

install: $(VENV)/.compiled

install-distributed: $(RAY_VENV)/.installed

# $(call venv,DIR,EXTRAS,CONSTRAINTS): a venv with the CPU torch wheel first, then the package and
# its extras at the versions the constraints file pins (the ones the README's figures were measured
# with; `make lock` re-resolves them, docs/reproducibility.md)
define venv
	python3 -m venv $(1)
	$(1)/bin/python -m pip install -q --upgrade pip
	$(1)/bin/python -m pip install -q -c $(3) $(TORCH)
	$(1)/bin/python -m pip install -q -c $(3) -e ".[$(2)]"
	touch $(1)/.installed
endef

MAIN_EXTRAS := train,test,mujoco,zoo,offline,docs
RAY_EXTRAS := train,test,distributed
LOCK := requirements/constraints.txt
RAY_LOCK := requirements/constraints-ray.txt

$(VENV)/.installed: pyproject.toml $(LOCK)
	$(call venv,$(VENV),$(MAIN_EXTRAS),$(LOCK))

# numba's cache of the kernels (python -m cepam_gym.precompile; 3 min on 2 cores, once), so the main
# job and a user's first env start from machine code. The tests do not wait for it: on 2 cores it
# made a fresh clone's pytest no faster (cepam-gym 1.0.0, fresh clones of 4b06cd2 and 35bce5a on
# one 2-core machine: 18 min 28 s without, 18 min 32 s with), each worker compiling only what it
# first drives while the other keeps testing
$(VENV)/.compiled: $(VENV)/.installed
	$(PY) -m cepam_gym.precompile
	touch $@

$(RAY_VENV)/.installed: pyproject.toml $(RAY_LOCK)
	$(call venv,$(RAY_VENV),$(RAY_EXTRAS),$(RAY_LOCK))

# re-pin every package to what a fresh install resolves today (both constraints files; nothing is
# installed); then rebuild the venvs and re-measure the README's figures before committing
lock:
	python3 requirements/lock.py --torch "$(TORCH)" $(LOCK)=$(MAIN_EXTRAS) $(RAY_LOCK)=$(RAY_EXTRAS)

run: install  ## the main job on the default config
	$(PY) -m cepam_gym.cli run

# every test on every core (pytest-xdist; --dist worksteal keeps both cores busy behind the long
# tests) but the previous versions' re-measurements (marked previous_versions: the oracle's
# stored figures and firmness on versions the goldens pin; test-all runs them too); the strict docs
# build is one of them (tests/project/test_docs.py); the RLlib tests, skipped in .venv, run again
# in .venv-ray
test: $(VENV)/.installed install-distributed
	$(PY) -m pytest -q -n auto --dist worksteal -m "not previous_versions"
	$(RAY_PY) -m pytest -q tests/integrations/test_rllib.py tests/integrations/test_ray_grid.py

# what test runs and the previous versions' re-measurements: before a release, and after a change
# of the oracle, the planner or a previous version's plant
test-all: $(VENV)/.installed install-distributed
	$(PY) -m pytest -q -n auto --dist worksteal
	$(RAY_PY) -m pytest -q tests/integrations/test_rllib.py tests/integrations/test_ray_grid.py

# the inner loop: everything but the tests marked slow (training, wheel builds, videos, golden
# trajectories), on every core when pytest-xdist is there
test-fast: $(VENV)/.installed
	$(PY) -m pytest -q -m "not slow" -n auto --dist worksteal

lint: $(VENV)/.installed  ## ruff lint and format check (configured in pyproject.toml; tests/project/test_lint.py runs both)
	$(PY) -m ruff check .
	$(PY) -m ruff format --check .

# the documentation site (mkdocs.yml) into site/; strict: a broken link, a missing page or a warning fails
docs: $(VENV)/.installed
	NO_MKDOCS_2_WARNING=1 $(PY) -m mkdocs build --strict

bench: install
	$(PY) benchmarks/throughput.py
	$(PY) benchmarks/plant_throughput.py

clean:
	rm -rf $(VENV) $(RAY_VENV) runs site
