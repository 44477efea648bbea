//! Import of Gmsh meshes (`.msh`): one peridynamic node per element of the body's dimension.
//!
//! # Formats
//!
//! - version 4.1, ASCII and binary (little-endian only: the endianness marker is checked and a
//!   big-endian file is refused),
//! - version 2.2, ASCII.
//!
//! Sections read: `$MeshFormat` (must come first), `$PhysicalNames`, `$Entities` (version 4:
//! the physical groups of each entity), `$Nodes`, `$Elements`. Other sections are skipped.
//!
//! # Elements
//!
//! Elements of the body's dimension (`dim`, 2 or 3) become nodes: first-order triangles (type
//! 2) and quadrangles (3) in 2D, tetrahedra (4) and hexahedra (5) in 3D. Each gives one node at
//! its centroid carrying its area (2D) or volume (3D); quadrangles are split into two triangles
//! and hexahedra into six tetrahedra, so the measure and the centroid are those of the split
//! (exact for planar faces, including non-convex quadrangles). Other element types of the
//! body's dimension (second order, prisms, pyramids) are refused, naming the type. Elements of
//! a lower dimension (points, lines; triangles and quadrangles in 3D) are boundary elements,
//! used only for node sets; elements of a higher dimension are refused.
//!
//! A degenerate element (zero measure) is refused. So is an inverted one: in 3D a negative
//! volume; in 2D an element whose orientation is opposite to the majority of its surface's
//! elements (a whole surface meshed clockwise is fine). In 2D every node of the body's
//! elements must have the same z.
//!
//! # Physical groups
//!
//! - The first physical group of the body's dimension an element belongs to is its block id
//!   (the physical tag); an element in no such group has block 0.
//! - Every **named** physical group becomes a node set: for a group of the body's dimension,
//!   the nodes of its elements; for a lower-dimensional group (e.g. a boundary curve), the
//!   nodes whose element shares at least one mesh vertex with an element of the group. Groups
//!   of the same name are merged.
//!
//! Errors name the source and the 1-based line (ASCII files) or the byte offset (binary
//! files), e.g. `plate.msh:12: expected a node tag (an integer), found "x"`.

use std::collections::{BTreeMap, BTreeSet, HashMap, HashSet};
use std::fmt;
use std::path::Path;
use thiserror::Error;

/// Nodes made from a Gmsh mesh; `positions`, `measures`, `blocks` and `elements` have the same
/// length.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct GmshMesh {
    /// Element centroids; `z = 0` in 2D.
    pub positions: Vec<[f64; 3]>,
    /// Element area (m², 2D) or volume (m³, 3D).
    pub measures: Vec<f64>,
    /// Physical tag of the element's physical group of the body's dimension, 0 if none.
    pub blocks: Vec<u32>,
    /// Gmsh tag of each element.
    pub elements: Vec<u64>,
    /// Named physical groups as sorted node indices.
    pub node_sets: BTreeMap<String, Vec<u32>>,
}

impl GmshMesh {
    /// Number of nodes (elements of the body's dimension).
    pub fn len(&self) -> usize {
        self.positions.len()
    }

    /// Whether the mesh has no nodes (never true for a successfully read file).
    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }
}

/// Where in the file a problem is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Location {
    /// 1-based line of an ASCII file.
    Line(usize),
    /// Byte offset in a binary file.
    Byte(usize),
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Location::Line(l) => write!(f, "{l}"),
            Location::Byte(b) => write!(f, " byte {b}"),
        }
    }
}

/// Why a Gmsh mesh could not be imported; messages are meant for people.
#[derive(Debug, Error)]
pub enum GmshError {
    /// The file could not be read.
    #[error("{path}: cannot read Gmsh mesh: {source}")]
    Io {
        path: String,
        #[source]
        source: std::io::Error,
    },
    /// A problem at a place in the file.
    #[error("{source_name}:{at}: {message}")]
    At {
        source_name: String,
        at: Location,
        message: String,
    },
    /// A problem with the file as a whole.
    #[error("{source_name}: {message}")]
    File {
        source_name: String,
        message: String,
    },
}

/// Reads the Gmsh mesh at `path` for a `dim`-dimensional body (2 or 3).
pub fn read_gmsh(path: &Path, dim: usize) -> Result<GmshMesh, GmshError> {
    let name = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|source| GmshError::Io {
        path: name.clone(),
        source,
    })?;
    parse_gmsh(&bytes, dim, &name)
}

