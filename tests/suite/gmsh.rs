//! Gmsh mesh import: small meshes written here in the three formats read (4.1 ASCII, 4.1
//! binary, 2.2 ASCII) give the nodes, measures, blocks and node sets they describe; a deck runs
//! on one; every malformed file is refused with its own message.

use peridyn::deck::build::build_model;
use peridyn::deck::LoadedDeck;
use peridyn::discretize::gmsh::{parse_gmsh, GmshMesh};
use peridyn::run::{run, RunOptions};
use std::path::PathBuf;

/// A mesh as Gmsh models it: entities with physical tags, nodes, elements by entity.
#[derive(Clone)]
struct Mesh {
    /// (dimension, physical tag, name).
    names: Vec<(i32, i32, &'static str)>,
    /// (dimension, entity tag, physical tags).
    entities: Vec<(i32, i32, Vec<i32>)>,
    /// (tag, coordinates).
    nodes: Vec<(u64, [f64; 3])>,
    /// (entity dimension, entity tag, element type, element tag, node tags).
    elements: Vec<(i32, i32, i32, u64, Vec<u64>)>,
}

#[derive(Clone, Copy, Debug)]
enum Format {
    Ascii41,
    Binary41,
    Ascii22,
}

const FORMATS: [Format; 3] = [Format::Ascii41, Format::Binary41, Format::Ascii22];

/// (entity dim, entity tag, type) and its (element tag, node tags).
type Block = ((i32, i32, i32), Vec<(u64, Vec<u64>)>);

/// Element blocks: runs of elements with the same (entity dim, entity tag, type).
fn blocks(m: &Mesh) -> Vec<Block> {
    let mut out: Vec<Block> = Vec::new();
    for (d, t, ty, tag, nodes) in &m.elements {
        let key = (*d, *t, *ty);
        match out.last_mut() {
            Some((k, list)) if *k == key => list.push((*tag, nodes.clone())),
            _ => out.push((key, vec![(*tag, nodes.clone())])),
        }
    }
    out
}

fn names_section(m: &Mesh) -> String {
    if m.names.is_empty() {
        return String::new();
    }
    let mut s = format!("$PhysicalNames\n{}\n", m.names.len());
    for (d, t, n) in &m.names {
        s += &format!("{d} {t} \"{n}\"\n");
    }
    s + "$EndPhysicalNames\n"
}

fn entity_counts(m: &Mesh) -> [usize; 4] {
    let mut c = [0; 4];
    for e in &m.entities {
        c[e.0 as usize] += 1;
    }
    c
}

fn sorted_entities(m: &Mesh) -> Vec<(i32, i32, Vec<i32>)> {
    let mut e = m.entities.clone();
    e.sort_by_key(|e| e.0);
    e
}

fn write(m: &Mesh, f: Format) -> Vec<u8> {
    match f {
        Format::Ascii41 => write_ascii41(m).into_bytes(),
        Format::Binary41 => write_binary41(m),
        Format::Ascii22 => write_ascii22(m).into_bytes(),
    }
}

fn write_ascii41(m: &Mesh) -> String {
    let mut s = String::from("$MeshFormat\n4.1 0 8\n$EndMeshFormat\n");
    s += &names_section(m);
    let c = entity_counts(m);
    s += &format!("$Entities\n{} {} {} {}\n", c[0], c[1], c[2], c[3]);
    for (d, t, phys) in sorted_entities(m) {
        let coords = if d == 0 { "0 0 0" } else { "0 0 0 1 1 1" };
        let p: String = phys.iter().map(|p| format!(" {p}")).collect();
        let bound = if d == 0 { "" } else { " 0" };
        s += &format!("{t} {coords} {}{p}{bound}\n", phys.len());
    }
    s += "$EndEntities\n";
    let n = m.nodes.len();
    let (lo, hi) = (
        m.nodes.iter().map(|n| n.0).min().unwrap(),
        m.nodes.iter().map(|n| n.0).max().unwrap(),
    );
    s += &format!("$Nodes\n1 {n} {lo} {hi}\n2 1 0 {n}\n");
    for (t, _) in &m.nodes {
        s += &format!("{t}\n");
    }
    for (_, x) in &m.nodes {
        s += &format!("{} {} {}\n", x[0], x[1], x[2]);
    }
    s += "$EndNodes\n";
    let b = blocks(m);
    let (lo, hi) = (
        m.elements.iter().map(|e| e.3).min().unwrap(),
        m.elements.iter().map(|e| e.3).max().unwrap(),
    );
    s += &format!("$Elements\n{} {} {lo} {hi}\n", b.len(), m.elements.len());
    for ((d, t, ty), list) in &b {
        s += &format!("{d} {t} {ty} {}\n", list.len());
        for (tag, nodes) in list {
            let ns: String = nodes.iter().map(|n| format!(" {n}")).collect();
            s += &format!("{tag}{ns}\n");
        }
    }
    s + "$EndElements\n"
}

fn write_binary41(m: &Mesh) -> Vec<u8> {
    let mut b: Vec<u8> = b"$MeshFormat\n4.1 1 8\n".to_vec();
    b.extend(1i32.to_le_bytes());
    b.extend(b"\n$EndMeshFormat\n");
    b.extend(names_section(m).as_bytes());
    let int = |b: &mut Vec<u8>, v: i32| b.extend(v.to_le_bytes());
    let size = |b: &mut Vec<u8>, v: u64| b.extend(v.to_le_bytes());
    let float = |b: &mut Vec<u8>, v: f64| b.extend(v.to_le_bytes());
    b.extend(b"$Entities\n");
    for c in entity_counts(m) {
        size(&mut b, c as u64);
    }
    for (d, t, phys) in sorted_entities(m) {
        int(&mut b, t);
        for _ in 0..if d == 0 { 3 } else { 6 } {
            float(&mut b, 0.0);
        }
        size(&mut b, phys.len() as u64);
        for p in phys {
            int(&mut b, p);
        }
        if d > 0 {
            size(&mut b, 0);
        }
    }
    b.extend(b"\n$EndEntities\n$Nodes\n");
    let n = m.nodes.len() as u64;
    size(&mut b, 1);
    size(&mut b, n);
    size(&mut b, m.nodes.iter().map(|n| n.0).min().unwrap());
    size(&mut b, m.nodes.iter().map(|n| n.0).max().unwrap());
    int(&mut b, 2);
    int(&mut b, 1);
    int(&mut b, 0);
    size(&mut b, n);
    for (t, _) in &m.nodes {
        size(&mut b, *t);
    }
    for (_, x) in &m.nodes {
        for c in x {
            float(&mut b, *c);
        }
    }
    b.extend(b"\n$EndNodes\n$Elements\n");
    let bl = blocks(m);
    size(&mut b, bl.len() as u64);
    size(&mut b, m.elements.len() as u64);
    size(&mut b, m.elements.iter().map(|e| e.3).min().unwrap());
    size(&mut b, m.elements.iter().map(|e| e.3).max().unwrap());
    for ((d, t, ty), list) in &bl {
        int(&mut b, *d);
        int(&mut b, *t);
        int(&mut b, *ty);
        size(&mut b, list.len() as u64);
        for (tag, nodes) in list {
            size(&mut b, *tag);
            for n in nodes {
                size(&mut b, *n);
            }
        }
    }
    b.extend(b"\n$EndElements\n");
    b
}

/// Version 2.2 repeats an element once per physical group, as Gmsh does.
fn write_ascii22(m: &Mesh) -> String {
    let mut s = String::from("$MeshFormat\n2.2 0 8\n$EndMeshFormat\n");
    s += &names_section(m);
    s += &format!("$Nodes\n{}\n", m.nodes.len());
    for (t, x) in &m.nodes {
        s += &format!("{t} {} {} {}\n", x[0], x[1], x[2]);
    }
    s += "$EndNodes\n";
    let mut lines = Vec::new();
    for (d, t, ty, tag, nodes) in &m.elements {
        let phys = m
            .entities
            .iter()
            .find(|e| e.0 == *d && e.1 == *t)
            .map(|e| e.2.clone())
            .unwrap_or_default();
        let ns: String = nodes.iter().map(|n| format!(" {n}")).collect();
        if phys.is_empty() {
            lines.push(format!("{tag} {ty} 2 0 {t}{ns}"));
        }
        for p in phys {
            lines.push(format!("{tag} {ty} 2 {p} {t}{ns}"));
        }
    }
    s += &format!("$Elements\n{}\n", lines.len());
    for l in lines {
        s += &l;
        s += "\n";
    }
    s + "$EndElements\n"
}

fn parse(m: &Mesh, f: Format, dim: usize) -> GmshMesh {
    parse_gmsh(&write(m, f), dim, "m.msh").unwrap_or_else(|e| panic!("{f:?}: {e}"))
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-14 * b.abs().max(1.0)
}

fn close3(a: [f64; 3], b: [f64; 3]) -> bool {
    (0..3).all(|k| close(a[k], b[k]))
}

/// Index of the node at `centroid`.
fn at(g: &GmshMesh, centroid: [f64; 3]) -> u32 {
    g.positions
        .iter()
        .position(|&p| close3(p, centroid))
        .unwrap_or_else(|| panic!("no node at {centroid:?} in {:?}", g.positions)) as u32
}

/// The unit square as two counter-clockwise triangles, in physical surface 7 "plate".
fn unit_square() -> Mesh {
    Mesh {
        names: vec![(2, 7, "plate")],
        entities: vec![(2, 1, vec![7])],
        nodes: vec![
            (1, [0.0, 0.0, 0.0]),
            (2, [1.0, 0.0, 0.0]),
            (3, [1.0, 1.0, 0.0]),
            (4, [0.0, 1.0, 0.0]),
        ],
        elements: vec![(2, 1, 2, 1, vec![1, 2, 3]), (2, 1, 2, 2, vec![1, 3, 4])],
    }
}

/// [0, 2]² as 2×2 quadrangles: the left column in physical surface 1 "soft", the right one
/// in surface 2 (unnamed); boundary curve "left" (x = 0) and point "corner" at (2, 0).
fn quad_mesh() -> Mesh {
    let mut nodes = Vec::new();
    for j in 0..3 {
        for i in 0..3 {
            nodes.push(((j * 3 + i + 1) as u64, [i as f64, j as f64, 0.0]));
        }
    }
    let q = |i: u64, j: u64| {
        let n = |i: u64, j: u64| j * 3 + i + 1;
        vec![n(i, j), n(i + 1, j), n(i + 1, j + 1), n(i, j + 1)]
    };
    Mesh {
        names: vec![(2, 1, "soft"), (1, 10, "left"), (0, 20, "corner")],
        entities: vec![
            (2, 1, vec![1]),
            (2, 2, vec![2]),
            (1, 5, vec![10]),
            (1, 6, vec![]),
            (0, 3, vec![20]),
        ],
        nodes,
        elements: vec![
            (0, 3, 15, 100, vec![3]),
            (1, 5, 1, 101, vec![1, 4]),
            (1, 5, 1, 102, vec![4, 7]),
            (1, 6, 1, 103, vec![7, 8]),
            (2, 1, 3, 1, q(0, 0)),
            (2, 1, 3, 2, q(0, 1)),
            (2, 2, 3, 3, q(1, 0)),
            (2, 2, 3, 4, q(1, 1)),
        ],
    }
}

/// Corners of the unit cube in Gmsh's hexahedron order, offset by `x0` along x.
fn cube_nodes(first: u64, x0: f64) -> Vec<(u64, [f64; 3])> {
    let c = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
        [1.0, 0.0, 1.0],
        [1.0, 1.0, 1.0],
        [0.0, 1.0, 1.0],
    ];
    c.iter()
        .enumerate()
        .map(|(k, p)| (first + k as u64, [p[0] + x0, p[1], p[2]]))
        .collect()
}

