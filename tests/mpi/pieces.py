#!/usr/bin/env python3
"""Compares a run written in pieces (`[output] pieces = "per_rank"`) with the same run written
whole, bit for bit: `pieces.py WHOLE_DIR PIECES_DIR RANKS`.

Each snapshot `fields/step_N.vtu` of WHOLE_DIR must be `fields/step_N.pvtu` in PIECES_DIR,
naming RANKS pieces `step_N_piece_R.vtu` in rank order whose points and point arrays,
concatenated, are the whole file's byte for byte (each piece's cells its own vertices), with
the arrays the `.pvtu` declares. `fields.pvd` must be the whole run's with `.pvtu` for `.vtu`,
`resolved.toml` the whole run's plus the `pieces` line (past its first line, the deck's path),
and every other file identical (`summary.txt` without its wall-time lines) but `checkpoint.bin`,
which records the deck (pieces.sh compares it across rank counts). Standard library only. Exit status 1 on any
difference, naming it.
"""

import re
import struct
import sys
from pathlib import Path

ATTRIBUTE = re.compile(r'(\w+)="([^"]*)"')
MARKER = b'<AppendedData encoding="raw">'
# The lines of summary.txt that depend on the wall clock or the results folder.
TIMELY = ("finished ", "timers ", "results in ")


def tags(text, name):
    """The attributes of every `<name .../>` tag of an XML text, in order."""
    return [dict(ATTRIBUTE.findall(m)) for m in re.findall(r"<%s\b([^>]*)>" % name, text)]


def read_vtu(path):
    """A VTU file written by peridyn (raw appended data, UInt64 headers): its point count and,
    in file order, each array's (name, type, components) and payload bytes."""
    data = path.read_bytes()
    head_end = data.index(MARKER)
    header = data[:head_end].decode()
    base = data.index(b"_", head_end) + 1
    (piece,) = tags(header, "Piece")
    arrays = []
    for a in tags(header, "DataArray"):
        at = base + int(a["offset"])
        (size,) = struct.unpack_from("<Q", data, at)
        key = (a["Name"], a["type"], a["NumberOfComponents"])
        arrays.append((key, data[at + 8 : at + 8 + size]))
    return int(piece["NumberOfPoints"]), arrays


CELLS = {"connectivity", "offsets", "types"}


def own_cells(n, arrays):
    """Whether a piece's cells are its n points as vertices (connectivity 0..n, offsets
    1..n, type 1), as a whole file's are."""
    cells = {key[0]: payload for key, payload in arrays if key[0] in CELLS}
    iota = lambda start: struct.pack("<%dq" % n, *range(start, start + n))
    return (
        cells.get("connectivity") == iota(0)
        and cells.get("offsets") == iota(1)
        and cells.get("types") == bytes([1]) * n
    )


def compare_snapshot(whole_vtu, pvtu, ranks):
    """The differences between a whole snapshot and its pieces, as messages."""
    if not pvtu.exists():
        return ["%s: missing" % pvtu.name]
    text = pvtu.read_text()
    step = whole_vtu.stem
    sources = [p["Source"] for p in tags(text, "Piece")]
    expected = ["%s_piece_%d.vtu" % (step, r) for r in range(ranks)]
    if sources != expected:
        return ["%s: pieces %s, expected %s" % (pvtu.name, sources, expected)]
    n, whole = read_vtu(whole_vtu)
    fields = [(k, p) for k, p in whole if k[0] not in CELLS]
    declared = [(a["Name"], a["type"], a["NumberOfComponents"]) for a in tags(text, "PDataArray")]
    if sorted(declared) != sorted(k for k, _ in fields):
        return ["%s: declares %s, the whole file has %s" % (pvtu.name, declared, fields)]
    joined = {k: b"" for k, _ in fields}
    count = 0
    problems = []
    for source in sources:
        m, arrays = read_vtu(pvtu.parent / source)
        count += m
        if not own_cells(m, arrays):
            problems.append("%s: its cells are not its %d vertices" % (source, m))
        for k, payload in arrays:
            if k in joined:
                joined[k] += payload
    if count != n:
        problems.append("%s: %d points in its pieces, %d in the whole file" % (pvtu.name, count, n))
    for k, payload in fields:
        if joined[k] != payload:
            problems.append("%s: array %s differs" % (pvtu.name, k[0]))
    return problems


def files(folder):
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*") if p.is_file())


def main(whole, pieces, ranks):
    problems = []
    for vtu in sorted((whole / "fields").glob("step_*.vtu")):
        problems += compare_snapshot(vtu, pieces / "fields" / (vtu.stem + ".pvtu"), ranks)
    snapshots = len(list((whole / "fields").glob("step_*.vtu")))
    piece_files = {
        "fields/%s_piece_%d.vtu" % (v.stem, r) for v in (whole / "fields").glob("step_*.vtu") for r in range(ranks)
    }
    piece_files |= {"fields/%s.pvtu" % v.stem for v in (whole / "fields").glob("step_*.vtu")}
    rest = [f for f in files(whole) if not re.fullmatch(r"fields/step_\d+\.vtu", f)]
    if sorted(rest + list(piece_files)) != files(pieces):
        extra = set(files(pieces)) - set(rest) - piece_files
        missing = (set(rest) | piece_files) - set(files(pieces))
        problems.append("other files: %s more, %s missing" % (sorted(extra), sorted(missing)))
    for f in rest:
        a, b = whole / f, pieces / f
        if not b.exists():
            continue
        if f == "fields.pvd":
            same = a.read_text().replace('.vtu"', '.pvtu"') == b.read_text()
        elif f == "resolved.toml":
            # Past its first line (the deck's path), the whole run's plus the pieces line.
            deck = lambda text: text.split("\n", 1)[1]
            same = deck(a.read_text()) == deck(b.read_text()).replace('pieces = "per_rank"\n', "", 1)
        elif f == "checkpoint.bin":
            # It records the deck, which asks for pieces: pieces.sh compares it across ranks.
            continue
        elif f == "summary.txt":
            timeless = lambda p: [l for l in p.read_text().splitlines() if not l.startswith(TIMELY)]
            same = timeless(a) == timeless(b)
        else:
            same = a.read_bytes() == b.read_bytes()
        if not same:
            problems.append("%s differs" % f)
    for p in problems:
        print("  " + p)
    print(
        "%s: %d snapshots in %d pieces, %d other files: %s"
        % (pieces, snapshots, ranks, len(rest), "identical" if not problems else "%d differences" % len(problems))
    )
    return 1 if problems else 0


if __name__ == "__main__":
    if len(sys.argv) != 4:
        sys.exit(__doc__)
    sys.exit(main(Path(sys.argv[1]), Path(sys.argv[2]), int(sys.argv[3])))
