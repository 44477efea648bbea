//! A table of bad decks: every one must be rejected with its specific message, located at the
//! offending line, and never with a panic.
//!
//! Convention (as in lumol's `tests/input/bad`): each file in `tests/decks/bad/` holds the
//! offending line immediately followed by a comment line
//!
//! ```toml
//! density = -1.0
//! #^ density (kg/m³) must be a positive finite number
//! ```
//!
//! The text after `#^ ` must be a substring of the error's `Display`, on an issue line that starts
//! with `<deck file>:<LINE>:<COL>:` where LINE is the line just above the `#^` comment.
//!
//! Every deck is loaded with `LoadedDeck::from_file`; a deck that loads (its problem is only
//! visible once the model is built: an empty node set, `dt` above the stable step, a point-cloud
//! file) is then built with `peridyn::run::check`.
//!
//! Point-cloud files the decks refer to live in `tests/decks/data/`.

use peridyn::deck::LoadedDeck;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};

const MARKER: &str = "#^";

fn decks_dir(sub: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests")
        .join("decks")
        .join(sub)
}

/// The `.toml` files of a folder, sorted by name.
fn deck_files(dir: &Path) -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.expect("directory entry").path())
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .collect();
    files.sort();
    files
}

/// What a bad deck promises: the 1-based line of the offending key and a message substring.
#[derive(Debug)]
struct Expectation {
    line: usize,
    message: String,
}

fn expectation(path: &Path) -> Result<Expectation, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("cannot read: {e}"))?;
    let markers: Vec<(usize, &str)> = text
        .lines()
        .enumerate()
        .filter_map(|(k, l)| {
            l.trim_start()
                .strip_prefix(MARKER)
                .map(|rest| (k + 1, rest.trim()))
        })
        .collect();
    match markers.as_slice() {
        [(marker_line, message)] => {
            if *marker_line < 2 {
                return Err(format!(
                    "the `{MARKER}` comment is on line 1; it must follow the offending line"
                ));
            }
            if message.is_empty() {
                return Err(format!(
                    "the `{MARKER}` comment on line {marker_line} gives no expected message"
                ));
            }
            Ok(Expectation {
                line: marker_line - 1,
                message: message.to_string(),
            })
        }
        [] => Err(format!("no `{MARKER} <expected message>` comment")),
        more => Err(format!(
            "{} `{MARKER}` comments (lines {:?}); expected exactly one",
            more.len(),
            more.iter().map(|m| m.0).collect::<Vec<_>>()
        )),
    }
}

/// Loads (and, if it loads, builds) a deck; `Ok` with the error text, or `Err` if it was accepted.
fn rejection(path: &Path) -> Result<String, String> {
    match LoadedDeck::from_file(path) {
        Err(e) => Ok(e.to_string()),
        Ok(loaded) => match peridyn::run::check(&loaded, Some(1)) {
            Err(e) => Ok(e.to_string()),
            Ok(report) => Err(format!("the deck was accepted and builds:\n{report}")),
        },
    }
}

/// Checks one bad deck; `Err` describes the failure.
fn check_bad_deck(path: &Path) -> Result<(), String> {
    let expected = expectation(path)?;
    let outcome = catch_unwind(AssertUnwindSafe(|| rejection(path)));
    let text = match outcome {
        Err(payload) => {
            let what = payload
                .downcast_ref::<String>()
                .map(String::as_str)
                .or_else(|| payload.downcast_ref::<&str>().copied())
                .unwrap_or("<non-string panic payload>");
            return Err(format!("PANICKED: {what}"));
        }
        Ok(Err(accepted)) => return Err(accepted),
        Ok(Ok(text)) => text,
    };
    if !text.contains(&expected.message) {
        return Err(format!(
            "the message does not contain {:?}; got:\n{text}",
            expected.message
        ));
    }
    // The issue carrying the expected message must be located at `file:LINE:COL:`.
    let prefix = format!("{}:{}:", path.display(), expected.line);
    let located = text
        .lines()
        .filter(|l| l.contains(&expected.message))
        .any(|l| {
            l.strip_prefix(&prefix)
                .and_then(|rest| rest.split_once(':'))
                .is_some_and(|(col, _)| {
                    !col.is_empty() && col.bytes().all(|b| b.is_ascii_digit()) && col != "0"
                })
        });
    if !located {
        return Err(format!(
            "expected the issue at {}{{COL}}: (line {}); got:\n{text}",
            prefix, expected.line
        ));
    }
    Ok(())
}