/// The unit cube as six tetrahedra around the diagonal 1–7, in volume group 3 "cube", with
/// the bottom face (z = 0) as boundary group "bottom".
fn tet_cube() -> Mesh {
    let t = |a: u64, b: u64, c: u64, d: u64| vec![a, b, c, d];
    Mesh {
        names: vec![(3, 3, "cube"), (2, 4, "bottom")],
        entities: vec![(3, 1, vec![3]), (2, 1, vec![4])],
        nodes: cube_nodes(1, 0.0),
        elements: vec![
            (2, 1, 2, 20, vec![1, 3, 2]),
            (2, 1, 2, 21, vec![1, 4, 3]),
            (3, 1, 4, 1, t(1, 2, 3, 7)),
            (3, 1, 4, 2, t(1, 3, 4, 7)),
            (3, 1, 4, 3, t(1, 4, 8, 7)),
            (3, 1, 4, 4, t(1, 8, 5, 7)),
            (3, 1, 4, 5, t(1, 5, 6, 7)),
            (3, 1, 4, 6, t(1, 6, 2, 7)),
        ],
    }
}

/// Two unit hexahedra along x, in volume groups 1 and 2, with the face x = 0 as "left".
fn hex_pair() -> Mesh {
    let mut nodes = cube_nodes(1, 0.0);
    // The second cube shares the face x = 1 (nodes 2, 3, 6, 7).
    let far = cube_nodes(9, 1.0);
    nodes.extend([far[1], far[2], far[5], far[6]]);
    Mesh {
        names: vec![(2, 5, "left"), (3, 2, "right_block")],
        entities: vec![(3, 1, vec![1]), (3, 2, vec![2]), (2, 1, vec![5])],
        nodes,
        elements: vec![
            (3, 1, 5, 1, vec![1, 2, 3, 4, 5, 6, 7, 8]),
            (3, 2, 5, 2, vec![2, 10, 11, 3, 6, 14, 15, 7]),
            (2, 1, 3, 3, vec![1, 4, 8, 5]),
        ],
    }
}

