#!/usr/bin/env bash
# Set-up step of `make demo` and `make test`: make sure dolfinx and the project are importable.
#
# - If the python3 on PATH already imports dolfinx (conda, the dolfinx docker
#   images), install the project into it (editable) and use it.
# - Otherwise (Debian/Ubuntu): install the FEniCSx apt packages for the system
#   interpreter /usr/bin/python3 if they are missing (as root, or through sudo),
#   create .venv with --system-site-packages and pip-install the project in
#   editable mode with its extras.
#
# OpenBLAS replaces Debian's reference BLAS (through update-alternatives): MUMPS's
# factorisations are several times faster with it.
#
# Prints the interpreter to use as its last line. When everything is in place it
# returns in a few seconds: the install happens once, recorded by a stamp file.
set -euo pipefail
cd "$(dirname "$0")/.."

APT_PACKAGES="python3-dolfinx python3-gmsh python3-mpi4py python3-petsc4py python3-venv
python3-matplotlib python3-h5py python3-meshio python3-tqdm python3-pytest
openmpi-bin build-essential python3-dev libopenblas0-pthread"
EXTRAS="${NITSCHE_EXTRAS:-test,plot}"
log() { echo "[setup] $*" >&2; }

stamp_ok() {  # $1 = stamp file: newer than pyproject.toml?
  [ -f "$1" ] && [ "$1" -nt pyproject.toml ]
}

pip_install() {  # $1 = python, $2 = stamp file
  local py=$1 stamp=$2 constraints
  stamp_ok "$stamp" && return 0
  # Never let pip replace the numpy that dolfinx was compiled against.
  constraints=$(mktemp)
  "$py" -c 'import numpy; print(f"numpy=={numpy.__version__}")' > "$constraints"
  log "installing nitsche-dolfinx[$EXTRAS] (editable) for $py"
  if ! "$py" -m pip install --quiet --disable-pip-version-check -c "$constraints" -e ".[$EXTRAS]" >&2; then
    log "full extras failed; retrying with the test extra only (figures needing pyvista are skipped)"
    "$py" -m pip install --quiet --disable-pip-version-check -c "$constraints" -e ".[test]" >&2
  fi
  rm -f "$constraints"
  touch "$stamp"
}

# 1. An interpreter that already has dolfinx (conda, docker) and no venv of ours.
if [ ! -x .venv/bin/python ] && command -v python3 >/dev/null \
   && python3 -c "import dolfinx" 2>/dev/null && [ "$(command -v python3)" != /usr/bin/python3 ]; then
  py=$(command -v python3)
  pip_install "$py" ".setup-stamp"
  echo "$py"
  exit 0
fi

# 2. Debian/Ubuntu: the system interpreter with the FEniCSx packages.
if ! /usr/bin/python3 -c "import dolfinx, gmsh, petsc4py, mpi4py, matplotlib, h5py" 2>/dev/null \
   || ! command -v mpirun >/dev/null || ! /usr/bin/python3 -c "import ensurepip" 2>/dev/null \
   || ! ls /usr/lib/*/openblas*/libblas.so.3 \
        >/dev/null 2>&1; then
  SUDO=""
  [ "$(id -u)" -eq 0 ] || SUDO=sudo
  if ! command -v apt-get >/dev/null; then
    log "dolfinx is not importable and this is not a Debian/Ubuntu system: see README.md (conda or docker)"
    exit 1
  fi
  log "installing the FEniCSx packages with apt-get (about a minute)"
  $SUDO apt-get update -qq >&2
  # shellcheck disable=SC2086
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends $APT_PACKAGES >&2
fi

if [ ! -x .venv/bin/python ]; then
  log "creating .venv (system site packages visible)"
  /usr/bin/python3 -m venv --system-site-packages .venv >&2
fi
pip_install .venv/bin/python .venv/.setup-stamp
echo "$PWD/.venv/bin/python"
