//! Import of discretisations given as point clouds in plain text (one node per line).
//!
//! # Format
//!
//! Each data line holds one node: `x y volume [block]` in 2D, `x y z volume [block]`
//! in 3D. Columns are separated by whitespace, by commas (CSV), or by both
//! (`1.0, 2.0, 0.01`). Further rules:
//!
//! - Blank lines and lines whose first non-blank character is `#` are skipped.
//! - The first non-comment line may be a header (e.g. `x,y,volume,block`): it is
//!   skipped when none of its fields is a number. A first line mixing numbers
//!   and text is reported as a bad data line instead, so a typo in the first
//!   node is not silently dropped.
//! - Every data line must have as many columns as the first one.
//! - In 2D the volume column is the nodal **area** in m² (the plate thickness is
//!   applied elsewhere); in 3D it is the nodal volume in m³. It must be positive
//!   and finite. Coordinates must be finite.
//! - Block ids are non-negative integers fitting in `u32` (0 when the column is
//!   absent). Integral values written as floats (`1.0`, `2.000e+00`, as
//!   `numpy.savetxt` does by default) are accepted.
//!
//! Errors name the source, the 1-based line and the column, e.g.
//! `nodes.csv:17: column 3 (volume): expected a positive number, found "-0.1"`.

use std::path::Path;
use thiserror::Error;

/// Nodes read from a point-cloud file; the three vectors have the same length.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct PointCloud {
    /// Node positions; `z = 0` for 2D clouds.
    pub positions: Vec<[f64; 3]>,
    /// Nodal volume in m³ (3D) or nodal area in m² (2D).
    pub volumes: Vec<f64>,
    /// Block (material region) id of each node, 0 when the file has no block column.
    pub blocks: Vec<u32>,
}

impl PointCloud {
    /// Number of nodes.
    pub fn len(&self) -> usize {
        self.positions.len()
    }

    /// Whether the cloud has no nodes (never true for a successfully read file).
    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }
}

/// Why a point cloud could not be imported; messages are meant for people.
#[derive(Debug, Error)]
pub enum ImportError {
    /// The file could not be read (missing, unreadable, not UTF-8).
    #[error("{path}: cannot read point cloud: {source}")]
    Io {
        path: String,
        #[source]
        source: std::io::Error,
    },
    /// A line is malformed; `line` is 1-based.
    #[error("{source_name}:{line}: {message}")]
    Line {
        source_name: String,
        line: usize,
        message: String,
    },
    /// A problem with the input as a whole (no data lines, unsupported dimension).
    #[error("{source_name}: {message}")]
    File {
        source_name: String,
        message: String,
    },
}

/// Reads a point cloud from `path` for a `dim`-dimensional model (2 or 3).
///
/// See the [module documentation](self) for the format. In 2D the volume
/// column is the nodal area in m².
pub fn read_point_cloud(path: &Path, dim: usize) -> Result<PointCloud, ImportError> {
    let name = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|source| ImportError::Io {
        path: name.clone(),
        source,
    })?;
    parse_point_cloud(&text, dim, &name)
}

