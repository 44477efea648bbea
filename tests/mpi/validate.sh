#!/usr/bin/env bash
# A validation case over ranks (`mpirun -np N peridyn-mpi validate`, each run one model over the
# N ranks): runs the case (by default tests/mpi/validate/seed002/tiny.toml, reduced) in one
# process, then on 2 and 3 ranks, and compares the measurement (measured.toml without its wall
# times), runs.csv and each run's history.csv byte for byte; then starts it again on 2 ranks,
# which must find every run finished and run none. Needs the MPI program (`peridyn-mpi`):
#   cargo build --release -p peridyn-mpi && tests/mpi/validate.sh [CASE...]
set -euo pipefail
cd "$(dirname "$0")/../.."
bin=${PERIDYN:-target/release/peridyn-mpi}
ranks=${RANKS:-"2 3"}
if [ $# -eq 0 ]; then
  set -- tests/mpi/validate/seed002/tiny.toml
fi
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
failed=0
# `same_case REFERENCE OTHER LABEL`: the measurement (wall times left out), runs.csv and the runs'
# histories identical.
same_case() {
  local f ok=1
  for f in runs.csv $(cd "$1" && ls runs/run_*/history.csv); do
    if ! cmp -s "$1/$f" "$2/$f"; then
      echo "  differs: $f"
      ok=0
    fi
  done
  if ! diff -q <(grep -v wall_minutes "$1/measured.toml") <(grep -v wall_minutes "$2/measured.toml") >/dev/null; then
    echo "  differs: measured.toml"
    ok=0
  fi
  if [ $ok = 1 ]; then echo "$3: measurement, runs.csv and histories identical"; else echo "$3: differ"; failed=1; fi
}
for case in "$@"; do
  name=$(basename "$(dirname "$case")")-$(basename "$case" .toml)   # its results folder
  "$bin" validate "$case" --reduced -o "$out/1" --quiet --threads 1 >/dev/null
  for n in $ranks; do
    mpirun -np "$n" --oversubscribe "$bin" validate "$case" --reduced -o "$out/$n" --quiet --threads 1 >/dev/null
    same_case "$out/1/$name" "$out/$n/$name" "$name on $n ranks"
  done
  # Started again: every run is found finished in runs.csv, none runs (their folders stay).
  touch "$out/2/$name/runs/run_0000/history.csv" -d "2000-01-01"
  mpirun -np 2 --oversubscribe "$bin" validate "$case" --reduced -o "$out/2" --quiet --threads 1 >/dev/null
  if [ "$(date -r "$out/2/$name/runs/run_0000/history.csv" +%Y)" != 2000 ]; then
    echo "$name started again on 2 ranks: a finished run ran again"
    failed=1
  fi
done
exit $failed