#[test]
fn unit_square_of_two_triangles() {
    for f in FORMATS {
        let g = parse(&unit_square(), f, 2);
        assert_eq!(g.len(), 2, "{f:?}");
        assert!(close3(g.positions[0], [2.0 / 3.0, 1.0 / 3.0, 0.0]), "{f:?}");
        assert!(close3(g.positions[1], [1.0 / 3.0, 2.0 / 3.0, 0.0]), "{f:?}");
        assert_eq!(g.measures, vec![0.5, 0.5], "{f:?}");
        assert_eq!(g.measures.iter().sum::<f64>(), 1.0);
        assert_eq!(g.blocks, vec![7, 7], "{f:?}");
        assert_eq!(g.elements, vec![1, 2], "{f:?}");
        assert_eq!(g.node_sets["plate"], vec![0, 1], "{f:?}");
    }
}

#[test]
fn clockwise_surface_is_accepted_with_positive_areas() {
    let mut m = unit_square();
    for e in &mut m.elements {
        e.4.reverse();
    }
    let g = parse(&m, Format::Ascii41, 2);
    assert_eq!(g.measures, vec![0.5, 0.5]);
    assert!(close3(g.positions[0], [2.0 / 3.0, 1.0 / 3.0, 0.0]));
}

#[test]
fn quad_mesh_blocks_and_boundary_sets() {
    for f in FORMATS {
        let g = parse(&quad_mesh(), f, 2);
        assert_eq!(g.len(), 4, "{f:?}");
        assert_eq!(g.measures, vec![1.0; 4], "{f:?}");
        let (a, b, c, d) = (
            at(&g, [0.5, 0.5, 0.0]),
            at(&g, [0.5, 1.5, 0.0]),
            at(&g, [1.5, 0.5, 0.0]),
            at(&g, [1.5, 1.5, 0.0]),
        );
        let block = |i: u32| g.blocks[i as usize];
        assert_eq!([block(a), block(b), block(c), block(d)], [1, 1, 2, 2]);
        let mut left = vec![a, b];
        left.sort();
        assert_eq!(g.node_sets["left"], left, "{f:?}");
        assert_eq!(g.node_sets["soft"], left, "{f:?}");
        assert_eq!(g.node_sets["corner"], vec![c], "{f:?}");
        assert_eq!(g.node_sets.len(), 3, "unnamed groups are no sets: {f:?}");
    }
}