/// Gmsh element types: (number, name, dimension, node count).
const ELEMENT_TYPES: &[(i32, &str, usize, usize)] = &[
    (1, "2-node line", 1, 2),
    (2, "3-node triangle", 2, 3),
    (3, "4-node quadrangle", 2, 4),
    (4, "4-node tetrahedron", 3, 4),
    (5, "8-node hexahedron", 3, 8),
    (6, "6-node prism", 3, 6),
    (7, "5-node pyramid", 3, 5),
    (8, "3-node second-order line", 1, 3),
    (9, "6-node second-order triangle", 2, 6),
    (10, "9-node second-order quadrangle", 2, 9),
    (11, "10-node second-order tetrahedron", 3, 10),
    (12, "27-node second-order hexahedron", 3, 27),
    (13, "18-node second-order prism", 3, 18),
    (14, "14-node second-order pyramid", 3, 14),
    (15, "1-node point", 0, 1),
    (16, "8-node second-order quadrangle", 2, 8),
    (17, "20-node second-order hexahedron", 3, 20),
    (18, "15-node second-order prism", 3, 15),
    (19, "13-node second-order pyramid", 3, 13),
    (20, "9-node third-order incomplete triangle", 2, 9),
    (21, "10-node third-order triangle", 2, 10),
    (22, "12-node fourth-order incomplete triangle", 2, 12),
    (23, "15-node fourth-order triangle", 2, 15),
    (24, "15-node fifth-order incomplete triangle", 2, 15),
    (25, "21-node fifth-order triangle", 2, 21),
    (26, "4-node third-order line", 1, 4),
    (27, "5-node fourth-order line", 1, 5),
    (28, "6-node fifth-order line", 1, 6),
    (29, "20-node third-order tetrahedron", 3, 20),
    (30, "35-node fourth-order tetrahedron", 3, 35),
    (31, "56-node fifth-order tetrahedron", 3, 56),
    (92, "64-node third-order hexahedron", 3, 64),
    (93, "125-node fourth-order hexahedron", 3, 125),
];

#[derive(Debug, Clone, Copy)]
struct ElementType {
    number: i32,
    name: &'static str,
    dim: usize,
    nodes: usize,
}

fn element_type(number: i32) -> Option<ElementType> {
    ELEMENT_TYPES
        .iter()
        .find(|t| t.0 == number)
        .map(|&(number, name, dim, nodes)| ElementType {
            number,
            name,
            dim,
            nodes,
        })
}

/// Short name of a supported body element.
fn short_name(number: i32) -> &'static str {
    match number {
        2 => "triangle",
        3 => "quadrangle",
        4 => "tetrahedron",
        _ => "hexahedron",
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Version {
    V2,
    V4,
}

/// One element as read, before its nodes are looked up.
struct RawElement {
    tag: u64,
    kind: ElementType,
    /// Range into `Raw::connectivity`.
    first: usize,
    at: Location,
    /// (entity dimension, entity tag): version 4 only.
    entity: (i32, i32),
    /// Version 2: the physical tag written with the element (0: none).
    physical: i32,
}

#[derive(Default)]
struct Raw {
    names: Vec<(i32, i32, String)>,
    /// (entity dimension, entity tag) → physical tags.
    entities: HashMap<(i32, i32), Vec<i32>>,
    node_index: HashMap<u64, usize>,
    coords: Vec<[f64; 3]>,
    elements: Vec<RawElement>,
    connectivity: Vec<u64>,
}

struct Reader<'a> {
    data: &'a [u8],
    pos: usize,
    line: usize,
    binary: bool,
    name: &'a str,
    section: &'static str,
}

impl<'a> Reader<'a> {
    fn at(&self) -> Location {
        if self.binary {
            Location::Byte(self.pos)
        } else {
            Location::Line(self.line)
        }
    }

    fn err(&self, at: Location, message: impl Into<String>) -> GmshError {
        GmshError::At {
            source_name: self.name.to_string(),
            at,
            message: message.into(),
        }
    }

    fn file_err(&self, message: impl Into<String>) -> GmshError {
        GmshError::File {
            source_name: self.name.to_string(),
            message: message.into(),
        }
    }

    fn truncated(&self, what: &str) -> GmshError {
        self.err(
            self.at(),
            format!(
                "the file ends inside {} (truncated?); expected {what}",
                self.section
            ),
        )
    }

    fn skip_ws(&mut self) {
        while let Some(&c) = self.data.get(self.pos) {
            if !c.is_ascii_whitespace() {
                break;
            }
            if c == b'\n' {
                self.line += 1;
            }
            self.pos += 1;
        }
    }

