#!/usr/bin/env bash
# Entry point for newcomers and CI.
#
#   ./run.sh                         run the default scene (configs/six_dof.yaml)
#   ./run.sh test                    run the test suite (serial and mpiexec -n 2)
#   ./run.sh [-n N] SCENE.yaml [--set key.path=value ...] [PETSc options]
#   ./run.sh sweep SCENE.yaml --ratios 1,2,5 [-n 2]
#   ./run.sh plot RESULT.h5           plot probes vs reference, error, energies
#   ./run.sh plan SCENE.yaml          predicted cost of uniform steps, levels, mass scaling
#   ./run.sh bench [--all]           run the benchmark scripts (--all: the slow ones too)
#   ./run.sh keys [--markdown]       every scene key with type, default and meaning
#   ./run.sh schemes                 integrators and coupling schemes, stability limits
#   ./run.sh install                 only install (then .venv/bin/mts-solver works anywhere)
#   ./run.sh --help                  this list
#
# Every form first installs what is missing (idempotent): Debian's MPICH and
# OpenBLAS, then a virtual environment with PETSc, petsc4py and mpi4py built
# against that MPICH (requirements-petsc.txt), plus the pinned wheels of
# requirements.txt, and the checkout itself (pip install --no-deps -e .).
# A petsc4py + mpi4py already importable by python3 is reused.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
# the user's working directory is kept: scene paths given here are theirs, and
# paths inside a scene are relative to the scene file
VENV="${MTS_VENV:-$here/.venv}"
PY="$VENV/bin/python"

log() { echo "[run.sh] $*" >&2; }

case "${1:-}" in
  -h|--help|help) sed -n '3,14p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
esac

# -n N first: a rank count that is not a whole number >= 1 is refused before anything runs
nproc_arg=()
if [ "${1:-}" = "-n" ] || [ "${1:-}" = "-np" ]; then
  if ! [[ "${2:-}" =~ ^[1-9][0-9]*$ ]]; then
    echo "error: ${1} needs a whole number of ranks >= 1, got '${2:-}'" >&2; exit 4
  fi
  nproc_arg=(-n "$2"); shift 2
fi

ensure_system() {
  # System MPI (MPICH) and BLAS/LAPACK; compilers are needed to build PETSc.
  if command -v mpicc.mpich >/dev/null 2>&1 && [ -e /usr/lib/x86_64-linux-gnu/libopenblas.so ]; then
    return
  fi
  if [ "$(id -u)" != 0 ]; then
    log "MPICH/OpenBLAS missing and not root: install mpich libmpich-dev libopenblas-dev"; exit 1
  fi
  log "installing MPICH and OpenBLAS with apt-get"
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq
  apt-get install -y -qq --no-install-recommends mpich libmpich-dev libopenblas-dev liblapack-dev \
      build-essential gfortran pkg-config python3-venv >/dev/null
}

petsc_ok() {
  # A petsc4py and an mpi4py that import and initialise.
  "$1" -c 'from petsc4py import PETSc; from mpi4py import MPI' >/dev/null 2>&1
}

python_ok() {
  petsc_ok "$1" && "$1" -c 'import numpy, scipy, numba, h5py, yaml, matplotlib, meshio, pytest, xdist' >/dev/null 2>&1
}

ensure_python() {
  local stamp="$VENV/.requirements.sha"
  local want; want="$(cat "$here/requirements.txt" "$here/requirements-petsc.txt" | sha256sum | cut -d' ' -f1)"
  # the stamp is written only after the imports were checked: trust it (no imports here)
  if [ -x "$PY" ] && [ -f "$stamp" ] && [ "$(cat "$stamp")" = "$want" ]; then
    return
  fi
  local t0=$SECONDS
  if [ ! -x "$PY" ] && petsc_ok "$(command -v python3)"; then
    # A working petsc4py + mpi4py is used as it is: the venv sees it, pip adds the rest.
    log "using the petsc4py and mpi4py already importable by python3"
    python3 -m venv --system-site-packages "$VENV"
    "$PY" -m pip install -q -r "$here/requirements.txt"
  else
    ensure_system
    [ -x "$PY" ] || { log "creating virtual environment $VENV"; python3 -m venv "$VENV"; }
    log "installing Python packages (PETSc builds from source the first time: ~18 min)"
    "$PY" -m pip install -q --upgrade pip setuptools wheel
    "$PY" -m pip install -q "$(grep -E '^numpy==' "$here/requirements.txt")" cython
    if ! petsc_ok "$PY"; then
      # PETSc against Debian's MPICH and OpenBLAS, optimised, no downloads.
      export PETSC_CONFIGURE_OPTIONS="--with-debugging=0 --with-blaslapack-lib=-lopenblas --with-fc=0 --with-x=0 COPTFLAGS=-O2 CXXOPTFLAGS=-O2"
      MPICC=mpicc.mpich MPICXX=mpicxx.mpich "$PY" -m pip install -q --no-binary mpi4py,petsc,petsc4py \
        -r "$here/requirements-petsc.txt"
    fi
    "$PY" -m pip install -q -r "$here/requirements.txt"
  fi
  python_ok "$PY" || { log "installation finished but petsc4py/mpi4py or the wheels do not import"; exit 1; }
  rm -f "$VENV/.mpiexec"
  echo "$want" > "$stamp"
  log "Python environment ready in $((SECONDS - t0)) s"
}