/// Parses point-cloud `text` for a `dim`-dimensional model (2 or 3);
/// `source_name` is used in error messages (usually the file name).
///
/// See the [module documentation](self) for the format. In 2D the volume
/// column is the nodal area in m². Runs in linear time in the text length.
pub fn parse_point_cloud(
    text: &str,
    dim: usize,
    source_name: &str,
) -> Result<PointCloud, ImportError> {
    if dim != 2 && dim != 3 {
        return Err(ImportError::File {
            source_name: source_name.to_string(),
            message: format!("cannot read a point cloud for dimension {dim}; expected 2 or 3"),
        });
    }
    let names: &[&str] = if dim == 2 {
        &["x", "y", "volume", "block"]
    } else {
        &["x", "y", "z", "volume", "block"]
    };
    let line_err = |line: usize, message: String| ImportError::Line {
        source_name: source_name.to_string(),
        line,
        message,
    };

    // A UTF-8 byte-order mark (common in spreadsheet exports) is not data.
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);

    let mut cloud = PointCloud::default();
    // (column count, line number) of the first data line.
    let mut layout: Option<(usize, usize)> = None;
    let mut seen_first_line = false;
    let mut fields: Vec<&str> = Vec::with_capacity(8);

    for (idx, raw) in text.lines().enumerate() {
        let lineno = idx + 1;
        let line = raw.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        split_fields(line, &mut fields).map_err(|col| {
            line_err(
                lineno,
                format!("column {col}: empty field (two commas in a row or a trailing comma); expected a number"),
            )
        })?;

        let first_line = !seen_first_line;
        seen_first_line = true;
        if first_line && fields.iter().all(|f| f.parse::<f64>().is_err()) {
            continue; // header
        }

        let ncols = match layout {
            Some((n, first)) => {
                if fields.len() != n {
                    return Err(line_err(
                        lineno,
                        format!(
                            "expected {n} columns like the first data line (line {first}), found {}",
                            fields.len()
                        ),
                    ));
                }
                n
            }
            None => {
                let n = fields.len();
                if n != dim + 1 && n != dim + 2 {
                    return Err(line_err(
                        lineno,
                        format!(
                            "expected {} or {} columns for {dim}D ({}), found {n}",
                            dim + 1,
                            dim + 2,
                            if dim == 2 {
                                "x y volume [block]"
                            } else {
                                "x y z volume [block]"
                            }
                        ),
                    ));
                }
                layout = Some((n, lineno));
                n
            }
        };

        let bad = |col: usize, expected: &str, found: &str| {
            line_err(
                lineno,
                format!(
                    "column {} ({}): expected {expected}, found {found:?}",
                    col + 1,
                    names[col]
                ),
            )
        };

        let mut pos = [0.0; 3];
        for (c, slot) in pos.iter_mut().enumerate().take(dim) {
            let f = fields[c];
            match f.parse::<f64>() {
                Ok(v) if v.is_finite() => *slot = v,
                Ok(_) => return Err(bad(c, "a finite number", f)),
                Err(_) => return Err(bad(c, "a number", f)),
            }
        }

        let f = fields[dim];
        let volume = match f.parse::<f64>() {
            Ok(v) if v.is_finite() && v > 0.0 => v,
            Ok(v) if v > 0.0 => return Err(bad(dim, "a finite positive number", f)),
            _ => return Err(bad(dim, "a positive number", f)),
        };

        let block = if ncols == dim + 2 {
            let f = fields[dim + 1];
            parse_block(f).ok_or_else(|| {
                bad(
                    dim + 1,
                    "a non-negative integer block id (at most 4294967295)",
                    f,
                )
            })?
        } else {
            0
        };

        cloud.positions.push(pos);
        cloud.volumes.push(volume);
        cloud.blocks.push(block);
    }

    if cloud.is_empty() {
        return Err(ImportError::File {
            source_name: source_name.to_string(),
            message: format!(
                "no nodes found; expected one node per line as \"{}\"",
                if dim == 2 {
                    "x y volume [block]"
                } else {
                    "x y z volume [block]"
                }
            ),
        });
    }
    Ok(cloud)
}

/// Splits `line` (already trimmed, non-empty) into `out`. A separator is a run
/// of whitespace holding at most one comma. On an empty field between commas
/// (or a leading/trailing comma) returns its 1-based column.
fn split_fields<'a>(line: &'a str, out: &mut Vec<&'a str>) -> Result<(), usize> {
    out.clear();
    for piece in line.split(',') {
        let before = out.len();
        out.extend(piece.split_whitespace());
        if out.len() == before {
            return Err(before + 1);
        }
    }
    Ok(())
}

