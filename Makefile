# Two commands for a fresh machine (see README.md):
#   make demo   install everything, then run the default scene (with the front's model: docs/usage.md)
#   make test   install everything, then lint (ruff) and run the tests serial (in TEST_WORKERS processes)
#               and under mpiexec -n 2
# Everything comes from PyPI as binary wheels (FEniCSx 0.11 with PETSc, MUMPS, OpenBLAS and MPICH:
# pyproject.toml's extras "stack" and "test") into .venv, made from a Python >= 3.12.
# Re-running either is fast: the install step is skipped when nothing changed.

VENV    := .venv
PY      := $(VENV)/bin/python
# MPICH's launcher from the wheel, beside the Python it starts (an OpenMPI mpiexec cannot start it)
MPIEXEC := $(VENV)/bin/mpiexec
PYTEST_ARGS ?=
# the serial suite's worker processes (pytest-xdist), one per core of the 2-core machines it is measured on
TEST_WORKERS ?= 2
# the system libraries gmsh's wheel links (X11 and OpenGL for its unused GUI), installed only if missing
GMSH_LIBS := libglu1-mesa libgl1 libxrender1 libxcursor1 libxfixes3 libxft2 libxinerama1 libgomp1
SUDO    := $(shell [ "$$(id -u)" = 0 ] || echo sudo)

.PHONY: demo test install clean

demo: install
	$(VENV)/bin/fem-bounce run

# With CI set (CI=true), each pass compiles every form into an empty cache of its own (ffcx's JIT
# cache lives under XDG_CACHE_HOME): a test that passes only on a machine whose cache is already warm
# fails in CI instead of on a new user's first `make test`.
FRESH_CACHE = $(if $(CI),rm -rf .ci-cache/$(1) && XDG_CACHE_HOME=$(CURDIR)/.ci-cache/$(1))

# The MPI subset first, so that the last line CI reads is the whole serial suite's summary.
test: install
	$(VENV)/bin/ruff check --no-cache .
	$(call FRESH_CACHE,mpi) $(MPIEXEC) -n 2 $(PY) tests/mpi_pytest.py -q --color=no -m mpi $(PYTEST_ARGS)
	$(call FRESH_CACHE,serial) $(PY) -m pytest -q -n $(TEST_WORKERS) --dist worksteal $(PYTEST_ARGS)

install: $(VENV)/.installed

# The first of python3.13, python3.12 and pyenv's 3.12+ versions that runs.
find_python = for p in python3.13 python3.12 $$(ls -d $$( (pyenv root || echo $$HOME/.pyenv) 2>/dev/null)/versions/3.1[2-9]*/bin/python 2>/dev/null | sort -rV); do \
	  $$p -c 'import sys; sys.exit(sys.version_info < (3, 12))' 2>/dev/null && { echo $$p; break; }; done

$(VENV)/.installed: pyproject.toml
	@[ -x $(PY) ] || { python=$$($(find_python)); \
	  [ -n "$$python" ] || { echo "fem_bounce needs Python >= 3.12 (FEniCSx's wheels): none found; get one with e.g. 'uv python install 3.12' or 'pyenv install 3.12'" >&2; exit 1; }; \
	  echo "making $(VENV) from $$python ($$($$python --version))"; $$python -m venv $(VENV); }
	$(PY) -m pip install -q -e ".[stack,test]"
	@$(PY) -c "import gmsh" 2>/dev/null || { \
	  $(SUDO) apt-get update -qq && DEBIAN_FRONTEND=noninteractive $(SUDO) apt-get install -y -qq $(GMSH_LIBS); }
	@touch $@

clean:
	rm -rf $(VENV) *.egg-info .ci-cache