#[test]
fn non_convex_quadrangle_is_exact() {
    // A dart: (0,0), (2,0), (1,0.5) reflex... ordered (0,0) (2,0) (2,2) (1.5,0.5): area 1.5.
    let m = Mesh {
        names: vec![],
        entities: vec![],
        nodes: vec![
            (1, [0.0, 0.0, 0.0]),
            (2, [2.0, 0.0, 0.0]),
            (3, [2.0, 2.0, 0.0]),
            (4, [1.5, 0.5, 0.0]),
        ],
        elements: vec![(2, 1, 3, 1, vec![1, 2, 3, 4])],
    };
    for f in FORMATS {
        let g = parse(&m, f, 2);
        // Shoelace: ½|0·0−2·0 + 2·2−2·0 + 2·0.5−1.5·2 + 1.5·0−0·0.5| = ½·2 = 1.
        assert!(close(g.measures[0], 1.0), "{f:?}: {}", g.measures[0]);
        assert_eq!(g.blocks, vec![0], "no physical group: block 0");
        // Centroid from the two triangles (1,2,3) of area 2 and (1,3,4) of area −1.
        let c = [
            (2.0 * (4.0 / 3.0) - (3.5 / 3.0)) / 1.0,
            (2.0 * (2.0 / 3.0) - (2.5 / 3.0)) / 1.0,
            0.0,
        ];
        assert!(close3(g.positions[0], c), "{f:?}: {:?}", g.positions[0]);
    }
}

#[test]
fn cube_of_tetrahedra() {
    for f in FORMATS {
        let g = parse(&tet_cube(), f, 3);
        assert_eq!(g.len(), 6, "{f:?}");
        for v in &g.measures {
            assert!(close(*v, 1.0 / 6.0), "{f:?}: {v}");
        }
        assert!(close(g.measures.iter().sum::<f64>(), 1.0), "{f:?}");
        // Tetrahedron (1, 2, 3, 7): corners (0,0,0), (1,0,0), (1,1,0), (1,1,1).
        assert!(close3(g.positions[0], [0.75, 0.5, 0.25]), "{f:?}");
        assert_eq!(g.blocks, vec![3; 6], "{f:?}");
        assert_eq!(g.node_sets["cube"], (0..6).collect::<Vec<u32>>());
        // Every tetrahedron holds corner 1, on the bottom face.
        assert_eq!(g.node_sets["bottom"], (0..6).collect::<Vec<u32>>());
    }
}

