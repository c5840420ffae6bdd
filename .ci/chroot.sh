#!/usr/bin/env bash
# Build (once) and use a Debian chroot with a given suite's dolfinx.
#
#   .ci/chroot.sh build SUITE        create or reuse $CACHE/SUITE
#   .ci/chroot.sh run SUITE CMD...   run CMD inside it, in the repository (bound at /work-PID)
#
# The chroots live in a cache folder outside the repository
# (NITSCHE_CI_CACHE, default /var/cache/nitsche-dolfinx-ci) and are reused
# when present. The mirror is the one the host's apt sources already use.
set -euo pipefail

CACHE=${NITSCHE_CI_CACHE:-/var/cache/nitsche-dolfinx-ci}
PACKAGES="python3-dolfinx-real python3-gmsh python3-mpi4py python3-petsc4py python3-pytest
python3-h5py python3-matplotlib build-essential python3-dev libopenblas0-pthread"
REPO=$(cd "$(dirname "$0")/.." && pwd)

mirror() {
  local uri
  uri=$(grep -rhoE '^(URIs:|deb) *https?://[^ ]+' /etc/apt/sources.list /etc/apt/sources.list.d/ 2>/dev/null \
        | grep -v -e security -e nodesource -e google | head -n 1 | awk '{print $2}')
  echo "${uri:-http://deb.debian.org/debian}"
}

# The system mounts stay while the chroot is in use by any run (several runs may share
# it); each run binds the repository at a mount point of its own, /work-PID.
mount_system() {
  local dir=$1
  for fs in proc sys dev dev/pts; do
    mkdir -p "$dir/$fs"
    mountpoint -q "$dir/$fs" || mount --bind "/$fs" "$dir/$fs"
  done
}

umount_all() {  # every mount below the chroot: before deleting or updating it
  local dir=$1 point
  for point in $(grep -o " $dir/[^ ]*" /proc/mounts | sort -r); do
    umount -l "$point" || true
  done
}

build() {
  local suite=$1 dir=$CACHE/$1
  if [ -f "$dir/.ready" ]; then
    # a cached chroot gets the packages added to the list since it was built
    [ "$(cat "$dir/.ready")" = "$(echo $PACKAGES)" ] && return 0
    mount_system "$dir"
    chroot "$dir" /bin/bash -c "DEBIAN_FRONTEND=noninteractive apt-get install -y -qq \
      --no-install-recommends $(echo $PACKAGES) openmpi-bin" >> "$CACHE/$suite.log" 2>&1
    local status=$?
    [ $status -eq 0 ] && echo $PACKAGES > "$dir/.ready"
    return $status
  fi
  command -v debootstrap >/dev/null || { apt-get update -qq; apt-get install -y -qq debootstrap; }
  umount_all "$dir"  # never delete through a bind mount of /dev or /sys
  rm -rf --one-file-system "$dir"; mkdir -p "$CACHE"
  local keyring=()
  [ "$suite" = sid ] && keyring=(--no-check-gpg)
  debootstrap --variant=minbase "${keyring[@]}" "$suite" "$dir" "$(mirror)" > "$CACHE/$suite.log" 2>&1 \
    || { tail -n 20 "$CACHE/$suite.log"; return 1; }
  cp /etc/resolv.conf "$dir/etc/resolv.conf" 2>/dev/null || true
  mount_system "$dir"
  chroot "$dir" /bin/bash -c "
    export DEBIAN_FRONTEND=noninteractive
    apt-get -o Acquire::Check-Valid-Until=false update -qq &&
    apt-get install -y -qq --no-install-recommends $(echo $PACKAGES) openmpi-bin" >> "$CACHE/$suite.log" 2>&1 \
    || { tail -n 20 "$CACHE/$suite.log"; return 1; }
  echo $PACKAGES > "$dir/.ready"
}

run() {
  local suite=$1; shift
  local dir=$CACHE/$suite work=/work-$$
  mount_system "$dir"
  mkdir -p "$dir$work"
  mount --bind "$REPO" "$dir$work"
  # EXIT, not RETURN: under set -e a failing command leaves the script without returning
  trap "umount -l '$dir$work'; rmdir '$dir$work'" EXIT
  chroot "$dir" /usr/bin/env -i PATH=/usr/local/bin:/usr/bin:/bin HOME=/root LANG=C.UTF-8 \
    OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_rmaps_base_oversubscribe=1 \
    OPENBLAS_NUM_THREADS=1 \
    PYTHONPATH=$work CI="${CI:-}" MPLBACKEND=Agg /bin/bash -c "cd $work && $*"
}

cmd=${1:?usage: chroot.sh build|run SUITE [CMD...]}; shift
"$cmd" "$@"
