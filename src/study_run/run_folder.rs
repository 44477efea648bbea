//! The folder of one run of a study (or of a validation case): started afresh, or continued
//! from the checkpoint an earlier invocation left there when it was stopped (a session's end,
//! a killed job), so a run of many hours can be run in parts. A continued run is bitwise the
//! run that did not stop (tested), so the outputs do not tell the two apart; its wall time is
//! the sum of its parts, each counted up to its last checkpoint (the work after it is done
//! again).

use crate::atomic_file::write_atomic;
use std::path::{Path, PathBuf};
use std::time::{Duration, SystemTime};

/// How often a study's run checkpoints by the clock, whatever its deck says: a stopped run
/// loses at most this much.
pub const CHECKPOINT_EVERY: Duration = Duration::from_secs(600);

/// Rewritten when an invocation starts (or continues) the run: its time stamp is the start of
/// the part in progress.
const PART_START: &str = "part_started";
/// The wall seconds of the parts before the one in progress, up to each one's last checkpoint.
const EARLIER_PARTS: &str = "earlier_parts_wall_seconds";

/// The folder of run `k` in a study's `runs/` folder.
pub fn of_run(runs_dir: &Path, k: usize) -> PathBuf {
    runs_dir.join(format!("run_{k:04}"))
}

/// How a run begins in its folder.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Start {
    Afresh,
    /// From the folder's checkpoint, written by an earlier invocation with the same deck.
    FromCheckpoint,
}

/// Readies `dir` to run the deck `deck_src`: a folder that holds this deck and a checkpoint
/// continues from it; any other is cleared and started afresh.
pub fn prepare(dir: &Path, deck_src: &str) -> Result<Start, String> {
    let same_deck = std::fs::read_to_string(dir.join("deck.toml"))
        .ok()
        .as_deref()
        == Some(deck_src);
    let checkpoint = dir.join(crate::checkpoint::FILE_NAME);
    if !(same_deck && checkpoint.exists()) {
        start_afresh(dir, deck_src)?;
        return Ok(Start::Afresh);
    }
    let worked = match (modified(&checkpoint), modified(&dir.join(PART_START))) {
        (Some(saved), Some(started)) => saved.duration_since(started).unwrap_or_default(),
        _ => Duration::ZERO,
    };
    let earlier = earlier_parts_seconds(dir) + worked.as_secs_f64();
    write(dir, EARLIER_PARTS, &format!("{earlier}\n"))?;
    write(dir, PART_START, "")?;
    Ok(Start::FromCheckpoint)
}

/// Clears `dir` and writes the deck it runs: the run starts at its first step.
pub fn start_afresh(dir: &Path, deck_src: &str) -> Result<(), String> {
    if dir.exists() {
        std::fs::remove_dir_all(dir).map_err(|e| format!("cannot clear {}: {e}", dir.display()))?;
    }
    std::fs::create_dir_all(dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    write(dir, "deck.toml", deck_src)?;
    write(dir, PART_START, "")
}

/// The wall time of a finished run in minutes: what its `summary.txt` reports ("finished … in
/// S s wall") for the last part, plus the earlier parts'.
pub fn wall_minutes(dir: &Path) -> Option<f64> {
    let text = std::fs::read_to_string(dir.join("summary.txt")).ok()?;
    let line = text.lines().find(|l| l.starts_with("finished"))?;
    let words: Vec<&str> = line.split_whitespace().collect();
    let at = words.iter().position(|w| *w == "wall,")?;
    let last_part = words.get(at.checked_sub(2)?)?.parse::<f64>().ok()?;
    Some((last_part + earlier_parts_seconds(dir)) / 60.0)
}

fn earlier_parts_seconds(dir: &Path) -> f64 {
    std::fs::read_to_string(dir.join(EARLIER_PARTS))
        .ok()
        .and_then(|t| t.trim().parse().ok())
        .unwrap_or(0.0)
}

fn modified(path: &Path) -> Option<SystemTime> {
    std::fs::metadata(path).ok()?.modified().ok()
}

fn write(dir: &Path, name: &str, text: &str) -> Result<(), String> {
    let path = dir.join(name);
    write_atomic(&path, text.as_bytes())
        .map_err(|e| format!("cannot write {}: {e}", path.display()))
}