#[test]
fn bad_decks_give_located_messages() {
    let files = deck_files(&decks_dir("bad"));
    assert!(
        files.len() >= 25,
        "expected at least 25 bad decks, found {}",
        files.len()
    );
    let verbose = std::env::var_os("PERIDYN_SHOW_DECK_ERRORS").is_some();
    let mut failures = Vec::new();
    for path in &files {
        let name = path
            .file_name()
            .expect("file name")
            .to_string_lossy()
            .to_string();
        if verbose {
            let shown = catch_unwind(AssertUnwindSafe(|| rejection(path)));
            match shown {
                Ok(Ok(t)) | Ok(Err(t)) => eprintln!("--- {name}\n{t}"),
                Err(_) => eprintln!("--- {name}\n<panic>"),
            }
        }
        if let Err(why) = check_bad_deck(path) {
            failures.push(format!("{name}: {why}"));
        }
    }
    assert!(
        failures.is_empty(),
        "{} of {} bad decks failed:\n\n{}",
        failures.len(),
        files.len(),
        failures.join("\n\n")
    );
}

/// The decks in `bad/` are small edits of this one; it must load and build, so each failure
/// above is due to its one edit.
const BASE: &str = r#"
version = 1
dimension = 2
plane = "stress"
thickness = 1e-3

[discretization]
type = "lattice"
shape = { type = "rectangle", min = [0.0, 0.0], max = [2e-3, 1e-3] }
spacing = 0.25e-3
horizon_ratio = 3.0

[material]
type = "pmb"
density = 1000.0
youngs_modulus = 1e9
fracture_energy = 100.0

[[node_sets]]
name = "left"
region = { type = "rectangle", min = [-1.0, -1.0], max = [0.5e-3, 1.0] }

[[boundary_conditions]]
set = "left"
kind = "velocity"
component = "x"
value = -1.0
time = { type = "ramp", duration = 1e-6 }

[solver]
type = "explicit"
steps = 10
"#;

#[test]
fn base_deck_is_valid() {
    let loaded =
        LoadedDeck::from_str(BASE, Path::new("base.toml")).unwrap_or_else(|e| panic!("{e}"));
    let report = peridyn::run::check(&loaded, Some(1)).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(report.nodes, 8 * 4);
}

/// The harness itself: a wrong line number must be caught.
#[test]
fn harness_checks_the_line_exactly() {
    let dir = std::env::temp_dir().join(format!("peridyn-deck-errors-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let good = BASE.replace(
        "density = 1000.0",
        "density = -1.0\n#^ density (kg/m³) must be a positive finite number",
    );
    let path = dir.join("right_line.toml");
    std::fs::write(&path, &good).expect("write");
    assert_eq!(check_bad_deck(&path), Ok(()));
    let wrong = BASE.replace(
        "density = 1000.0",
        "density = -1.0\n\n#^ density (kg/m³) must be a positive finite number",
    );
    let path = dir.join("wrong_line.toml");
    std::fs::write(&path, &wrong).expect("write");
    assert!(check_bad_deck(&path)
        .unwrap_err()
        .contains("expected the issue at"));
    std::fs::remove_dir_all(&dir).ok();
}

/// The examples of `docs/deck.md` stay valid: complete decks (```toml blocks with a
/// `version = 1` line) load and build; `[discretization…]` fragments are spliced into the base deck.
#[test]
fn docs_examples_are_valid() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("docs")
        .join("deck.md");
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let blocks: Vec<&str> = text
        .split("```toml\n")
        .skip(1)
        .map(|b| b.split("\n```").next().expect("closed block"))
        .collect();
    let disc_start = BASE.find("[discretization]").expect("base discretization");
    let disc_end = BASE.find("[material]").expect("base material");
    let mut checked = 0;
    for (k, block) in blocks.iter().enumerate() {
        let deck = if block.lines().any(|l| l.starts_with("version = 1")) {
            block.to_string()
        } else if block.starts_with("[discretization]")
            || block.starts_with("[discretization.shape]")
        {
            let prefix = if block.starts_with("[discretization.shape]") {
                "[discretization]\ntype = \"lattice\"\nspacing = 0.25e-3\nhorizon_ratio = 3.0\n\n"
            } else {
                ""
            };
            format!(
                "{}{prefix}{block}\n\n{}",
                &BASE[..disc_start],
                &BASE[disc_end..]
            )
        } else {
            continue;
        };
        let name = format!("docs/deck.md block {}", k + 1);
        let loaded = LoadedDeck::from_str(&deck, Path::new(&name))
            .unwrap_or_else(|e| panic!("{name}:\n{e}\n---\n{deck}"));
        peridyn::run::check(&loaded, None).unwrap_or_else(|e| panic!("{name}:\n{e}"));
        checked += 1;
    }
    assert!(
        checked >= 3,
        "expected the quickstart and the two CSG examples, checked {checked}"
    );
}
