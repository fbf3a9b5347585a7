# The OpenMPI environment of the MPI tests, sourced by each of them after setting `exe`:
# root in containers and CI needs the two ALLOW variables; a container without a network
# still has loopback, so OpenMPI's TCP stays on it; containers often forbid cross-process
# memory access (CMA), so copies go through shared memory; ranks and threads share two busy
# cores in CI, so idle OpenMP threads sleep instead of spinning.
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
export OMPI_MCA_btl_tcp_if_include=lo OMPI_MCA_oob_tcp_if_include=lo
export OMPI_MCA_btl_vader_single_copy_mechanism=none
export OMP_WAIT_POLICY=PASSIVE
# mpi NP ARGS...: the grainbath under test on NP ranks
mpi() { local np=$1; shift; mpirun --oversubscribe --bind-to none -np "$np" "$exe" "$@"; }
# fresh_work_dir DIR: an empty work directory for the test (what a previous run left is removed)
fresh_work_dir() { rm -rf "$1"; mkdir -p "$1"; }