    /// The next whitespace-separated token, with its location.
    fn token(&mut self, what: &str) -> Result<(&'a [u8], Location), GmshError> {
        self.skip_ws();
        let at = self.at();
        let start = self.pos;
        while self
            .data
            .get(self.pos)
            .is_some_and(|c| !c.is_ascii_whitespace())
        {
            self.pos += 1;
        }
        if start == self.pos {
            return Err(self.truncated(what));
        }
        Ok((&self.data[start..self.pos], at))
    }

    fn parsed<T: std::str::FromStr>(&mut self, what: &str, kind: &str) -> Result<T, GmshError> {
        let (tok, at) = self.token(what)?;
        std::str::from_utf8(tok)
            .ok()
            .and_then(|s| s.parse::<T>().ok())
            .ok_or_else(|| {
                self.err(
                    at,
                    format!(
                        "expected {what} ({kind}), found {:?}",
                        String::from_utf8_lossy(tok)
                    ),
                )
            })
    }

    fn int(&mut self, what: &str) -> Result<i32, GmshError> {
        self.parsed(what, "an integer")
    }

    fn count(&mut self, what: &str) -> Result<u64, GmshError> {
        self.parsed(what, "a non-negative integer")
    }

    fn float(&mut self, what: &str) -> Result<f64, GmshError> {
        let (tok, at) = self.token(what)?;
        match std::str::from_utf8(tok)
            .ok()
            .and_then(|s| s.parse::<f64>().ok())
        {
            Some(v) if v.is_finite() => Ok(v),
            _ => Err(self.err(
                at,
                format!(
                    "expected {what} (a finite number), found {:?}",
                    String::from_utf8_lossy(tok)
                ),
            )),
        }
    }

    /// The rest of the current line (without the newline), trimmed; `None` at the end.
    fn line(&mut self) -> Option<(String, Location)> {
        if self.pos >= self.data.len() {
            return None;
        }
        let at = self.at();
        let start = self.pos;
        while self.data.get(self.pos).is_some_and(|&c| c != b'\n') {
            self.pos += 1;
        }
        let text = String::from_utf8_lossy(&self.data[start..self.pos])
            .trim()
            .to_string();
        if self.pos < self.data.len() {
            self.pos += 1;
            self.line += 1;
        }
        Some((text, at))
    }

    /// The next non-blank line.
    fn next_line(&mut self) -> Option<(String, Location)> {
        self.skip_ws();
        self.line()
    }

    /// Reads the line closing the current section.
    fn end(&mut self, end: &str) -> Result<(), GmshError> {
        match self.next_line() {
            Some((l, _)) if l == end => Ok(()),
            Some((l, at)) => Err(self.err(at, format!("expected {end}, found {:?}", shorten(&l)))),
            None => Err(self.truncated(end)),
        }
    }

    fn bytes<const N: usize>(&mut self, what: &str) -> Result<[u8; N], GmshError> {
        match self.data.get(self.pos..self.pos + N) {
            Some(b) => {
                self.pos += N;
                Ok(b.try_into().expect("N bytes"))
            }
            None => Err(self.err(
                self.at(),
                format!(
                    "the file ends inside {} (truncated?): {what} needs {N} bytes, {} left",
                    self.section,
                    self.data.len() - self.pos
                ),
            )),
        }
    }

    fn bin_int(&mut self, what: &str) -> Result<i32, GmshError> {
        Ok(i32::from_le_bytes(self.bytes::<4>(what)?))
    }

    fn bin_size(&mut self, what: &str) -> Result<u64, GmshError> {
        Ok(u64::from_le_bytes(self.bytes::<8>(what)?))
    }

    fn bin_float(&mut self, what: &str) -> Result<f64, GmshError> {
        let at = self.at();
        let v = f64::from_le_bytes(self.bytes::<8>(what)?);
        if v.is_finite() {
            Ok(v)
        } else {
            Err(self.err(at, format!("expected {what} (a finite number), found {v}")))
        }
    }

    /// An integer field: binary `int` or ASCII token.
    fn i(&mut self, what: &str) -> Result<i32, GmshError> {
        if self.binary {
            self.bin_int(what)
        } else {
            self.int(what)
        }
    }

    /// A count or tag: binary `size_t` or ASCII token.
    fn n(&mut self, what: &str) -> Result<u64, GmshError> {
        if self.binary {
            self.bin_size(what)
        } else {
            self.count(what)
        }
    }

    fn f(&mut self, what: &str) -> Result<f64, GmshError> {
        if self.binary {
            self.bin_float(what)
        } else {
            self.float(what)
        }
    }
}

fn shorten(s: &str) -> String {
    if s.chars().count() > 40 {
        format!("{}…", s.chars().take(40).collect::<String>())
    } else {
        s.to_string()
    }
}

/// A capacity that a corrupt count cannot blow up.
fn capacity(n: u64, data: &[u8]) -> usize {
    (n as usize).min(data.len() / 2)
}