/// A block id: a `u32`, or an integral float within `u32` range.
fn parse_block(f: &str) -> Option<u32> {
    if let Ok(b) = f.parse::<u32>() {
        return Some(b);
    }
    let v = f.parse::<f64>().ok()?;
    (v.fract() == 0.0 && (0.0..=u32::MAX as f64).contains(&v)).then_some(v as u32)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str, dim: usize) -> PointCloud {
        match parse_point_cloud(text, dim, "nodes.csv") {
            Ok(c) => c,
            Err(e) => panic!("unexpected error: {e}"),
        }
    }

    fn parse_err(text: &str, dim: usize) -> String {
        match parse_point_cloud(text, dim, "nodes.csv") {
            Ok(c) => panic!("expected an error, got {c:?}"),
            Err(e) => e.to_string(),
        }
    }

    #[test]
    fn whitespace_2d() {
        let c = parse("0 0 0.01\n1.5\t2.5   0.02\n", 2);
        assert_eq!(c.positions, vec![[0.0, 0.0, 0.0], [1.5, 2.5, 0.0]]);
        assert_eq!(c.volumes, vec![0.01, 0.02]);
        assert_eq!(c.blocks, vec![0, 0]);
        assert_eq!(c.len(), 2);
    }

    #[test]
    fn csv_3d_with_blocks() {
        let c = parse("1,2,3,0.5,1\n4,5,6,0.25,7\n", 3);
        assert_eq!(c.positions, vec![[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]]);
        assert_eq!(c.volumes, vec![0.5, 0.25]);
        assert_eq!(c.blocks, vec![1, 7]);
    }

    #[test]
    fn mixed_separators_and_crlf() {
        let c = parse("1.0, 2.0 ,0.1, 3\r\n  4e-3 ,\t-5E2, 1e-6 ,0\r\n", 2);
        assert_eq!(c.positions, vec![[1.0, 2.0, 0.0], [4e-3, -500.0, 0.0]]);
        assert_eq!(c.volumes, vec![0.1, 1e-6]);
        assert_eq!(c.blocks, vec![3, 0]);
    }

    #[test]
    fn block_column_2d_and_3d_without_block() {
        let c = parse("0 0 1 2\n", 2);
        assert_eq!(c.blocks, vec![2]);
        let c = parse("0 0 1 2\n", 3);
        assert_eq!(c.positions, vec![[0.0, 0.0, 1.0]]);
        assert_eq!(c.volumes, vec![2.0]);
        assert_eq!(c.blocks, vec![0]);
    }

    #[test]
    fn block_as_integral_float() {
        let c = parse("0 0 1 2.000000000000000000e+00\n0 0 1 3.0\n", 2);
        assert_eq!(c.blocks, vec![2, 3]);
    }

    #[test]
    fn header_comments_and_blank_lines() {
        let text = "\u{feff}# exported by mesher\n\n  # another comment\nx,y,z,volume,block\n0,0,0,1,0\n\n# mid comment\n1,1,1,1,2\n";
        let c = parse(text, 3);
        assert_eq!(c.len(), 2);
        assert_eq!(c.blocks, vec![0, 2]);
    }

    #[test]
    fn only_first_header_is_skipped() {
        let e = parse_err("x y volume\nx y volume\n0 0 1\n", 2);
        assert_eq!(
            e,
            "nodes.csv:2: column 1 (x): expected a number, found \"x\""
        );
        let e = parse_err("x y volume\n0 0 1\nx y volume\n", 2);
        assert_eq!(
            e,
            "nodes.csv:3: column 1 (x): expected a number, found \"x\""
        );
    }

    #[test]
    fn first_line_with_a_typo_is_not_a_header() {
        let e = parse_err("0 0 1o\n1 1 1\n", 2);
        assert_eq!(
            e,
            "nodes.csv:1: column 3 (volume): expected a positive number, found \"1o\""
        );
    }

    #[test]
    fn error_negative_volume() {
        let mut text = String::from("x,y,volume\n");
        for i in 0..15 {
            text.push_str(&format!("{i},0,0.1\n"));
        }
        text.push_str("15,0,-0.1\n");
        assert_eq!(
            parse_err(&text, 2),
            "nodes.csv:17: column 3 (volume): expected a positive number, found \"-0.1\""
        );
    }

    #[test]
    fn error_zero_and_infinite_volume() {
        assert_eq!(
            parse_err("0 0 0 0\n", 3),
            "nodes.csv:1: column 4 (volume): expected a positive number, found \"0\""
        );
        assert_eq!(
            parse_err("0 0 0 1\n0 0 0 inf\n", 3),
            "nodes.csv:2: column 4 (volume): expected a finite positive number, found \"inf\""
        );
        assert_eq!(
            parse_err("0 0 NaN\n", 2),
            "nodes.csv:1: column 3 (volume): expected a positive number, found \"NaN\""
        );
    }

    #[test]
    fn error_bad_coordinate() {
        assert_eq!(
            parse_err("0 0 0 1\n0 abc 0 1\n", 3),
            "nodes.csv:2: column 2 (y): expected a number, found \"abc\""
        );
        assert_eq!(
            parse_err("0 0 0 1\n0 0 -inf 1\n", 3),
            "nodes.csv:2: column 3 (z): expected a finite number, found \"-inf\""
        );
        assert_eq!(
            parse_err("nan 0 1\n", 2),
            "nodes.csv:1: column 1 (x): expected a finite number, found \"nan\""
        );
    }

    #[test]
    fn error_bad_block() {
        assert_eq!(
            parse_err("0 0 1 0\n0 0 1 -1\n", 2),
            "nodes.csv:2: column 4 (block): expected a non-negative integer block id (at most 4294967295), found \"-1\""
        );
        assert_eq!(
            parse_err("0 0 1 1.5\n", 2),
            "nodes.csv:1: column 4 (block): expected a non-negative integer block id (at most 4294967295), found \"1.5\""
        );
        assert_eq!(
            parse_err("0 0 0 1 4294967296\n", 3),
            "nodes.csv:1: column 5 (block): expected a non-negative integer block id (at most 4294967295), found \"4294967296\""
        );
    }

    #[test]
    fn error_column_count_changes() {
        assert_eq!(
            parse_err("# c\n0 0 1\n1 1 1 4\n", 2),
            "nodes.csv:3: expected 3 columns like the first data line (line 2), found 4"
        );
        assert_eq!(
            parse_err("0 0 1 4\n1 1 1\n", 2),
            "nodes.csv:2: expected 4 columns like the first data line (line 1), found 3"
        );
    }

    #[test]
    fn error_wrong_column_count_for_dimension() {
        assert_eq!(
            parse_err("0 0\n", 2),
            "nodes.csv:1: expected 3 or 4 columns for 2D (x y volume [block]), found 2"
        );
        assert_eq!(
            parse_err("x y z v\n0 0 0 1 2 3\n", 3),
            "nodes.csv:2: expected 4 or 5 columns for 3D (x y z volume [block]), found 6"
        );
    }

    #[test]
    fn error_empty_field() {
        assert_eq!(
            parse_err("0,,1\n", 2),
            "nodes.csv:1: column 2: empty field (two commas in a row or a trailing comma); expected a number"
        );
        assert_eq!(
            parse_err("0 0 1\n0,0,1,\n", 2),
            "nodes.csv:2: column 4: empty field (two commas in a row or a trailing comma); expected a number"
        );
    }

    #[test]
    fn error_empty_input() {
        let expected =
            "nodes.csv: no nodes found; expected one node per line as \"x y volume [block]\"";
        assert_eq!(parse_err("", 2), expected);
        assert_eq!(parse_err("# only comments\n\n   \n", 2), expected);
        assert_eq!(parse_err("x y volume\n", 2), expected, "header only");
    }

    #[test]
    fn error_bad_dimension() {
        assert_eq!(
            parse_err("0 1\n", 1),
            "nodes.csv: cannot read a point cloud for dimension 1; expected 2 or 3"
        );
    }

    #[test]
    fn read_from_file_and_missing_file() {
        let dir = std::env::temp_dir().join(format!("peridyn-pc-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("temp dir");
        let path = dir.join("cloud.txt");
        std::fs::write(&path, "x y z volume\n0 0 0 1e-9\n1e-3 0 0 1e-9\n").expect("write");
        let c = read_point_cloud(&path, 3).expect("reads");
        assert_eq!(c.len(), 2);

        std::fs::write(&path, "0 0 0 1e-9\n0 0 0 -1\n").expect("write");
        let e = read_point_cloud(&path, 3).unwrap_err().to_string();
        assert!(
            e.starts_with(&format!("{}:2: column 4 (volume)", path.display())),
            "{e}"
        );

        let missing = dir.join("missing.txt");
        let e = read_point_cloud(&missing, 3).unwrap_err();
        assert!(matches!(e, ImportError::Io { .. }));
        assert!(e
            .to_string()
            .starts_with(&format!("{}: cannot read point cloud:", missing.display())));
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn many_lines() {
        // 200k lines in a debug build stays well under a second.
        let n = 200_000;
        let mut text = String::with_capacity(n * 32);
        text.push_str("x,y,z,volume,block\n");
        for i in 0..n {
            text.push_str(&format!("{}.5,{},{},1e-9,{}\n", i, i % 7, i % 3, i % 4));
        }
        let c = parse(&text, 3);
        assert_eq!(c.len(), n);
        assert_eq!(
            c.positions[n - 1],
            [
                (n - 1) as f64 + 0.5,
                ((n - 1) % 7) as f64,
                ((n - 1) % 3) as f64
            ]
        );
        assert_eq!(c.blocks[n - 1], ((n - 1) % 4) as u32);
    }
}