#[test]
fn hexahedra_blocks_and_face_set() {
    for f in FORMATS {
        let g = parse(&hex_pair(), f, 3);
        assert_eq!(g.len(), 2, "{f:?}");
        assert_eq!(g.measures, vec![1.0, 1.0], "{f:?}");
        assert!(close3(g.positions[0], [0.5, 0.5, 0.5]), "{f:?}");
        assert!(close3(g.positions[1], [1.5, 0.5, 0.5]), "{f:?}");
        assert_eq!(g.blocks, vec![1, 2], "{f:?}");
        assert_eq!(g.node_sets["left"], vec![0], "{f:?}");
        assert_eq!(g.node_sets["right_block"], vec![1], "{f:?}");
    }
}

#[test]
fn stretched_hexahedron_volume() {
    let mut m = hex_pair();
    m.elements.truncate(1);
    for n in &mut m.nodes {
        n.1 = [2.0 * n.1[0], n.1[1], 3.0 * n.1[2] + n.1[0]];
    }
    let g = parse(&m, Format::Binary41, 3);
    assert!(close(g.measures[0], 6.0), "{}", g.measures[0]);
    assert!(
        close3(g.positions[0], [1.0, 0.5, 2.0]),
        "{:?}",
        g.positions[0]
    );
}

#[test]
fn unknown_sections_are_skipped_and_crlf_is_read() {
    let text = write_ascii41(&unit_square())
        .replace("$Nodes", "$Comments\nanything $Nodes\n$EndComments\n$Nodes")
        .replace('\n', "\r\n");
    let g = parse_gmsh(text.as_bytes(), 2, "m.msh").unwrap();
    assert_eq!(g.len(), 2);
}

/// Parses `bytes` and returns the error message.
fn err(bytes: &[u8], dim: usize) -> String {
    match parse_gmsh(bytes, dim, "m.msh") {
        Ok(g) => panic!("expected an error, got {g:?}"),
        Err(e) => e.to_string(),
    }
}

/// 1-based line of the first line of `text` containing `needle`.
fn line_of(text: &str, needle: &str) -> usize {
    text.lines()
        .position(|l| l.contains(needle))
        .unwrap_or_else(|| panic!("{needle:?} not in {text}"))
        + 1
}

#[test]
fn error_missing_mesh_format() {
    let text = write_ascii41(&unit_square()).replace("$MeshFormat\n4.1 0 8\n$EndMeshFormat\n", "");
    assert_eq!(
        err(text.as_bytes(), 2),
        "m.msh:1: expected $MeshFormat, the first line of a Gmsh mesh, found \"$PhysicalNames\""
    );
    assert_eq!(
        err(b"\n  \n", 2),
        "m.msh: empty file; expected a Gmsh mesh starting with $MeshFormat"
    );
}

#[test]
fn error_unsupported_version() {
    let text = write_ascii41(&unit_square()).replace("4.1 0 8", "4.0 0 8");
    assert_eq!(
        err(text.as_bytes(), 2),
        "m.msh:2: unsupported Gmsh format version \"4.0\"; expected 4.1 or 2.2 (in Gmsh: Mesh.MshFileVersion = 4.1)"
    );
    let text = write_ascii22(&unit_square()).replace("2.2 0 8", "2.2 1 8");
    assert_eq!(
        err(text.as_bytes(), 2),
        "m.msh: byte 20: binary version 2.2 is not supported; expected version 4.1 (ASCII or binary) or 2.2 ASCII"
    );
}

#[test]
fn error_big_endian() {
    let mut b = write_binary41(&unit_square());
    b[20..24].copy_from_slice(&1i32.to_be_bytes());
    assert_eq!(
        err(&b, 2),
        "m.msh: byte 20: the mesh is big-endian binary; only little-endian binary meshes are read (re-export it on a little-endian machine or as ASCII)"
    );
}

#[test]
fn error_missing_nodes_or_elements() {
    let text = write_ascii22(&unit_square());
    let nodes = text.find("$Nodes").unwrap();
    let elements = text.find("$Elements").unwrap();
    let no_nodes = format!("{}{}", &text[..nodes], &text[elements..]);
    assert_eq!(
        err(no_nodes.as_bytes(), 2),
        "m.msh: no $Nodes section; expected the mesh nodes (export the mesh, not only the geometry)"
    );
    assert_eq!(
        err(&text.as_bytes()[..elements], 2),
        "m.msh: no $Elements section; expected the mesh elements"
    );
}

