# The two commands of the README: `make demo` and `make test`.
# Both first run scripts/setup.sh, which installs whatever is missing (once).

SHELL := /bin/bash
NP ?= 2
export OMPI_ALLOW_RUN_AS_ROOT := 1
export OMPI_ALLOW_RUN_AS_ROOT_CONFIRM := 1
export OMPI_MCA_rmaps_base_oversubscribe := 1
export MPLBACKEND := Agg
# one BLAS thread per MPI rank: the machines have two cores and mpirun -n 2 uses both
export OPENBLAS_NUM_THREADS := 1
PY = $(shell cat .python-path)

.PHONY: setup demo test test-serial test-mpi lint gallery docs docs-check clean

setup:
	@scripts/setup.sh > .python-path.tmp && tail -n 1 .python-path.tmp > .python-path && rm -f .python-path.tmp

# The main job: the paper's experiments (the bar also with its time loop written out).
demo: setup
	$(PY) demos/bar_1d.py --out out/bar_1d
	$(PY) demos/bar_loop_1d.py --out out/bar_loop_1d
	$(PY) demos/compare_methods_1d.py --out out/compare_methods_1d
	$(PY) demos/convergence_1d.py --out out/convergence_1d
	mpirun -n $(NP) $(PY) demos/ring_2d.py --quiet --out out/ring_2d
	mpirun -n $(NP) $(PY) demos/disk_2d.py --quiet --out out/disk_2d
	mpirun -n $(NP) $(PY) demos/ball_3d.py --quiet --out out/ball_3d

# The suite serially, then the MPI tests under mpirun -n $(NP).
test: setup
	$(MAKE) --no-print-directory test-serial test-mpi

test-serial:
	$(PY) -m pytest -q tests

test-mpi:
	mpirun -n $(NP) $(PY) -m pytest -q -m mpi -p no:cacheprovider tests

lint:
	$(PY) -m pip install --quiet ruff
	$(PY) -m ruff check nitsche_dolfinx demos tests benchmarks meshes scripts
	$(PY) -m ruff format --check nitsche_dolfinx demos tests benchmarks meshes scripts

# The site's gallery: every demo run serially (scripts/gallery.py, its flags in one table),
# its pictures into docs/gallery/<demo>/ and docs/gallery/gallery.json; DEMOS="a b": only those.
gallery: setup
	$(PY) scripts/gallery.py $(DEMOS)

# The documentation site (docs/conf.py): the README, docs/*.md, the demos and the API
# reference, into _site/html; a warning fails the build.
docs: setup
	@test -e /usr/share/javascript/mathjax/MathJax.js || \
	  (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq libjs-mathjax)
	$(PY) -m pip install --quiet sphinx myst-nb jupytext furo sphinx-argparse
	$(PY) -m sphinx -W --keep-going -E -q -c docs -b html . _site/html

# The built site in headless Chromium: console errors, images, links, formulas, search.
docs-check: docs
	@command -v chromedriver > /dev/null && $(PY) -c "import selenium" 2> /dev/null || \
	  (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq \
	   chromium chromium-driver python3-selenium)
	$(PY) scripts/check_site.py _site/html

clean:
	rm -rf out .pytest_cache .python-path .setup-stamp _site
