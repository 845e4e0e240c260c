# Two commands for a fresh Debian 12 machine (see README.md):
#   make demo   install everything, then run the default scene
#   make test   install everything, then lint (ruff) and run the tests serial and under mpirun -n 2
# Re-running either is fast: each install step is skipped when nothing changed.

APT_PACKAGES := python3-dolfinx python3-gmsh python3-meshio python3-matplotlib python3-scipy \
                python3-pytest python3-venv python3-setuptools openmpi-bin python3-h5py
VENV   := .venv
PY     := $(VENV)/bin/python
SUDO   := $(shell [ "$$(id -u)" = 0 ] || echo sudo)
# OpenMPI refuses to start as root unless told; CI and containers run as root.
MPIRUN := OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_rmaps_base_oversubscribe=1 mpirun
PYTEST_ARGS ?=
RUFF   := ruff==0.17.6

.PHONY: demo test install system-packages clean

demo: install
	$(VENV)/bin/fem-bounce run

# With CI set (CI=true), each pass compiles every form into an empty cache of its own (ffcx's JIT
# cache lives under XDG_CACHE_HOME): a test that passes only on a machine whose cache is already warm
# fails in CI instead of on a new user's first `make test`.
FRESH_CACHE = $(if $(CI),rm -rf .ci-cache/$(1) && XDG_CACHE_HOME=$(CURDIR)/.ci-cache/$(1))

# The MPI subset first, so that the last line CI reads is the whole serial suite's summary.
test: install
	$(VENV)/bin/ruff check --no-cache .
	$(call FRESH_CACHE,mpi) $(MPIRUN) -n 2 $(PY) tests/mpirun_pytest.py -q --color=no -m mpi $(PYTEST_ARGS)
	$(call FRESH_CACHE,serial) $(PY) -m pytest -q $(PYTEST_ARGS)

install: $(VENV)/.installed

system-packages: .apt-stamp
.apt-stamp:
	@dpkg -s $(APT_PACKAGES) >/dev/null 2>&1 || { \
	  $(SUDO) apt-get update -qq && \
	  DEBIAN_FRONTEND=noninteractive $(SUDO) apt-get install -y -qq $(APT_PACKAGES); }
	@touch $@

# dolfinx and petsc4py import only under Debian's /usr/bin/python3, so the
# virtual environment is made from it and sees the system packages.
$(VENV)/.installed: .apt-stamp pyproject.toml
	@[ -x $(PY) ] || /usr/bin/python3 -m venv --system-site-packages $(VENV)
	$(PY) -m pip install -q --no-build-isolation --no-deps -e .
	$(PY) -m pip install -q "$(RUFF)"
	@touch $@

clean:
	rm -rf $(VENV) .apt-stamp *.egg-info .ci-cache
