#!/usr/bin/env bash
# Snapshots in pieces (`[output] pieces = "per_rank"`): runs each deck whole in one process,
# then with pieces in one process and on 2 and 3 ranks, and checks with pieces.py that the
# pieces, concatenated in rank order, are the whole run's snapshots bit for bit and every other
# file is the whole run's (checkpoint.bin, which records the deck: the one-process run's with
# pieces). A deck may be followed by `[output]` settings for both runs, `DECK:key=value,...`.
# By default a 2D deck with maps (every snapshot's fields gathered for them) and a 3D one
# without maps, its snapshots at steps 134 and 268 (no other observer reads those: their fields
# are never gathered). Needs a
# the MPI program (`peridyn-mpi`):
#   cargo build --release -p peridyn-mpi && tests/mpi/pieces.sh [DECK[:key=value,...]...]
set -euo pipefail
cd "$(dirname "$0")/../.."
bin=${PERIDYN:-target/release/peridyn-mpi}
ranks=${RANKS:-"1 2 3"}
if [ $# -eq 0 ]; then
  set -- tests/mpi/lps_energy_notched.toml tests/mpi/pmb_plate_3d.toml:png=false,history_interval=7,snapshots=3
fi
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
# `with_output DECK SETTINGS COPY`: the deck with the `[output]` settings (key=value,...) in
# place of its own, written to COPY (same file name, so the same title).
with_output() {
  python3 - "$@" <<'PY'
import re, sys
deck, settings, copy = sys.argv[1:]
text = open(deck).read()
lines = [s.strip() for s in settings.split(",") if s.strip()]
for s in lines:
    text = re.sub(r"^%s\s*=.*\n" % re.escape(s.split("=")[0].strip()), "", text, flags=re.M)
block = "".join(s.split("=", 1)[0].strip() + " = " + s.split("=", 1)[1].strip() + "\n" for s in lines)
if re.search(r"^\[output\]\s*$", text, re.M):
    text = re.sub(r"^\[output\]\s*\n", lambda m: "[output]\n" + block, text, count=1, flags=re.M)
else:
    text += "\n[output]\n" + block
open(copy, "w").write(text)
PY
}
failed=0
for arg in "$@"; do
  deck=${arg%%:*}
  settings=$([ "$arg" = "$deck" ] && echo "" || echo "${arg#*:}")
  name=$(basename "$deck" .toml)
  mkdir -p "$out/whole_deck" "$out/pieces_deck"
  with_output "$deck" "$settings" "$out/whole_deck/$name.toml"
  with_output "$deck" "$settings,pieces=\"per_rank\"" "$out/pieces_deck/$name.toml"
  "$bin" run "$out/whole_deck/$name.toml" -o "$out/$name/whole" --quiet --threads 1 >/dev/null
  for n in $ranks; do
    mpirun -np "$n" --oversubscribe "$bin" run "$out/pieces_deck/$name.toml" -o "$out/$name/$n" --quiet --threads 1 >/dev/null
    python3 tests/mpi/pieces.py "$out/$name/whole" "$out/$name/$n" "$n" || failed=1
    if [ -f "$out/$name/1/checkpoint.bin" ] && ! cmp -s "$out/$name/1/checkpoint.bin" "$out/$name/$n/checkpoint.bin"; then
      echo "  checkpoint.bin differs from the one-process run's with pieces"
      failed=1
    fi
  done
done
exit $failed
