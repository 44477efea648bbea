#!/usr/bin/env bash
# Distributed restarts: each deck run whole in one process, then stopped on A ranks and
# continued from its checkpoint on B ranks (by default 2 → 3, 3 → 1 and 1 → 2), every file of
# the continued run compared byte for byte with the whole run's (summary.txt without its
# wall-time lines). The run stops halfway between its middle snapshot and the next, so it
# continues from the checkpoint of the middle one (in the decks below, with the crack running;
# under the adaptive time step, dt reduced; in the quasi-static run, its load increment split
# and its predictor's last point set; in the staged run, inside its explicit release stage;
# with impactors, the disk in contact and slowed; under the correspondence model's critical
# energy, bonds breaking: each node's previous position and matrices kept). Needs the MPI program (`peridyn-mpi`):
#   cargo build --release -p peridyn-mpi && tests/mpi/restart.sh [DECK...]
# As root, Open MPI needs OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1.
set -euo pipefail
cd "$(dirname "$0")/../.."
bin=${PERIDYN:-target/release/peridyn-mpi}
pairs=${PAIRS:-"2:3 3:1 1:2"}
if [ $# -eq 0 ]; then
  set -- tests/mpi/lps_energy_notched.toml tests/mpi/pmb_energy_adaptive.toml \
    tests/mpi/pmb_adr_notched.toml tests/mpi/pmb_staged_preload_release.toml \
    tests/mpi/pmb_impactors_crack_path.toml tests/mpi/correspondence_energy_notched.toml
fi
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
. tests/mpi/same_files.sh
# A continued run's summary names only the quasi-static stages that ended in its own process
# (the solver's note: masses and iterations), so those lines are left out too.
ALSO_UNCOMPARED='^note  *stage [^:]*: \(ADR\|NCG\)'
# `on N ARGS...`: peridyn run ARGS on N ranks (one process without mpirun for N = 1).
on() {
  local n=$1
  shift
  if [ "$n" = 1 ]; then
    "$bin" run "$@" --quiet --threads 1
  else
    mpirun -np "$n" --oversubscribe "$bin" run "$@" --quiet --threads 1
  fi >/dev/null
}
failed=0
for deck in "$@"; do
  name=$(basename "$deck" .toml)
  whole="$out/$name/whole"
  on 1 "$deck" -o "$whole"
  # The snapshots' steps, from the names of their files (step_00000150.vtu: 150), in order.
  steps=$(cd "$whole/fields" && ls step_*.vtu | sed 's/^step_\([0-9]*\)\.vtu$/\1/' | sort)
  count=$(echo "$steps" | wc -l)
  middle=$((10#$(echo "$steps" | sed -n "$((count / 2 + 1))p")))
  next=$((10#$(echo "$steps" | sed -n "$((count / 2 + 2))p")))
  stop=$(((middle + next) / 2))
  for pair in $pairs; do
    a=${pair%:*} b=${pair#*:}
    parts="$out/$name/$a-$b"
    if on "$a" "$deck" -o "$parts" --stop-after-step "$stop" 2>/dev/null; then
      echo "$name: the run on $a ranks did not stop after step $stop"
      failed=1
      continue
    fi
    on "$b" "$deck" -o "$parts" --restart
    same_files "$whole" "$parts" "$name stopped on $a ranks after step $stop, continued on $b" || failed=1
  done
done
exit $failed
