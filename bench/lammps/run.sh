#!/usr/bin/env bash
# Times peridyn against LAMMPS' PERI package on the same plate, one core each, best of N runs
# (wall seconds). Needs `lmp` (Debian: apt-get install lammps) and a release build of peridyn.
#   bench/lammps/run.sh [N]
set -euo pipefail
cd "$(dirname "$0")"
n=${1:-3}
peridyn=../../target/release/peridyn
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
best() { # best wall time of n runs of the command
  local t b=
  for _ in $(seq "$n"); do
    /usr/bin/time -f %e -o "$out/time" "$@" >/dev/null 2>&1
    t=$(tail -1 "$out/time")
    if [ -z "$b" ] || awk "BEGIN{exit !($t < $b)}"; then b=$t; fi
  done
  echo "$b"
}
for model in pmb lps; do
  p=$(best "$peridyn" run "$model.toml" -o "$out/$model" --threads 1 --quiet)
  l=$(best lmp -in "$model.in" -log none -screen none)
  echo "$model: peridyn ${p} s, LAMMPS peri/$model ${l} s, ratio $(awk "BEGIN{printf \"%.2f\", $l / $p}")x"
done
