//! A number of a TOML file a run writes, by key path: `derived.materials[0].peak_stretch` of
//! `resolved.toml` (the constants peridyn derives from the deck: s1, sc, the solid phase's E
//! and G0, …). A missing key names the keys there are at the level where the path stops.

use crate::deck::locate::PathElem;
use crate::deck::KeyPath;
use toml::Value;

/// The number at `key` in the TOML `text`, or why there is none (for a person: the keys or
/// the length found where the path stops).
pub fn number_at(text: &str, key: &str) -> Result<f64, String> {
    let root: toml::Table = text
        .parse()
        .map_err(|e: toml::de::Error| format!("not valid TOML: {}", e.message().trim()))?;
    let path = KeyPath::parse(key);
    let mut at = Value::Table(root);
    let mut walked = String::new();
    for elem in &path.0 {
        let next = match (elem, &at) {
            (PathElem::Key(k), Value::Table(t)) => t.get(k).cloned().ok_or_else(|| {
                let keys: Vec<&str> = t.keys().map(String::as_str).collect();
                format!(
                    "no `{k}` at `{}` (the keys there are: {})",
                    shown(&walked),
                    keys.join(", ")
                )
            })?,
            (PathElem::Index(i), Value::Array(a)) => a.get(*i).cloned().ok_or_else(|| {
                format!(
                    "`{}` has {} entries, no index {i} (they count from 0)",
                    shown(&walked),
                    a.len()
                )
            })?,
            (PathElem::Key(k), other) => {
                return Err(format!(
                    "`{}` is a {}, not a table with `{k}`",
                    shown(&walked),
                    other.type_str()
                ))
            }
            (PathElem::Index(i), other) => {
                return Err(format!(
                    "`{}` is a {}, not an array with an index {i}",
                    shown(&walked),
                    other.type_str()
                ))
            }
        };
        walked = match elem {
            PathElem::Key(k) if walked.is_empty() => k.clone(),
            PathElem::Key(k) => format!("{walked}.{k}"),
            PathElem::Index(i) => format!("{walked}[{i}]"),
        };
        at = next;
    }
    match at {
        Value::Float(f) => Ok(f),
        Value::Integer(i) => Ok(i as f64),
        other => Err(format!("`{key}` is a {}, not a number", other.type_str())),
    }
}

fn shown(walked: &str) -> &str {
    if walked.is_empty() {
        "the top level"
    } else {
        walked
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const RESOLVED: &str = "title = \"plate\"\n[discretization]\nhorizon = 3e-3\n\n\
        [derived]\nnodes = 1651\n\n[[derived.materials]]\nkey = \"material\"\n\
        peak_stretch = 0.005\nbreaking_stretch = 0.04024\n";

    #[test]
    fn numbers_are_read_by_key_path() {
        assert_eq!(
            number_at(RESOLVED, "derived.materials[0].peak_stretch"),
            Ok(0.005)
        );
        assert_eq!(
            number_at(RESOLVED, "derived.materials[0].breaking_stretch"),
            Ok(0.04024)
        );
        // An integer reads as a number; a key of the deck as run too.
        assert_eq!(number_at(RESOLVED, "derived.nodes"), Ok(1651.0));
        assert_eq!(number_at(RESOLVED, "discretization.horizon"), Ok(3e-3));
    }

    #[test]
    fn a_missing_key_names_what_is_there() {
        let e = number_at(RESOLVED, "derived.materials[0].kink_stretch").unwrap_err();
        assert!(
            e.contains("no `kink_stretch` at `derived.materials[0]`"),
            "{e}"
        );
        for there in ["key", "peak_stretch", "breaking_stretch"] {
            assert!(e.contains(there), "{e}");
        }
        let e = number_at(RESOLVED, "derived.materials[1].peak_stretch").unwrap_err();
        assert!(
            e.contains("`derived.materials` has 1 entries, no index 1"),
            "{e}"
        );
        let e = number_at(RESOLVED, "derived.materials[0].key").unwrap_err();
        assert!(e.contains("is a string, not a number"), "{e}");
        let e = number_at(RESOLVED, "dimension").unwrap_err();
        assert!(e.contains("no `dimension` at `the top level`"), "{e}");
    }
}