/// Parses the Gmsh mesh in `bytes` for a `dim`-dimensional body (2 or 3); `source_name` is
/// used in error messages (usually the file name). See the [module documentation](self).
pub fn parse_gmsh(bytes: &[u8], dim: usize, source_name: &str) -> Result<GmshMesh, GmshError> {
    let mut r = Reader {
        data: bytes,
        pos: 0,
        line: 1,
        binary: false,
        name: source_name,
        section: "$MeshFormat",
    };
    if dim != 2 && dim != 3 {
        return Err(r.file_err(format!(
            "cannot read a Gmsh mesh for dimension {dim}; expected 2 or 3"
        )));
    }
    let version = read_format(&mut r)?;
    let mut raw = Raw::default();
    let (mut seen_nodes, mut seen_elements) = (false, false);
    while let Some((l, at)) = r.next_line() {
        match l.as_str() {
            "$PhysicalNames" => {
                r.section = "$PhysicalNames";
                read_physical_names(&mut r, &mut raw)?;
            }
            "$Entities" if version == Version::V4 => {
                r.section = "$Entities";
                read_entities(&mut r, &mut raw)?;
            }
            "$Nodes" => {
                r.section = "$Nodes";
                if version == Version::V4 {
                    read_nodes_v4(&mut r, &mut raw)?;
                } else {
                    read_nodes_v2(&mut r, &mut raw)?;
                }
                seen_nodes = true;
            }
            "$Elements" => {
                r.section = "$Elements";
                if version == Version::V4 {
                    read_elements_v4(&mut r, &mut raw, dim)?;
                } else {
                    read_elements_v2(&mut r, &mut raw, dim)?;
                }
                seen_elements = true;
            }
            "$MeshFormat" => return Err(r.err(at, "a second $MeshFormat section")),
            s if s.starts_with('$') && !s.starts_with("$End") => {
                skip_section(&mut r, s)?;
            }
            s => {
                return Err(r.err(
                    at,
                    format!(
                        "expected a section such as $Nodes or $Elements, found {:?}",
                        shorten(s)
                    ),
                ))
            }
        }
    }
    if !seen_nodes {
        return Err(r.file_err(
            "no $Nodes section; expected the mesh nodes (export the mesh, not only the geometry)",
        ));
    }
    if !seen_elements {
        return Err(r.file_err("no $Elements section; expected the mesh elements"));
    }
    assemble(&r, raw, dim, version)
}

fn read_format(r: &mut Reader) -> Result<Version, GmshError> {
    match r.next_line() {
        None => {
            return Err(r.file_err("empty file; expected a Gmsh mesh starting with $MeshFormat"))
        }
        Some((l, _)) if l == "$MeshFormat" => {}
        Some((l, at)) => {
            return Err(r.err(
                at,
                format!(
                    "expected $MeshFormat, the first line of a Gmsh mesh, found {:?}",
                    shorten(&l)
                ),
            ))
        }
    }
    let (tok, at) = r.token("the format version")?;
    let text = String::from_utf8_lossy(tok).to_string();
    let version = match text.as_str() {
        "4.1" => Version::V4,
        "2.2" => Version::V2,
        other => {
            return Err(r.err(
                at,
                format!("unsupported Gmsh format version {other:?}; expected 4.1 or 2.2 (in Gmsh: Mesh.MshFileVersion = 4.1)"),
            ))
        }
    };
    let file_type = r.int("the file type (0 for ASCII, 1 for binary)")?;
    let data_size = r.int("the data size")?;
    let binary = match file_type {
        0 => false,
        1 => true,
        t => {
            return Err(r.err(
                r.at(),
                format!("expected the file type 0 (ASCII) or 1 (binary), found {t}"),
            ))
        }
    };
    if binary {
        // Rest of the header line, then the endianness marker: the integer 1.
        r.line();
        r.binary = true;
        if version == Version::V2 {
            return Err(r.err(
                r.at(),
                "binary version 2.2 is not supported; expected version 4.1 (ASCII or binary) or 2.2 ASCII",
            ));
        }
        if data_size != 8 {
            return Err(r.err(
                r.at(),
                format!("expected the data size 8 (64-bit size_t), found {data_size}"),
            ));
        }
        let at = r.at();
        let marker = r.bytes::<4>("the endianness marker")?;
        if i32::from_le_bytes(marker) != 1 {
            let message = if i32::from_be_bytes(marker) == 1 {
                "the mesh is big-endian binary; only little-endian binary meshes are read (re-export it on a little-endian machine or as ASCII)".to_string()
            } else {
                format!("expected the endianness marker 1, found bytes {marker:02x?}")
            };
            return Err(r.err(at, message));
        }
    }
    r.end("$EndMeshFormat")?;
    Ok(version)
}