#[test]
fn error_undefined_node() {
    let mut m = unit_square();
    m.elements[1].4 = vec![1, 3, 99];
    let text = write_ascii41(&m);
    let line = line_of(&text, "2 1 3 99");
    assert_eq!(
        err(text.as_bytes(), 2),
        format!("m.msh:{line}: element 2 (3-node triangle) refers to node 99, which $Nodes does not define")
    );
    let text = write_ascii22(&m);
    let line = line_of(&text, "1 3 99");
    assert_eq!(
        err(text.as_bytes(), 2),
        format!("m.msh:{line}: element 2 (3-node triangle) refers to node 99, which $Nodes does not define")
    );
}

#[test]
fn error_truncated() {
    let text = write_ascii41(&unit_square());
    let cut = text.find("1 1 0\n").unwrap();
    assert_eq!(
        err(&text.as_bytes()[..cut], 2),
        format!(
            "m.msh:{}: the file ends inside $Nodes (truncated?); expected the x coordinate of node 3",
            line_of(&text, "1 1 0")
        )
    );
    let text = write_ascii41(&unit_square());
    let cut = text.find("$EndElements").unwrap();
    assert_eq!(
        err(&text.as_bytes()[..cut], 2),
        format!(
            "m.msh:{}: the file ends inside $Elements (truncated?); expected $EndElements",
            line_of(&text, "$EndElements")
        )
    );
    let b = write_binary41(&unit_square());
    let start = b.windows(7).position(|w| w == b"$Nodes\n").unwrap() + 7;
    // Header (4 size_t), block header (3 int + size_t), 4 tags: the coordinates start here.
    let coords = start + 32 + 20 + 32;
    let cut = coords + 2 * 24 + 8 + 3;
    assert_eq!(
        err(&b[..cut], 2),
        format!("m.msh: byte {}: the file ends inside $Nodes (truncated?): the y coordinate of node 3 needs 8 bytes, 3 left", cut - 3)
    );
}

#[test]
fn error_not_a_number() {
    let text = write_ascii41(&unit_square()).replace("\n1 0 0\n", "\n1 zero 0\n");
    assert_eq!(
        err(text.as_bytes(), 2),
        format!(
            "m.msh:{}: expected the y coordinate of node 2 (a finite number), found \"zero\"",
            line_of(&text, "1 zero 0")
        )
    );
    let text = write_ascii22(&unit_square()).replace("$Nodes\n4\n", "$Nodes\nfour\n");
    assert_eq!(
        err(text.as_bytes(), 2),
        "m.msh:9: expected the number of nodes (a non-negative integer), found \"four\""
    );
}

#[test]
fn error_section_not_closed() {
    let text = write_ascii22(&unit_square()).replace("$EndNodes", "$EndNode");
    assert_eq!(
        err(text.as_bytes(), 2),
        format!(
            "m.msh:{}: expected $EndNodes, found \"$EndNode\"",
            line_of(&text, "$EndNode")
        )
    );
}

#[test]
fn error_higher_order_and_unsupported_types() {
    let mut m = unit_square();
    m.elements = vec![(2, 1, 9, 1, vec![1, 2, 3, 1, 2, 3])];
    let text = write_ascii41(&m);
    assert_eq!(
        err(text.as_bytes(), 2),
        format!("m.msh:{}: element type 9 (6-node second-order triangle) is not supported; expected first-order triangles (type 2) or quadrangles (type 3) for a 2D body (in Gmsh: Mesh.ElementOrder = 1)", line_of(&text, "2 1 9 1"))
    );
    let mut m = tet_cube();
    m.elements.push((3, 1, 6, 9, vec![1, 2, 3, 5, 6, 7]));
    let text = write_ascii22(&m);
    assert_eq!(
        err(text.as_bytes(), 3),
        format!("m.msh:{}: element type 6 (6-node prism) is not supported; expected first-order tetrahedra (type 4) or hexahedra (type 5) for a 3D body (in Gmsh: Mesh.ElementOrder = 1, and no prisms or pyramids)", line_of(&text, "9 6 2"))
    );
    // A 3D mesh read for a 2D body.
    let text = write_ascii22(&tet_cube());
    assert_eq!(
        err(text.as_bytes(), 2),
        format!("m.msh:{}: element type 4 (4-node tetrahedron) is 3D, but the body is 2D; expected first-order triangles (type 2) or quadrangles (type 3) for a 2D body", line_of(&text, "1 4 2"))
    );
    // A 2D mesh read for a 3D body has no body elements.
    assert_eq!(
        err(write_ascii41(&unit_square()).as_bytes(), 3),
        "m.msh: no elements of the body's dimension; expected first-order tetrahedra (type 4) or hexahedra (type 5) for a 3D body"
    );
    let text = write_ascii41(&unit_square()).replace("2 1 2 2", "2 1 77 2");
    assert_eq!(
        err(text.as_bytes(), 2),
        format!(
            "m.msh:{}: unknown Gmsh element type 77",
            line_of(&text, "2 1 77 2")
        )
    );
}

