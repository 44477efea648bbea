#!/usr/bin/env bash
# A study across ranks (`mpirun -np N peridyn study`, each run on one rank): runs the study
# (by default tests/mpi/study/tiny_morris.toml) serially, then on 2 and 3 ranks, and compares
# runs.csv and morris.csv with the serial study's byte for byte; then continues on 3 ranks a
# copy of the serial study cut after its 2nd run (runs.csv as the serial study leaves it when
# stopped there) and compares again. Needs the MPI program (`peridyn-mpi`):
#   cargo build --release -p peridyn-mpi && tests/mpi/study.sh [STUDY...]
set -euo pipefail
cd "$(dirname "$0")/../.."
bin=${PERIDYN:-target/release/peridyn-mpi}
ranks=${RANKS:-"2 3"}
if [ $# -eq 0 ]; then
  set -- tests/mpi/study/tiny_morris.toml
fi
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
failed=0
# `same_tables REFERENCE OTHER LABEL`: runs.csv and morris.csv (if any) identical.
same_tables() {
  local f ok=1
  for f in runs.csv morris.csv; do
    if [ -f "$1/$f" ] && ! cmp -s "$1/$f" "$2/$f"; then
      echo "  differs: $f"
      ok=0
    fi
  done
  if [ $ok = 1 ]; then echo "$3: runs.csv and morris.csv identical"; else echo "$3: tables differ"; failed=1; fi
}
for study in "$@"; do
  name=$(basename "$study" .toml)
  "$bin" study "$study" -o "$out/$name/1" --quiet --threads 1 >/dev/null
  for n in $ranks; do
    mpirun -np "$n" --oversubscribe "$bin" study "$study" -o "$out/$name/$n" --quiet --threads 1 >/dev/null
    same_tables "$out/$name/1" "$out/$name/$n" "$name on $n ranks"
  done
  # The serial study stopped after its 2nd run: later rows without outputs or status.
  cp -r "$out/$name/1" "$out/$name/cut"
  python3 - "$study" "$out/$name/cut/runs.csv" <<'PY'
import sys, tomllib
study, path = sys.argv[1:]
outputs = len(tomllib.load(open(study, "rb"))["outputs"])
header, *rows = open(path).read().splitlines()
keep = len(header.split(",")) - outputs - 1  # run, trajectory, factors: before outputs, status
cut = [header] + [
    ",".join(r.split(",")[:keep] + [""] * (outputs + 1)) if k >= 2 else r for k, r in enumerate(rows)
]
open(path, "w").write("\n".join(cut) + "\n")
PY
  rm -f "$out/$name/cut/morris.csv"
  mpirun -np 3 --oversubscribe "$bin" study "$study" -o "$out/$name/cut" --quiet --threads 1 >/dev/null
  same_tables "$out/$name/1" "$out/$name/cut" "$name stopped after 2 runs, continued on 3 ranks"
done
exit $failed