fn skip_section(r: &mut Reader, start: &str) -> Result<(), GmshError> {
    let end = format!("$End{}", &start[1..]);
    // Binary payloads are skipped byte-wise; the closing line starts a line.
    loop {
        match r.line() {
            Some((l, _)) if l == end => return Ok(()),
            Some(_) => {}
            None => {
                return Err(r.err(
                    r.at(),
                    format!("the file ends inside {start} (truncated?); expected {end}"),
                ))
            }
        }
    }
}

fn read_physical_names(r: &mut Reader, raw: &mut Raw) -> Result<(), GmshError> {
    let n = r.count("the number of physical names")?;
    r.line();
    for _ in 0..n {
        let Some((l, at)) = r.next_line() else {
            return Err(r.truncated("a physical name: dimension tag \"name\""));
        };
        let bad = || {
            r.err(
                at,
                format!(
                    "expected a physical name: dimension tag \"name\", found {:?}",
                    shorten(&l)
                ),
            )
        };
        let mut it = l.splitn(3, char::is_whitespace);
        let d = it
            .next()
            .and_then(|s| s.parse::<i32>().ok())
            .ok_or_else(bad)?;
        let t = it
            .next()
            .and_then(|s| s.parse::<i32>().ok())
            .ok_or_else(bad)?;
        let rest = it.next().ok_or_else(bad)?.trim();
        let name = rest
            .strip_prefix('"')
            .and_then(|s| s.strip_suffix('"'))
            .ok_or_else(bad)?;
        raw.names.push((d, t, name.to_string()));
    }
    r.end("$EndPhysicalNames")
}

fn read_entities(r: &mut Reader, raw: &mut Raw) -> Result<(), GmshError> {
    let mut counts = [0u64; 4];
    for (d, c) in counts.iter_mut().enumerate() {
        *c = r.n([
            "the number of points",
            "the number of curves",
            "the number of surfaces",
            "the number of volumes",
        ][d])?;
    }
    for (d, &count) in counts.iter().enumerate() {
        let what = ["point", "curve", "surface", "volume"][d];
        for _ in 0..count {
            let tag = r.i(&format!("a {what} tag"))?;
            // A point has its coordinates, other entities their bounding box.
            for _ in 0..if d == 0 { 3 } else { 6 } {
                r.f(&format!("a coordinate of {what} {tag}"))?;
            }
            let np = r.n(&format!("the number of physical tags of {what} {tag}"))?;
            let mut tags = Vec::with_capacity(capacity(np, r.data));
            for _ in 0..np {
                tags.push(r.i(&format!("a physical tag of {what} {tag}"))?);
            }
            if d > 0 {
                let nb = r.n(&format!("the number of bounding entities of {what} {tag}"))?;
                for _ in 0..nb {
                    r.i(&format!("a bounding entity of {what} {tag}"))?;
                }
            }
            raw.entities.insert((d as i32, tag), tags);
        }
    }
    r.end("$EndEntities")
}

fn add_node(
    r: &Reader,
    raw: &mut Raw,
    tag: u64,
    at: Location,
    xyz: [f64; 3],
) -> Result<(), GmshError> {
    if raw.node_index.insert(tag, raw.coords.len()).is_some() {
        return Err(r.err(at, format!("node {tag} is defined twice")));
    }
    raw.coords.push(xyz);
    Ok(())
}

fn read_nodes_v4(r: &mut Reader, raw: &mut Raw) -> Result<(), GmshError> {
    let blocks = r.n("the number of node blocks")?;
    let total = r.n("the number of nodes")?;
    r.n("the smallest node tag")?;
    r.n("the largest node tag")?;
    raw.coords.reserve(capacity(total, r.data));
    let mut tags = Vec::new();
    let mut read = 0u64;
    for _ in 0..blocks {
        let entity_dim = r.i("the entity dimension of a node block")?;
        r.i("the entity tag of a node block")?;
        let parametric = r.i("the parametric flag of a node block (0 or 1)")?;
        let n = r.n("the number of nodes in the block")?;
        let extra = if parametric != 0 {
            entity_dim.clamp(0, 3) as usize
        } else {
            0
        };
        tags.clear();
        for _ in 0..n {
            let at = r.at();
            tags.push((r.n("a node tag")?, at));
        }
        for &(tag, at) in &tags {
            let at = if r.binary { at } else { r.at() };
            let x = r.f(&format!("the x coordinate of node {tag}"))?;
            let y = r.f(&format!("the y coordinate of node {tag}"))?;
            let z = r.f(&format!("the z coordinate of node {tag}"))?;
            for _ in 0..extra {
                r.f(&format!("a parametric coordinate of node {tag}"))?;
            }
            add_node(r, raw, tag, at, [x, y, z])?;
        }
        read += n;
    }
    if read != total {
        return Err(r.err(
            r.at(),
            format!("the $Nodes header announces {total} nodes, its blocks hold {read}"),
        ));
    }
    r.end("$EndNodes")
}