#[test]
fn error_degenerate_and_inverted() {
    let mut m = unit_square();
    m.elements[1].4 = vec![1, 3, 3];
    let text = write_ascii41(&m);
    assert_eq!(
        err(text.as_bytes(), 2),
        format!("m.msh:{}: element 2 (triangle) is degenerate (zero area); nodes 1 (0, 0, 0), 3 (1, 1, 0), 3 (1, 1, 0)", line_of(&text, "2 1 3 3"))
    );
    let mut m = quad_mesh();
    m.elements[7].4.reverse();
    let text = write_ascii41(&m);
    assert_eq!(
        err(text.as_bytes(), 2),
        format!("m.msh:{}: element 4 (quadrangle) is inverted: its orientation is opposite to the other elements of its surface; nodes 8 (1, 2, 0), 9 (2, 2, 0), 6 (2, 1, 0), 5 (1, 1, 0). Gmsh writes consistent orientations, so the file is probably broken", line_of(&text, "4 8 9 6 5"))
    );
    let mut m = tet_cube();
    m.elements[2].4 = vec![2, 1, 3, 7];
    let b = write_binary41(&m);
    let e = err(&b, 3);
    assert!(
        e.starts_with("m.msh: byte ")
            && e.ends_with(": element 1 (tetrahedron) is inverted (volume -1.6666666666666666e-1 m³ < 0); nodes 2 (1, 0, 0), 1 (0, 0, 0), 3 (1, 1, 0), 7 (1, 1, 1). Gmsh writes positive volumes, so the file is probably broken"),
        "{e}"
    );
}

#[test]
fn error_2d_mesh_not_flat() {
    let mut m = unit_square();
    m.nodes[3].1[2] = 0.1;
    let text = write_ascii22(&m);
    assert_eq!(
        err(text.as_bytes(), 2),
        format!("m.msh:{}: node 4 of element 2 has z = 0.1, other nodes z = 0; a 2D body must lie in a plane z = constant", line_of(&text, "2 2 2 7 1 1 3 4"))
    );
    // A plate at constant z ≠ 0 is fine; its nodes are at z = 0.
    for n in &mut m.nodes {
        n.1[2] = 0.5;
    }
    let g = parse(&m, Format::Ascii22, 2);
    assert_eq!(g.positions[0][2], 0.0);
}

#[test]
fn error_missing_file() {
    let e = peridyn::discretize::gmsh::read_gmsh(std::path::Path::new("/nonexistent/m.msh"), 2)
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with("/nonexistent/m.msh: cannot read Gmsh mesh:"),
        "{e}"
    );
}

/// A 20 mm × 10 mm plate of 20 × 10 quadrangles (physical surface 1), clamped edge "left"
/// (x = 0) and pulled edge "right".
fn plate() -> Mesh {
    let (nx, ny, h) = (20u64, 10u64, 1e-3);
    let node = |i: u64, j: u64| j * (nx + 1) + i + 1;
    let mut m = Mesh {
        names: vec![(2, 1, "plate"), (1, 2, "left"), (1, 3, "right")],
        entities: vec![(2, 1, vec![1]), (1, 1, vec![2]), (1, 2, vec![3])],
        nodes: vec![],
        elements: vec![],
    };
    for j in 0..=ny {
        for i in 0..=nx {
            m.nodes
                .push((node(i, j), [i as f64 * h, j as f64 * h, 0.0]));
        }
    }
    let mut tag = 1;
    for j in 0..ny {
        for i in 0..nx {
            m.elements.push((
                2,
                1,
                3,
                tag,
                vec![
                    node(i, j),
                    node(i + 1, j),
                    node(i + 1, j + 1),
                    node(i, j + 1),
                ],
            ));
            tag += 1;
        }
    }
    for j in 0..ny {
        m.elements
            .push((1, 1, 1, tag, vec![node(0, j), node(0, j + 1)]));
        tag += 1;
        m.elements
            .push((1, 2, 1, tag, vec![node(nx, j), node(nx, j + 1)]));
        tag += 1;
    }
    m
}

