"""Writes gmsh_plate.msh, the mesh of examples/gmsh_plate.toml, as Gmsh would save it
(format 4.1 ASCII): a 24 mm x 12 mm plate in 1 mm elements, its left half quadrangles
(physical surface 1 "pmma"), its right half triangles (physical surface 2 "stiff"), with the
physical curves "bottom" (y = 0) and "top" (y = 12 mm). Coordinates in metres.

    python3 examples/gmsh_plate.py
"""

from pathlib import Path

H = 1e-3  # element size (m)
NX, NY = 24, 12
HALF = NX // 2


def node(i, j):
    return j * (NX + 1) + i + 1


def main():
    nodes = [(node(i, j), i * H, j * H) for j in range(NY + 1) for i in range(NX + 1)]
    quads, tris = [], []
    for j in range(NY):
        for i in range(NX):
            a, b, c, d = node(i, j), node(i + 1, j), node(i + 1, j + 1), node(i, j + 1)
            if i < HALF:
                quads.append((a, b, c, d))
            else:
                tris += [(a, b, c), (a, c, d)]
    bottom = [(node(i, 0), node(i + 1, 0)) for i in range(NX)]
    top = [(node(i + 1, NY), node(i, NY)) for i in range(NX)]
    # Element blocks: (entity dim, entity tag, Gmsh type, connectivities).
    blocks = [(1, 1, 1, bottom), (1, 3, 1, top), (2, 1, 3, quads), (2, 2, 2, tris)]
    w, d = NX * H, NY * H
    out = [
        "$MeshFormat", "4.1 0 8", "$EndMeshFormat",
        "$PhysicalNames", "4",
        '1 3 "bottom"', '1 4 "top"', '2 1 "pmma"', '2 2 "stiff"',
        "$EndPhysicalNames",
        "$Entities", "0 4 2 0",
        f"1 0 0 0 {w} 0 0 1 3 0",
        f"2 {w} 0 0 {w} {d} 0 0 0",
        f"3 0 {d} 0 {w} {d} 0 1 4 0",
        f"4 0 0 0 0 {d} 0 0 0",
        f"1 0 0 0 {w / 2} {d} 0 1 1 0",
        f"2 {w / 2} 0 0 {w} {d} 0 1 2 0",
        "$EndEntities",
        "$Nodes", f"1 {len(nodes)} 1 {len(nodes)}", f"2 1 0 {len(nodes)}",
    ]
    out += [str(t) for t, _, _ in nodes]
    out += [f"{x:.6g} {y:.6g} 0" for _, x, y in nodes]
    out.append("$EndNodes")
    count = sum(len(b[3]) for b in blocks)
    out += ["$Elements", f"{len(blocks)} {count} 1 {count}"]
    tag = 1
    for dim, entity, kind, elements in blocks:
        out.append(f"{dim} {entity} {kind} {len(elements)}")
        for e in elements:
            out.append(" ".join(map(str, (tag,) + e)))
            tag += 1
    out.append("$EndElements")
    Path(__file__).with_name("gmsh_plate.msh").write_text("\n".join(out) + "\n")


if __name__ == "__main__":
    main()