fn read_nodes_v2(r: &mut Reader, raw: &mut Raw) -> Result<(), GmshError> {
    let n = r.count("the number of nodes")?;
    raw.coords.reserve(capacity(n, r.data));
    for _ in 0..n {
        r.skip_ws();
        let at = r.at();
        let tag = r.count("a node tag")?;
        let x = r.float(&format!("the x coordinate of node {tag}"))?;
        let y = r.float(&format!("the y coordinate of node {tag}"))?;
        let z = r.float(&format!("the z coordinate of node {tag}"))?;
        add_node(r, raw, tag, at, [x, y, z])?;
    }
    r.end("$EndNodes")
}

/// Checks an element type against the body's dimension when the block or element starts.
fn check_type(r: &Reader, at: Location, number: i32, dim: usize) -> Result<ElementType, GmshError> {
    let Some(kind) = element_type(number) else {
        return Err(r.err(at, format!("unknown Gmsh element type {number}")));
    };
    if kind.dim > dim {
        return Err(r.err(
            at,
            format!(
                "element type {number} ({}) is {}D, but the body is {dim}D; expected {}",
                kind.name,
                kind.dim,
                body_types(dim)
            ),
        ));
    }
    if kind.dim == dim && !matches!(number, 2..=5) {
        return Err(r.err(
            at,
            format!(
                "element type {number} ({}) is not supported; expected {} (in Gmsh: Mesh.ElementOrder = 1{})",
                kind.name,
                body_types(dim),
                if dim == 3 { ", and no prisms or pyramids" } else { "" }
            ),
        ));
    }
    Ok(kind)
}

fn body_types(dim: usize) -> &'static str {
    if dim == 2 {
        "first-order triangles (type 2) or quadrangles (type 3) for a 2D body"
    } else {
        "first-order tetrahedra (type 4) or hexahedra (type 5) for a 3D body"
    }
}

fn read_elements_v4(r: &mut Reader, raw: &mut Raw, dim: usize) -> Result<(), GmshError> {
    let blocks = r.n("the number of element blocks")?;
    let total = r.n("the number of elements")?;
    r.n("the smallest element tag")?;
    r.n("the largest element tag")?;
    raw.elements.reserve(capacity(total, r.data));
    let mut read = 0u64;
    for _ in 0..blocks {
        let entity_dim = r.i("the entity dimension of an element block")?;
        let entity_tag = r.i("the entity tag of an element block")?;
        let at = r.at();
        let number = r.i("the element type of an element block")?;
        let at = if r.binary { at } else { r.at() };
        let kind = check_type(r, at, number, dim)?;
        let n = r.n("the number of elements in the block")?;
        for _ in 0..n {
            if !r.binary {
                r.skip_ws();
            }
            let at = r.at();
            let tag = r.n("an element tag")?;
            let first = raw.connectivity.len();
            for _ in 0..kind.nodes {
                let node = r.n(&format!("a node tag of element {tag} ({})", kind.name))?;
                raw.connectivity.push(node);
            }
            raw.elements.push(RawElement {
                tag,
                kind,
                first,
                at,
                entity: (entity_dim, entity_tag),
                physical: 0,
            });
        }
        read += n;
    }
    if read != total {
        return Err(r.err(
            r.at(),
            format!("the $Elements header announces {total} elements, its blocks hold {read}"),
        ));
    }
    r.end("$EndElements")
}