mpiexec_for() {
  # The launcher of the MPI library mpi4py actually uses, whatever the system's
  # mpiexec alternative points to (installing an OpenMPI-based package switches it).
  local lib; lib="$("$PY" -c 'from mpi4py import MPI; print(MPI.Get_library_version())' 2>/dev/null)"
  case "$lib" in
    *MPICH*) command -v mpiexec.mpich || command -v mpiexec.hydra || command -v mpiexec ;;
    *"Open MPI"*) command -v mpiexec.openmpi || command -v mpiexec ;;
    *) command -v mpiexec ;;
  esac
}

ensure_package() {
  # The checkout as an editable install (no dependencies, offline): `mts-solver`
  # and `import solver` then work from any folder with this venv. The stamp
  # (checkout path + pyproject.toml) makes a second run free of pip.
  local stamp="$VENV/.package.sha"
  local want; want="$( (echo "$here"; cat "$here/pyproject.toml") | sha256sum | cut -d' ' -f1)"
  if [ -x "$VENV/bin/mts-solver" ] && [ -f "$stamp" ] && [ "$(cat "$stamp")" = "$want" ]; then
    return
  fi
  "$PY" -c 'import setuptools' >/dev/null 2>&1 || "$PY" -m pip install -q "setuptools>=68"
  log "installing the checkout into $VENV (pip install -e $here)"
  "$PY" -m pip install -q --no-deps --no-build-isolation --no-index -e "$here" >/dev/null 2>&1 \
    || { log "pip install --no-deps --no-build-isolation -e $here failed"; exit 1; }
  echo "$want" > "$stamp"
}

ensure_python
# the project's own .venv gets the checkout installed on every form; another
# environment (MTS_VENV) only on `./run.sh install` (PYTHONPATH serves the rest)
if [ "${1:-}" = "install" ] || [ "$VENV" = "$here/.venv" ]; then
  ensure_package
fi
# the launcher, found once per environment (asking mpi4py costs a Python start)
if [ -s "$VENV/.mpiexec" ] && [ -x "$(cat "$VENV/.mpiexec")" ]; then
  MPIEXEC="$(cat "$VENV/.mpiexec")"
else
  MPIEXEC="$(mpiexec_for)"
  echo "$MPIEXEC" > "$VENV/.mpiexec"
fi
export MTS_MPIEXEC="$MPIEXEC"
export MPLBACKEND=Agg
export OPENBLAS_NUM_THREADS="${OPENBLAS_NUM_THREADS:-1}"   # one BLAS thread per MPI rank
export PYTHONPATH="$here${PYTHONPATH:+:$PYTHONPATH}"


case "${1:-}" in
  test)
    shift
    cd "$here"                                     # the suite runs in the project
    # two workers, each taking whole test files (module fixtures run once);
    # MTS_TEST_WORKERS=0 runs in this process, as plain pytest does.  Without a
    # path pytest collects its testpaths (pyproject.toml: tests); with one, just it
    exec "$PY" -m pytest -q -n "${MTS_TEST_WORKERS:-2}" --dist loadfile "$@"
    ;;
  sweep)
    shift
    exec "$PY" -m solver.tools.sweep "${nproc_arg[@]}" "$@"
    ;;
  plot)
    shift
    exec "$PY" -m solver.tools.plot "$@"
    ;;
  plan)
    shift
    exec "$PY" -m solver.tools.plan "$@"
    ;;
  bench)
    shift
    cd "$here"
    exec "$PY" benchmarks/run_all.py "$@"
    ;;
  install)
    log "environment ready: $PY, $MPIEXEC, $VENV/bin/mts-solver"
    ;;
  "")
    exec "$PY" -m solver "$here/configs/six_dof.yaml"
    ;;
  *)
    if [ ${#nproc_arg[@]} -gt 0 ]; then
      exec "$MPIEXEC" "${nproc_arg[@]}" "$PY" -m solver "$@"
    fi
    exec "$PY" -m solver "$@"
    ;;
esac
