# common.sh — what every MPI test script starts with (sourced, not run):
# the launcher, a work directory removed at exit, check(), and mpi() that
# runs kerf on N oversubscribed ranks.
#   usage: work_prefix=kerf_mpi_x; . "$tests/mpi/common.sh"
# The launcher: $KERF_MPIRUN (the build's MPI, set by ctest), else mpirun.
# Exits 77 (skipped) when it is missing.
mpirun=${KERF_MPIRUN:-mpirun}
command -v "$mpirun" > /dev/null || { echo "$mpirun not found: skipped"; exit 77; }
work=$(mktemp -d "/tmp/${work_prefix:-kerf_mpi}.XXXXXX")
trap 'rm -rf "$work"' EXIT
fails=0
check() { # check <description> <command...>
    local what=$1; shift
    if "$@"; then echo "ok    $what"; else echo "FAIL  $what"; fails=$((fails + 1)); fi
}
# as root, Open MPI needs to be told; more ranks than cores needs --oversubscribe
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_rmaps_base_oversubscribe=1
export OMP_NUM_THREADS=1 OMP_WAIT_POLICY=PASSIVE
# (MPICH's launcher runs any number of ranks as any user, and has no such flag)
over=()
"$mpirun" --version 2>&1 | grep -qE "Open MPI|OpenRTE" && over=(--oversubscribe)
mpi() { local n=$1; shift; "$mpirun" -np "$n" "${over[@]}" "$kerf" "$@"; }
