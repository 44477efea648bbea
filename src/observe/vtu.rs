//! VTK XML UnstructuredGrid (`.vtu`) writer for point clouds, readable by
//! ParaView. Every node becomes one VTK_VERTEX cell so that filters which need
//! cells (e.g. "Cell Data to Point Data", thresholding) work out of the box.
//!
//! Arrays are stored as raw little-endian binary in one `<AppendedData>`
//! block (each array preceded by a UInt64 byte count): compact, exact, and
//! fast to write for 10^6 nodes.

use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::path::Path;

use crate::atomic_file as atomic;

/// Values of one nodal field; all slices are in node order.
#[derive(Debug, Clone, Copy)]
pub enum FieldData<'a> {
    /// One `f64` per node.
    Scalar(&'a [f64]),
    /// `components` consecutive `f64` per node (interleaved: x0 y0 x1 y1 ...).
    /// Two-component vectors are padded with a zero third component on output
    /// because ParaView's glyph and warp filters expect 3 components.
    Vector { data: &'a [f64], components: usize },
    /// One `i32` per node (flags, ids, bond counts, ...).
    Int(&'a [i32]),
}

/// A named nodal field.
#[derive(Debug, Clone, Copy)]
pub struct Field<'a> {
    /// Array name shown in ParaView.
    pub name: &'a str,
    /// The values.
    pub data: FieldData<'a>,
}

/// VTK cell type id of a single-point cell.
const VTK_VERTEX: u8 = 1;

/// One appended array: XML attributes plus a closure-free description of its
/// payload so the header can be written before the data.
struct ArrayDesc<'a> {
    vtk_type: &'static str,
    name: Option<&'a str>,
    components: usize,
    payload: Payload<'a>,
}

