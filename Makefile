# Set-up and the two main commands. Installs the pinned CPU torch wheel first: a bare "torch"
# requirement would pull a multi-GB CUDA build.
VENV ?= .venv
PY := $(VENV)/bin/python
TORCH := torch==2.13.0

.PHONY: install run test bench clean

install: $(VENV)/.installed

$(VENV)/.installed: pyproject.toml
	python3 -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q $(TORCH)
	$(PY) -m pip install -q -e ".[train,test,mujoco,zoo,distributed]"
	touch $@

run: install  ## the main job on the default config
	$(PY) -m cepam_gym.cli run

test: install
	$(PY) -m pytest -q

bench: install
	$(PY) benchmarks/throughput.py
	$(PY) benchmarks/plant_throughput.py

clean:
	rm -rf $(VENV) runs
