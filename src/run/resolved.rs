//! The deck as run: `resolved.toml`, every default filled in, with the derived constants.

use super::{ModelReport, RunError};
use crate::deck::LoadedDeck;
use serde::Serialize;

/// The deck with every default filled in, as `resolved.toml` holds it (and checkpoints hash).
pub(crate) fn resolved_deck(ld: &LoadedDeck) -> Result<String, RunError> {
    // A point-cloud or mesh path is made absolute so the resolved deck runs from the results folder.
    let mut resolved = ld.deck.clone();
    resolved.output.history_interval = Some(ld.deck.history_interval());
    for (k, stage) in resolved.stages.iter_mut().enumerate() {
        stage.history_interval = Some(ld.deck.stage_history_interval(k + 1));
    }
    if let crate::deck::schema::Discretization::PointCloud { file, .. }
    | crate::deck::schema::Discretization::Gmsh { file, .. } = &mut resolved.discretization
    {
        let path = ld.base_dir().join(&*file);
        *file = std::fs::canonicalize(&path)
            .unwrap_or(path)
            .display()
            .to_string();
    }
    Ok(toml::to_string(&resolved).map_err(|e| std::io::Error::other(e.to_string()))?)
}

/// Writes `resolved.toml`: the resolved `deck` text, and the derived constants.
fn write_resolved(
    ld: &LoadedDeck,
    deck: &str,
    report: &ModelReport,
    out: &std::path::Path,
) -> Result<(), RunError> {
    #[derive(Serialize)]
    struct Derived<'a> {
        derived: &'a ModelReport,
    }
    let derived = toml::to_string(&Derived { derived: report })
        .map_err(|e| std::io::Error::other(e.to_string()))?;
    let text = format!("# Resolved deck written by peridyn {} from {}\n# Every default is filled in; [derived] holds the constants computed from it.\n\n{deck}\n{derived}", env!("CARGO_PKG_VERSION"), ld.file.display());
    crate::atomic_file::write_atomic(&out.join("resolved.toml"), text.as_bytes())?;
    Ok(())
}

/// What a run writes before its first step: the results folder, `resolved.toml`, and the
/// pores of a porous grid (`pores.txt`).
pub(crate) fn write_start(
    ld: &LoadedDeck,
    resolved: &str,
    report: &ModelReport,
    pores: Option<&str>,
    out: &std::path::Path,
) -> Result<(), RunError> {
    std::fs::create_dir_all(out)
        .map_err(|e| crate::atomic_file::with_path(e, "cannot create directory", out))?;
    write_resolved(ld, resolved, report, out)?;
    if let Some(text) = pores {
        crate::atomic_file::write_atomic(&out.join("pores.txt"), text.as_bytes())?;
    }
    Ok(())
}