enum Payload<'a> {
    F64(&'a [f64]),
    /// 2-component data written as 3 components (zero z).
    F64Pad2(&'a [f64]),
    I32(&'a [i32]),
    Points(&'a [[f64; 3]]),
    /// connectivity (0..n) or offsets (1..=n) generated on the fly.
    IotaI64 {
        start: i64,
        n: usize,
    },
    Types(usize),
}

impl Payload<'_> {
    /// Size in bytes of the encoded data (without the UInt64 header).
    fn byte_len(&self) -> usize {
        match self {
            Payload::F64(d) => d.len() * 8,
            Payload::F64Pad2(d) => d.len() / 2 * 3 * 8,
            Payload::I32(d) => d.len() * 4,
            Payload::Points(p) => p.len() * 24,
            Payload::IotaI64 { n, .. } => n * 8,
            Payload::Types(n) => *n,
        }
    }

    fn write(&self, w: &mut impl Write) -> io::Result<()> {
        w.write_all(&(self.byte_len() as u64).to_le_bytes())?;
        match self {
            Payload::F64(d) => d.iter().try_for_each(|v| w.write_all(&v.to_le_bytes())),
            Payload::F64Pad2(d) => d.chunks_exact(2).try_for_each(|c| {
                w.write_all(&c[0].to_le_bytes())?;
                w.write_all(&c[1].to_le_bytes())?;
                w.write_all(&0f64.to_le_bytes())
            }),
            Payload::I32(d) => d.iter().try_for_each(|v| w.write_all(&v.to_le_bytes())),
            Payload::Points(p) => p
                .iter()
                .flatten()
                .try_for_each(|v| w.write_all(&v.to_le_bytes())),
            Payload::IotaI64 { start, n } => {
                (0..*n as i64).try_for_each(|i| w.write_all(&(start + i).to_le_bytes()))
            }
            Payload::Types(n) => (0..*n).try_for_each(|_| w.write_all(&[VTK_VERTEX])),
        }
    }
}

fn invalid(msg: String) -> io::Error {
    io::Error::new(io::ErrorKind::InvalidInput, msg)
}

/// The VTK type and the number of components a field is written with.
fn declared(data: &FieldData) -> (&'static str, usize) {
    match *data {
        FieldData::Scalar(_) => ("Float64", 1),
        FieldData::Int(_) => ("Int32", 1),
        // Two components are padded to three (see `FieldData::Vector`).
        FieldData::Vector { components: 2, .. } => ("Float64", 3),
        FieldData::Vector { components, .. } => ("Float64", components),
    }
}

/// Writes a `.pvtu` file (atomically): the VTU `pieces` (paths relative to its folder), each
/// written by `write_vtu` with fields of the names, types and components of `fields`, as one
/// dataset. Only the fields' declarations are read, not their data.
pub fn write_pvtu(path: &Path, fields: &[Field], pieces: &[String]) -> io::Result<()> {
    let mut s = String::new();
    s.push_str("<?xml version=\"1.0\"?>\n");
    s.push_str(
        "<VTKFile type=\"PUnstructuredGrid\" version=\"1.0\" \
         byte_order=\"LittleEndian\" header_type=\"UInt64\">\n",
    );
    s.push_str("  <PUnstructuredGrid GhostLevel=\"0\">\n");
    s.push_str("    <PPointData>\n");
    let array = |s: &mut String, vtk_type: &str, name: &str, components: usize| {
        s.push_str(&format!(
            "      <PDataArray type=\"{vtk_type}\" Name=\"{}\" NumberOfComponents=\"{components}\"/>\n",
            xml_attr(name)
        ));
    };
    for f in fields {
        let (vtk_type, components) = declared(&f.data);
        array(&mut s, vtk_type, f.name, components);
    }
    s.push_str("    </PPointData>\n");
    s.push_str("    <PCellData>\n    </PCellData>\n");
    s.push_str("    <PPoints>\n");
    array(&mut s, "Float64", "Points", 3);
    s.push_str("    </PPoints>\n");
    for p in pieces {
        s.push_str(&format!("    <Piece Source=\"{}\"/>\n", xml_attr(p)));
    }
    s.push_str("  </PUnstructuredGrid>\n</VTKFile>\n");
    atomic::write_atomic(path, s.as_bytes())
}

/// Checks one field against the point count and turns it into an array
/// description.
fn describe<'a>(field: &Field<'a>, n: usize) -> io::Result<ArrayDesc<'a>> {
    let (vtk_type, components, len, payload) = match field.data {
        FieldData::Scalar(d) => ("Float64", 1, d.len(), Payload::F64(d)),
        FieldData::Int(d) => ("Int32", 1, d.len(), Payload::I32(d)),
        FieldData::Vector { data, components } => {
            if components == 0 {
                return Err(invalid(format!(
                    "field '{}': vector with 0 components",
                    field.name
                )));
            }
            let (out_comp, payload) = if components == 2 {
                (3, Payload::F64Pad2(data))
            } else {
                (components, Payload::F64(data))
            };
            // Check against the *input* component count.
            if data.len() != n * components {
                return Err(invalid(format!(
                    "field '{}': length {} != {} points x {} components",
                    field.name,
                    data.len(),
                    n,
                    components
                )));
            }
            ("Float64", out_comp, data.len(), payload)
        }
    };
    if components == 1 && len != n {
        return Err(invalid(format!(
            "field '{}': length {} != {} points",
            field.name, len, n
        )));
    }
    Ok(ArrayDesc {
        vtk_type,
        name: Some(field.name),
        components,
        payload,
    })
}

/// Escapes the characters that are not allowed inside an XML attribute value.
fn xml_attr(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            _ => out.push(c),
        }
    }
    out
}

/// Writes `points` with nodal `fields` as a `.vtu` file (atomically).
///
/// Returns an `InvalidInput` error naming the field if a field's length is
/// not `points.len() ×` its component count.
pub fn write_vtu(path: &Path, points: &[[f64; 3]], fields: &[Field]) -> io::Result<()> {
    let n = points.len();
    let field_arrays = fields
        .iter()
        .map(|f| describe(f, n))
        .collect::<io::Result<Vec<_>>>()
        .map_err(|e| atomic::with_path(e, "cannot write", path))?;
    let point_array = ArrayDesc {
        vtk_type: "Float64",
        name: Some("Points"),
        components: 3,
        payload: Payload::Points(points),
    };
    let cell_arrays = [
        ArrayDesc {
            vtk_type: "Int64",
            name: Some("connectivity"),
            components: 1,
            payload: Payload::IotaI64 { start: 0, n },
        },
        ArrayDesc {
            vtk_type: "Int64",
            name: Some("offsets"),
            components: 1,
            payload: Payload::IotaI64 { start: 1, n },
        },
        ArrayDesc {
            vtk_type: "UInt8",
            name: Some("types"),
            components: 1,
            payload: Payload::Types(n),
        },
    ];

    atomic::write_atomic_with(path, |w| {
        write_body(w, n, &field_arrays, &point_array, &cell_arrays)
    })
}