fn read_elements_v2(r: &mut Reader, raw: &mut Raw, dim: usize) -> Result<(), GmshError> {
    let n = r.count("the number of elements")?;
    raw.elements.reserve(capacity(n, r.data));
    for _ in 0..n {
        r.skip_ws();
        let at = r.at();
        let tag = r.count("an element tag")?;
        let number = r.int(&format!("the type of element {tag}"))?;
        let kind = check_type(r, at, number, dim)?;
        let ntags = r.count(&format!("the number of tags of element {tag}"))?;
        let mut physical = 0;
        let mut entity = 0;
        for k in 0..ntags {
            let t = r.int(&format!("a tag of element {tag}"))?;
            match k {
                0 => physical = t,
                1 => entity = t,
                _ => {}
            }
        }
        let first = raw.connectivity.len();
        for _ in 0..kind.nodes {
            let node = r.count(&format!("a node tag of element {tag} ({})", kind.name))?;
            raw.connectivity.push(node);
        }
        raw.elements.push(RawElement {
            tag,
            kind,
            first,
            at,
            entity: (kind.dim as i32, entity),
            physical,
        });
    }
    r.end("$EndElements")
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn det3(a: [f64; 3], b: [f64; 3], c: [f64; 3]) -> f64 {
    a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
        + a[2] * (b[0] * c[1] - b[1] * c[0])
}

/// Signed measure and centroid of a body element, from its simplices. The simplices' weights
/// (2× area, 6× volume) are summed before scaling, so a unit cube split in six has volume 1.
fn measure(number: i32, p: &[[f64; 3]]) -> (f64, [f64; 3]) {
    const QUAD: &[[usize; 3]] = &[[0, 1, 2], [0, 2, 3]];
    const HEX: &[[usize; 4]] = &[
        [0, 1, 2, 6],
        [0, 2, 3, 6],
        [0, 3, 7, 6],
        [0, 7, 4, 6],
        [0, 4, 5, 6],
        [0, 5, 1, 6],
    ];
    let mut total = 0.0;
    let mut moment = [0.0; 3];
    let mut add = |m: f64, verts: &[usize]| {
        total += m;
        for k in 0..3 {
            let c: f64 = verts.iter().map(|&v| p[v][k]).sum::<f64>() / verts.len() as f64;
            moment[k] += m * c;
        }
    };
    match number {
        2 | 3 => {
            let tris = if number == 2 { &QUAD[..1] } else { QUAD };
            for t in tris {
                let (a, b) = (sub(p[t[1]], p[t[0]]), sub(p[t[2]], p[t[0]]));
                add(a[0] * b[1] - a[1] * b[0], t);
            }
        }
        4 => add(
            det3(sub(p[1], p[0]), sub(p[2], p[0]), sub(p[3], p[0])),
            &[0, 1, 2, 3],
        ),
        _ => {
            for t in HEX {
                let m = det3(
                    sub(p[t[1]], p[t[0]]),
                    sub(p[t[2]], p[t[0]]),
                    sub(p[t[3]], p[t[0]]),
                );
                add(m, t);
            }
        }
    }
    let centroid = if total != 0.0 {
        moment.map(|m| m / total)
    } else {
        [0.0; 3]
    };
    let factor = if matches!(number, 2 | 3) { 2.0 } else { 6.0 };
    (total / factor, centroid)
}

fn describe_nodes(tags: &[u64], p: &[[f64; 3]]) -> String {
    tags.iter()
        .zip(p)
        .map(|(t, x)| format!("{t} ({}, {}, {})", x[0], x[1], x[2]))
        .collect::<Vec<_>>()
        .join(", ")
}

fn assemble(r: &Reader, raw: Raw, dim: usize, version: Version) -> Result<GmshMesh, GmshError> {
    let err = |at: Location, message: String| GmshError::At {
        source_name: r.name.to_string(),
        at,
        message,
    };
    let physical_of = |e: &RawElement| -> Vec<i32> {
        match version {
            Version::V2 => {
                if e.physical != 0 {
                    vec![e.physical]
                } else {
                    vec![]
                }
            }
            Version::V4 => raw.entities.get(&e.entity).cloned().unwrap_or_default(),
        }
    };
    let nodes_of = |e: &RawElement| &raw.connectivity[e.first..e.first + e.kind.nodes];
    let lookup = |e: &RawElement| -> Result<Vec<[f64; 3]>, GmshError> {
        nodes_of(e)
            .iter()
            .map(|t| {
                raw.node_index
                    .get(t)
                    .map(|&i| raw.coords[i])
                    .ok_or_else(|| {
                        err(
                            e.at,
                            format!(
                                "element {} ({}) refers to node {t}, which $Nodes does not define",
                                e.tag, e.kind.name
                            ),
                        )
                    })
            })
            .collect()
    };

    // Body elements, once each (version 2.2 repeats an element for every physical group).
    let mut mesh = GmshMesh::default();
    let mut body: Vec<usize> = Vec::new();
    let mut groups: Vec<Vec<i32>> = Vec::new();
    let mut index_of_tag: HashMap<u64, usize> = HashMap::new();
    let mut signs: HashMap<(i32, i32), (usize, usize)> = HashMap::new();
    let mut z0: Option<f64> = None;
    for (k, e) in raw.elements.iter().enumerate() {
        if e.kind.dim != dim {
            continue;
        }
        let phys = physical_of(e);
        if let Some(&i) = index_of_tag.get(&e.tag) {
            for p in phys {
                if !groups[i].contains(&p) {
                    groups[i].push(p);
                }
            }
            continue;
        }
        let p = lookup(e)?;
        let length = p
            .iter()
            .flat_map(|a| p.iter().map(move |b| sub(*a, *b)))
            .map(|d| (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt())
            .fold(0.0, f64::max);
        if dim == 2 {
            for (x, t) in p.iter().zip(nodes_of(e)) {
                match z0 {
                    None => z0 = Some(x[2]),
                    Some(z) if (x[2] - z).abs() > 1e-9 * length => {
                        return Err(err(
                            e.at,
                            format!(
                                "node {t} of element {} has z = {}, other nodes z = {z}; a 2D body must lie in a plane z = constant",
                                e.tag, x[2]
                            ),
                        ));
                    }
                    _ => {}
                }
            }
        }
        let (m, c) = measure(e.kind.number, &p);
        if m.abs() <= 1e-12 * length.powi(dim as i32) || length == 0.0 {
            return Err(err(
                e.at,
                format!(
                    "element {} ({}) is degenerate (zero {}); nodes {}",
                    e.tag,
                    short_name(e.kind.number),
                    if dim == 2 { "area" } else { "volume" },
                    describe_nodes(nodes_of(e), &p)
                ),
            ));
        }
        if dim == 3 && m < 0.0 {
            return Err(err(
                e.at,
                format!(
                    "element {} ({}) is inverted (volume {m:e} m³ < 0); nodes {}. Gmsh writes positive volumes, so the file is probably broken",
                    e.tag,
                    short_name(e.kind.number),
                    describe_nodes(nodes_of(e), &p)
                ),
            ));
        }
        if dim == 2 {
            let s = signs.entry(e.entity).or_default();
            if m > 0.0 {
                s.0 += 1;
            } else {
                s.1 += 1;
            }
        }
        index_of_tag.insert(e.tag, body.len());
        body.push(k);
        groups.push(phys);
        mesh.positions
            .push(if dim == 2 { [c[0], c[1], 0.0] } else { c });
        mesh.measures.push(m);
        mesh.elements.push(e.tag);
    }
    if body.is_empty() {
        return Err(r.file_err(format!(
            "no elements of the body's dimension; expected {}",
            body_types(dim)
        )));
    }
    // 2D: a surface meshed clockwise is fine; an element against its surface's majority is not.
    if dim == 2 {
        for (i, &k) in body.iter().enumerate() {
            let e = &raw.elements[k];
            let (pos, neg) = signs[&e.entity];
            let m = mesh.measures[i];
            if (m > 0.0 && pos < neg) || (m < 0.0 && neg <= pos) {
                let p = lookup(e)?;
                return Err(err(
                    e.at,
                    format!(
                        "element {} ({}) is inverted: its orientation is opposite to the other elements of its surface; nodes {}. Gmsh writes consistent orientations, so the file is probably broken",
                        e.tag,
                        short_name(e.kind.number),
                        describe_nodes(nodes_of(e), &p)
                    ),
                ));
            }
            mesh.measures[i] = m.abs();
        }
    }
    // Blocks: the first physical group of the body's dimension.
    for g in &groups {
        let block = match g.first() {
            None => 0,
            Some(&t) => u32::try_from(t).map_err(|_| {
                r.file_err(format!(
                    "physical tag {t} is negative; expected a positive tag"
                ))
            })?,
        };
        mesh.blocks.push(block);
    }

    // Named physical groups → node sets.
    let mut sets: BTreeMap<String, BTreeSet<u32>> = BTreeMap::new();
    for (d, tag, name) in &raw.names {
        let set = sets.entry(name.clone()).or_default();
        if *d as usize == dim {
            for (i, g) in groups.iter().enumerate() {
                if g.contains(tag) {
                    set.insert(i as u32);
                }
            }
        } else if (*d as usize) < dim {
            let mut vertices: HashSet<u64> = HashSet::new();
            for e in raw.elements.iter().filter(|e| e.kind.dim == *d as usize) {
                if physical_of(e).contains(tag) {
                    vertices.extend(nodes_of(e));
                }
            }
            if vertices.is_empty() {
                continue;
            }
            for (i, &k) in body.iter().enumerate() {
                if nodes_of(&raw.elements[k])
                    .iter()
                    .any(|v| vertices.contains(v))
                {
                    set.insert(i as u32);
                }
            }
        }
    }
    mesh.node_sets = sets
        .into_iter()
        .filter(|(_, s)| !s.is_empty())
        .map(|(n, s)| (n, s.into_iter().collect()))
        .collect();
    Ok(mesh)
}
