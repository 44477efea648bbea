# Sourced by compare.sh and restart.sh: `same_files REFERENCE OTHER LABEL` compares every file
# of two results folders byte for byte (summary.txt without its wall-time lines), prints
# "LABEL: N files identical, M differ" (or that the folders hold other files), and returns 1
# unless all are identical.

# The lines of summary.txt that depend on the wall clock (or the results folder), and those
# matching $ALSO_UNCOMPARED when the caller sets it.
timeless() { grep -v -e '^finished ' -e '^timers ' -e '^results in ' ${ALSO_UNCOMPARED:+-e "$ALSO_UNCOMPARED"} "$1"; }

same_files() {
  local reference=$1 other=$2 label=$3 files f ok same=0 differ=0
  files=$(cd "$reference" && find . -type f | sort)
  if [ "$files" != "$(cd "$other" && find . -type f | sort)" ]; then
    echo "$label: other files than the reference"
    return 1
  fi
  for f in $files; do
    if [ "$f" = ./summary.txt ]; then
      cmp -s <(timeless "$reference/$f") <(timeless "$other/$f") && ok=1 || ok=0
    else
      cmp -s "$reference/$f" "$other/$f" && ok=1 || ok=0
    fi
    if [ $ok = 1 ]; then same=$((same + 1)); else differ=$((differ + 1)); echo "  differs: $f"; fi
  done
  echo "$label: $same files identical, $differ differ"
  [ $differ = 0 ]
}
