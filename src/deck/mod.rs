//! Decks: parse (TOML, unknown keys rejected) → validate (physics, with key paths) → build.
//! Every error names the file, line:column, key path and what was expected.

pub mod build;
pub mod case;
pub mod contact;
pub mod contact_schema;
pub mod edit;
pub mod grids;
pub mod locate;
pub mod schema;
pub mod solver_settings;
pub mod stages;
pub mod study;
pub mod validate;

pub use locate::KeyPath;
pub use schema::Deck;

use std::fmt;
use std::path::{Path, PathBuf};

/// One problem found in a deck, before it is located in the text.
#[derive(Debug, Clone, PartialEq)]
pub struct DeckIssue {
    pub path: KeyPath,
    pub message: String,
}

impl DeckIssue {
    pub fn new(path: &str, message: impl Into<String>) -> Self {
        DeckIssue {
            path: KeyPath::parse(path),
            message: message.into(),
        }
    }
}

/// A located problem: `file:line:column: key.path: message`.
#[derive(Debug, Clone, PartialEq)]
pub struct LocatedIssue {
    pub file: String,
    pub line: usize,
    pub column: usize,
    pub path: String,
    pub message: String,
}

impl fmt::Display for LocatedIssue {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.path.is_empty() {
            write!(
                f,
                "{}:{}:{}: {}",
                self.file, self.line, self.column, self.message
            )
        } else {
            write!(
                f,
                "{}:{}:{}: {}: {}",
                self.file, self.line, self.column, self.path, self.message
            )
        }
    }
}

/// Why a deck could not be used.
#[derive(Debug, thiserror::Error)]
pub enum DeckError {
    #[error("{file}: cannot read the deck: {source}")]
    Io {
        file: String,
        source: std::io::Error,
    },
    #[error("{}", .0.iter().map(|i| i.to_string()).collect::<Vec<_>>().join("\n"))]
    Invalid(Vec<LocatedIssue>),
}

impl DeckError {
    /// The located issues (empty for I/O errors).
    pub fn issues(&self) -> &[LocatedIssue] {
        match self {
            DeckError::Invalid(v) => v,
            DeckError::Io { .. } => &[],
        }
    }
}

/// A parsed and validated deck together with its text, so later (build-time) problems can
/// still be located.
#[derive(Debug, Clone)]
pub struct LoadedDeck {
    pub deck: Deck,
    pub file: PathBuf,
    pub src: String,
}

impl LoadedDeck {
    /// Reads, parses and validates a deck file.
    pub fn from_file(path: &Path) -> Result<Self, DeckError> {
        let src = std::fs::read_to_string(path).map_err(|source| DeckError::Io {
            file: path.display().to_string(),
            source,
        })?;
        Self::from_str(&src, path)
    }

    /// Parses and validates deck text; `file` names it in messages and anchors relative paths.
    pub fn from_str(src: &str, file: &Path) -> Result<Self, DeckError> {
        let deck: Deck = parse_located(src, file)?;
        let loaded = LoadedDeck {
            deck,
            file: file.to_path_buf(),
            src: src.to_string(),
        };
        let issues = validate::validate(&loaded.deck);
        if !issues.is_empty() {
            return Err(loaded.locate(issues));
        }
        Ok(loaded)
    }

    /// Turns issues into a located error.
    pub fn locate(&self, issues: Vec<DeckIssue>) -> DeckError {
        locate_issues(&self.src, &self.file, issues)
    }

    /// The folder relative paths in the deck are taken from.
    pub fn base_dir(&self) -> PathBuf {
        self.file
            .parent()
            .map(Path::to_path_buf)
            .unwrap_or_default()
    }

    /// The deck's title, or its file name without extension when it has none.
    pub fn title(&self) -> String {
        if self.deck.title.is_empty() {
            self.file
                .file_stem()
                .map(|s| s.to_string_lossy().to_string())
                .unwrap_or_default()
        } else {
            self.deck.title.clone()
        }
    }
}

/// Parses TOML text into `T` (unknown keys rejected by `T`'s schema); a syntax or schema error
/// is located at its line, column and key path.
pub(crate) fn parse_located<T: serde::de::DeserializeOwned>(
    src: &str,
    file: &Path,
) -> Result<T, DeckError> {
    toml::from_str(src).map_err(|e| {
        let mut offset = e.span().map(|r| r.start).unwrap_or(0);
        let located = locate::Located::new(src);
        let mut path = located.path_at(offset);
        let message = e.message().trim().replace('\n', " ");
        if let Some((p, span)) = located.refine(&path, &message) {
            path = p;
            offset = span.start;
        }
        let (line, column) = locate::line_col(src, offset);
        DeckError::Invalid(vec![LocatedIssue {
            file: file.display().to_string(),
            line,
            column,
            path: path.to_string(),
            message,
        }])
    })
}

/// Issues found in the text `src` of `file`, located at their keys.
pub(crate) fn locate_issues(src: &str, file: &Path, issues: Vec<DeckIssue>) -> DeckError {
    let located = locate::Located::new(src);
    DeckError::Invalid(
        issues
            .into_iter()
            .map(|i| {
                let offset = located.span_of(&i.path).map(|r| r.start).unwrap_or(0);
                let (line, column) = locate::line_col(src, offset);
                LocatedIssue {
                    file: file.display().to_string(),
                    line,
                    column,
                    path: i.path.to_string(),
                    message: i.message,
                }
            })
            .collect(),
    )
}
