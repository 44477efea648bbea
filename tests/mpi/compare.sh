#!/usr/bin/env bash
# Runs each deck (by default every deck in tests/mpi) in one process and on 2 and 3 ranks
# (mpirun), and compares every output file of the distributed runs with the single-process
# run's, byte for byte (summary.txt without its wall-time lines). Needs the MPI program
# (`peridyn-mpi`):
#   cargo build --release -p peridyn-mpi && tests/mpi/compare.sh [DECK...]
# As root, Open MPI needs OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1.
set -euo pipefail
cd "$(dirname "$0")/../.."
bin=${PERIDYN:-target/release/peridyn-mpi}
ranks=${RANKS:-"2 3"}
if [ $# -eq 0 ]; then
  set -- tests/mpi/*.toml
fi
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
. tests/mpi/same_files.sh
failed=0
for deck in "$@"; do
  name=$(basename "$deck" .toml)
  "$bin" run "$deck" -o "$out/$name/1" --quiet --threads 1 >/dev/null
  for n in $ranks; do
    mpirun -np "$n" --oversubscribe "$bin" run "$deck" -o "$out/$name/$n" --quiet --threads 1 >/dev/null
    same_files "$out/$name/1" "$out/$name/$n" "$name on $n ranks" || failed=1
  done
done
exit $failed