const PLATE_DECK: &str = r#"
version = 2
dimension = 2
plane = "stress"
thickness = 1e-3
[discretization]
type = "gmsh"
file = "plate.msh"
horizon = 3e-3
[material]
type = "pmb"
density = 1000.0
youngs_modulus = 1e9
[[blocks]]
id = 1
[[boundary_conditions]]
set = "left"
kind = "velocity"
component = "x"
value = 0.0
[[boundary_conditions]]
set = "right"
kind = "velocity"
component = "x"
value = 0.1
[solver]
type = "explicit"
steps = 20
[output]
snapshots = 0
png = false
"#;

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("peridyn-gmsh-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

#[test]
fn deck_runs_on_a_mesh_in_every_format() {
    for f in FORMATS {
        let dir = temp_dir(&format!("{f:?}"));
        std::fs::write(dir.join("plate.msh"), write(&plate(), f)).unwrap();
        let ld = LoadedDeck::from_str(PLATE_DECK, &dir.join("deck.toml")).unwrap();
        let model = build_model::<2>(&ld).unwrap_or_else(|e| panic!("{f:?}: {e}"));
        assert_eq!(model.body.len(), 200);
        assert!((model.body.total_volume() - 2e-4 * 1e-3).abs() < 1e-20);
        assert!(model
            .body
            .cell_sizes
            .iter()
            .all(|&r| (r - 1e-3).abs() < 1e-15));
        assert!(model.body.blocks.iter().all(|&b| b == 1));
        // Node sets survive the body's reordering: "left" is the first column of elements.
        let left = &model.body.node_sets["left"];
        assert_eq!(left.len(), 10);
        assert!(left
            .iter()
            .all(|&i| (model.body.positions[i as usize][0] - 0.5e-3).abs() < 1e-15));
        assert_eq!(model.body.node_sets["right"].len(), 10);
        assert_eq!(model.body.node_sets["plate"].len(), 200);

        let out = dir.join("out");
        let summary = run(
            &ld,
            &RunOptions {
                out_dir: out.clone(),
                threads: Some(2),
                quiet: true,
            },
        )
        .unwrap_or_else(|e| panic!("{f:?}: {e}"));
        assert_eq!(summary.report.steps, 20);
        assert!(
            summary.external_work > 0.0,
            "{f:?}: the pulled edge does work"
        );
        assert!(summary.strain_energy > 0.0 && summary.kinetic_energy.is_finite());
        // resolved.toml refers to the mesh by an absolute path.
        let resolved = std::fs::read_to_string(out.join("resolved.toml")).unwrap();
        assert!(resolved.contains(
            &dir.join("plate.msh")
                .canonicalize()
                .unwrap()
                .display()
                .to_string()
        ));
        std::fs::remove_dir_all(&dir).ok();
    }
}

#[test]
fn deck_errors_with_mesh_sets() {
    let dir = temp_dir("errors");
    std::fs::write(dir.join("plate.msh"), write(&plate(), Format::Ascii41)).unwrap();
    let deck = dir.join("deck.toml");
    let build_err = |src: &str| match LoadedDeck::from_str(src, &deck) {
        Ok(ld) => match build_model::<2>(&ld) {
            Ok(_) => panic!("expected an error"),
            Err(e) => e.to_string(),
        },
        Err(e) => e.to_string(),
    };
    // An unknown set lists the deck's and the mesh's sets.
    let src = PLATE_DECK.replace("set = \"right\"", "set = \"rigth\"");
    let e = build_err(&src);
    assert!(
        e.contains("boundary_conditions[1].set: unknown node set \"rigth\"; defined sets (deck and mesh): all, left, plate, right"),
        "{e}"
    );
    // A deck set of a mesh group's name.
    let src = format!(
        "{PLATE_DECK}\n[[node_sets]]\nname = \"left\"\nregion = {{ type = \"rectangle\", min = [0.0, 0.0], max = [1e-3, 1e-2] }}\n"
    );
    let e = build_err(&src);
    assert!(
        e.contains("node_sets[0].name: node set \"left\" is also a named physical group of the mesh; rename one of them"),
        "{e}"
    );
    // A broken mesh is reported at discretization.file with the mesh's own location.
    std::fs::write(
        dir.join("plate.msh"),
        "$MeshFormat\n3.0 0 8\n$EndMeshFormat\n",
    )
    .unwrap();
    let e = build_err(PLATE_DECK);
    assert!(
        e.contains(&format!(
            "discretization.file: {}:2: unsupported Gmsh format version \"3.0\"",
            dir.join("plate.msh").display()
        )),
        "{e}"
    );
    std::fs::remove_dir_all(&dir).ok();
}