fn write_body(
    w: &mut BufWriter<File>,
    n: usize,
    field_arrays: &[ArrayDesc],
    point_array: &ArrayDesc,
    cell_arrays: &[ArrayDesc],
) -> io::Result<()> {
    // Offsets are relative to the first byte after the '_' marker and include
    // each array's 8-byte size header.
    let mut offset = 0usize;
    let mut data_array = |w: &mut BufWriter<File>, a: &ArrayDesc, indent: &str| {
        write!(w, "{indent}<DataArray type=\"{}\"", a.vtk_type)?;
        if let Some(name) = a.name {
            write!(w, " Name=\"{}\"", xml_attr(name))?;
        }
        writeln!(
            w,
            " NumberOfComponents=\"{}\" format=\"appended\" offset=\"{offset}\"/>",
            a.components
        )?;
        offset += 8 + a.payload.byte_len();
        Ok::<(), io::Error>(())
    };

    writeln!(w, "<?xml version=\"1.0\"?>")?;
    writeln!(
        w,
        "<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" \
         byte_order=\"LittleEndian\" header_type=\"UInt64\">"
    )?;
    writeln!(w, "  <UnstructuredGrid>")?;
    writeln!(
        w,
        "    <Piece NumberOfPoints=\"{n}\" NumberOfCells=\"{n}\">"
    )?;
    writeln!(w, "      <PointData>")?;
    for a in field_arrays {
        data_array(w, a, "        ")?;
    }
    writeln!(w, "      </PointData>")?;
    writeln!(w, "      <CellData>")?;
    writeln!(w, "      </CellData>")?;
    writeln!(w, "      <Points>")?;
    data_array(w, point_array, "        ")?;
    writeln!(w, "      </Points>")?;
    writeln!(w, "      <Cells>")?;
    for a in cell_arrays {
        data_array(w, a, "        ")?;
    }
    writeln!(w, "      </Cells>")?;
    writeln!(w, "    </Piece>")?;
    writeln!(w, "  </UnstructuredGrid>")?;
    write!(w, "  <AppendedData encoding=\"raw\">\n   _")?;
    // Same order as the offsets above.
    for a in field_arrays
        .iter()
        .chain(std::iter::once(point_array))
        .chain(cell_arrays)
    {
        a.payload.write(w)?;
    }
    write!(w, "\n  </AppendedData>\n</VTKFile>\n")?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::fs;

    /// Value of attribute `attr` in an XML tag text.
    fn attr<'a>(tag: &'a str, attr: &str) -> Option<&'a str> {
        let key = format!(" {attr}=\"");
        let start = tag.find(&key)? + key.len();
        let len = tag[start..].find('"')?;
        Some(&tag[start..start + len])
    }

    fn u64_at(b: &[u8], pos: usize) -> u64 {
        u64::from_le_bytes(b[pos..pos + 8].try_into().unwrap())
    }

    fn f64_at(b: &[u8], pos: usize) -> f64 {
        f64::from_le_bytes(b[pos..pos + 8].try_into().unwrap())
    }

    #[test]
    fn structure_and_appended_sizes_are_consistent() {
        let dir = atomic::test_dir("vtu");
        let path = dir.join("snap.vtu");
        let points = [[0.0, 0.0, 0.0], [1.5e-3, 0.0, 0.0], [0.0, 2.5e-3, 0.1]];
        let damage = [0.0, 0.25, 1.0];
        let disp2 = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0];
        let vel3 = [0.1; 9];
        let ids = [7, -1, 3];
        let fields = [
            Field {
                name: "damage",
                data: FieldData::Scalar(&damage),
            },
            Field {
                name: "displacement",
                data: FieldData::Vector {
                    data: &disp2,
                    components: 2,
                },
            },
            Field {
                name: "velocity",
                data: FieldData::Vector {
                    data: &vel3,
                    components: 3,
                },
            },
            Field {
                name: "material",
                data: FieldData::Int(&ids),
            },
        ];
        write_vtu(&path, &points, &fields).unwrap();

        let bytes = fs::read(&path).unwrap();
        let marker = b"<AppendedData encoding=\"raw\">";
        let head_end = bytes
            .windows(marker.len())
            .position(|w| w == marker)
            .expect("AppendedData present");
        let header = std::str::from_utf8(&bytes[..head_end]).unwrap();
        assert!(header.contains("type=\"UnstructuredGrid\""));
        assert!(header.contains("header_type=\"UInt64\""));
        assert!(header.contains("byte_order=\"LittleEndian\""));
        let piece = header.lines().find(|l| l.contains("<Piece")).unwrap();
        assert_eq!(attr(piece, "NumberOfPoints"), Some("3"));
        assert_eq!(attr(piece, "NumberOfCells"), Some("3"));

        let arrays: Vec<&str> = header
            .lines()
            .filter(|l| l.contains("<DataArray"))
            .collect();
        let names: Vec<&str> = arrays.iter().map(|l| attr(l, "Name").unwrap()).collect();
        assert_eq!(
            names,
            [
                "damage",
                "displacement",
                "velocity",
                "material",
                "Points",
                "connectivity",
                "offsets",
                "types"
            ]
        );
        let disp_line = arrays[1];
        assert_eq!(attr(disp_line, "NumberOfComponents"), Some("3"));
        assert_eq!(attr(arrays[3], "type"), Some("Int32"));
        assert_eq!(attr(arrays[5], "type"), Some("Int64"));
        assert_eq!(attr(arrays[7], "type"), Some("UInt8"));

        // Walk the appended block: each header offset must match the running
        // position and the last array must end right before the closing tags.
        let underscore = head_end + bytes[head_end..].iter().position(|&b| b == b'_').unwrap();
        let base = underscore + 1;
        let expected_sizes = [3 * 8, 3 * 3 * 8, 9 * 8, 3 * 4, 9 * 8, 3 * 8, 3 * 8, 3];
        let mut pos = base;
        for (line, size) in arrays.iter().zip(expected_sizes) {
            let off: usize = attr(line, "offset").unwrap().parse().unwrap();
            assert_eq!(base + off, pos, "offset of {line}");
            assert_eq!(u64_at(&bytes, pos) as usize, size, "size of {line}");
            pos += 8 + size;
        }
        let tail = b"\n  </AppendedData>\n</VTKFile>\n";
        assert_eq!(pos + tail.len(), bytes.len());
        assert_eq!(&bytes[pos..], tail);

        // Spot-check payloads: padded displacement and point coordinates.
        let disp_data = base + 24 + 8 + 8;
        let got: Vec<f64> = (0..9).map(|i| f64_at(&bytes, disp_data + 8 * i)).collect();
        assert_eq!(got, [1.0, 2.0, 0.0, 3.0, 4.0, 0.0, 5.0, 6.0, 0.0]);
        let pts_off: usize = attr(arrays[4], "offset").unwrap().parse().unwrap();
        assert_eq!(f64_at(&bytes, base + pts_off + 8 + 8 * 8), 0.1);
        fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn length_mismatch_is_invalid_input_naming_field() {
        let dir = atomic::test_dir("vtu-bad");
        let path = dir.join("bad.vtu");
        let points = [[0.0; 3]; 4];
        let short = [1.0; 3];
        let err = write_vtu(
            &path,
            &points,
            &[Field {
                name: "stretch",
                data: FieldData::Scalar(&short),
            }],
        )
        .unwrap_err();
        assert_eq!(err.kind(), io::ErrorKind::InvalidInput);
        assert!(err.to_string().contains("stretch"), "{err}");

        let vec = [1.0; 7];
        let err = write_vtu(
            &path,
            &points,
            &[Field {
                name: "disp",
                data: FieldData::Vector {
                    data: &vec,
                    components: 2,
                },
            }],
        )
        .unwrap_err();
        assert_eq!(err.kind(), io::ErrorKind::InvalidInput);
        assert!(err.to_string().contains("disp"), "{err}");
        assert!(!path.exists());
        fs::remove_dir_all(&dir).unwrap();
    }
}
