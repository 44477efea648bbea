//! `docs/validation.md`: every row of every case, grouped by paper, then one section per case
//! with its figures and the paragraph that says what was run and why a row differs. Written
//! from the case files and the committed measurements only, so it can be written again
//! without running anything.

use super::figures;
use super::measured::Measured;
use super::others::Others;
use super::verdict::{judge_case, number, percent, Row, Status, NOT_YET_RUN};
use crate::deck::case::LoadedCase;
use std::fmt::Write;
use std::path::Path;

/// The five papers (seed number, citation).
const PAPERS: [(&str, &str); 5] = [
    (
        "000",
        "Peng, Chen & Bobaru (2023), Accurate predictions of dynamic fracture in perforated plates, Int J Fract",
    ),
    (
        "001",
        "Niazi, Chen & Bobaru, Crack nucleation in brittle and quasi-brittle materials: a peridynamic analysis",
    ),
    (
        "002",
        "Butt & Meschke (2021), Peridynamic analysis of dynamic fracture: influence of peridynamic horizon, dimensionality and specimen size",
    ),
    (
        "003",
        "Dai, Xie, Lu, Qin & Wang (2021), Numerical modeling on crack propagation based on a multi-grid bond-based dual-horizon peridynamics, Mathematics 9, 2848",
    ),
    (
        "004",
        "Willberg, Hesse & Heinecke (2022), Peridynamic simulation of a mixed-mode fracture experiment in PMMA utilizing an adaptive-time stepping for an explicit solver",
    ),
];

/// One case with its last full measurement, if any.
pub struct CaseEntry {
    pub case: LoadedCase,
    pub measured: Option<Measured>,
    /// The cases its comparisons read, with their measurements.
    pub others: Others,
    /// The case file as the report names it (relative to the repository).
    pub path: String,
    /// A screening not finished yet: how far it is (said in its rows instead of "not run").
    pub progress: Option<String>,
}

impl CaseEntry {
    /// The case's rows as the full report shows them.
    pub fn rows(&self) -> Vec<Row> {
        let mut rows = judge_case(&self.case, self.measured.as_ref(), false, &self.others);
        if let Some(progress) = &self.progress {
            for row in rows.iter_mut().filter(|r| r.note == NOT_YET_RUN) {
                row.note = progress.clone();
            }
        }
        rows
    }
}

/// The report's markdown. `figure_dir` is where the figures are, relative to the report.
pub fn markdown(entries: &[CaseEntry], figure_dir: &str, figures_present: &Path) -> String {
    let judged: Vec<(&CaseEntry, Vec<Row>)> = entries.iter().map(|e| (e, e.rows())).collect();
    let mut md = String::new();
    md += "# Validation: the papers' results reproduced\n\n";
    md += "Written by `peridyn validate` from the case files in [`validation/`](../validation/) \
           and the measurements of their full runs in `validation/measured/`; do not edit it by \
           hand. One case again, at full size or in its reduced (CI) version:\n\n";
    md += "```sh\ncargo run --release -- validate validation/seed002/<case>.toml            \
           # full size: writes its measurement, figures and this page\n\
           cargo run --release -- validate validation/seed002/<case>.toml --reduced  # minutes\n\
           cargo run --release -- validate --report                                  \
           # this page again from the measurements\n```\n\n";
    md += "PASS: within the row's tolerance (set from the paper's own scatter or reading \
           precision, never widened). DIFFERS: outside it, or no value where the paper has one (a \
           crack that does not start), with the cause. NOT RUN: with what it needs.\n\n";

    md += "## Summary\n\n";
    md += &summary(&judged, "#seed-");
    md += "\n";

    for (seed, citation) in PAPERS {
        let cases: Vec<&(&CaseEntry, Vec<Row>)> = judged
            .iter()
            .filter(|(e, _)| e.case.case.paper == seed)
            .collect();
        let _ = writeln!(md, "## Seed {seed}\n\n{citation}.\n");
        if cases.is_empty() {
            md += "No case yet.\n\n";
            continue;
        }
        md += "| id | result | source | paper | peridyn | difference | tolerance | status |\n\
               |---|---|---|---|---|---|---|---|\n";
        for (e, rows) in &cases {
            for r in rows {
                let _ = writeln!(
                    md,
                    "| [{}](#{}) | {} | {} | {} | {} | {} | {} | {} |",
                    r.id,
                    anchor(&e.case),
                    cell(&r.quantity),
                    cell(&r.source),
                    value(r.paper, &r.unit),
                    measured(r),
                    r.relative_difference().map_or(String::new(), |d| format!(
                        "{}{}",
                        sign(d),
                        percent(d.abs())
                    )),
                    r.tolerance,
                    r.status
                );
            }
        }
        md += "\n";
        for (e, rows) in &cases {
            md += &case_section(e, rows, figure_dir, figures_present);
        }
    }
    md
}

/// The table of rows per paper and status; `link` prefixes each paper's anchor.
fn summary(judged: &[(&CaseEntry, Vec<Row>)], link: &str) -> String {
    let mut md =
        String::from("| paper | results | PASS | DIFFERS | NOT RUN |\n|---|---|---|---|---|\n");
    for (seed, citation) in PAPERS {
        let rows: Vec<&Row> = judged
            .iter()
            .filter(|(e, _)| e.case.case.paper == seed)
            .flat_map(|(_, r)| r.iter())
            .collect();
        let count = |s: Status| rows.iter().filter(|r| r.status == s).count();
        let short = citation.split(", ").next().unwrap_or(citation);
        let _ = writeln!(
            md,
            "| [{seed}]({link}{seed}) {short} | {} | {} | {} | {} |",
            rows.len(),
            count(Status::Pass),
            count(Status::Differs),
            count(Status::NotRun) + count(Status::Unchecked)
        );
    }
    md
}

/// The README's summary: the same table, linking into the report.
pub fn readme_summary(entries: &[CaseEntry]) -> String {
    let judged: Vec<(&CaseEntry, Vec<Row>)> = entries.iter().map(|e| (e, e.rows())).collect();
    summary(&judged, "docs/validation.md#seed-")
}

/// `readme` with the text between its summary markers replaced by `table`; `None` when it
/// has no markers.
pub fn with_readme_summary(readme: &str, table: &str) -> Option<String> {
    let start = readme.find(README_START)? + README_START.len();
    let end = start + readme[start..].find(README_END)?;
    Some(format!("{}\n{table}{}", &readme[..start], &readme[end..]))
}

const README_START: &str = "<!-- validation summary: written by `peridyn validate --report` -->";
const README_END: &str = "<!-- end of validation summary -->";

/// A text as one cell of a markdown table: a `|` (an absolute value, |x|) would end the cell.
fn cell(text: &str) -> String {
    text.replace('|', "\\|")
}

fn sign(d: f64) -> &'static str {
    if d < 0.0 {
        "−"
    } else {
        "+"
    }
}

fn anchor(case: &LoadedCase) -> String {
    format!("case-{}-{}", case.case.paper, case.name().replace('_', "-"))
}

fn value(v: Option<f64>, unit: &str) -> String {
    v.map_or(String::new(), |v| {
        format!("{} {unit}", number(v)).trim().to_string()
    })
}

fn measured(r: &Row) -> String {
    if !r.values.is_empty() {
        return r
            .values
            .iter()
            .map(|v| number(*v))
            .collect::<Vec<_>>()
            .join(" → ");
    }
    value(r.measured, &r.unit)
}

/// "1 thread", "2 threads", or "1-2 threads" when the runs were measured by invocations
/// with different thread counts.
fn threads_used(m: &Measured) -> String {
    let lo = m.run_threads().min().unwrap_or(m.threads);
    let hi = m.run_threads().max().unwrap_or(m.threads);
    match (lo, hi) {
        (1, 1) => "1 thread".into(),
        (lo, hi) if lo == hi => format!("{lo} threads"),
        (lo, hi) => format!("{lo}-{hi} threads"),
    }
}

fn case_section(e: &CaseEntry, rows: &[Row], figure_dir: &str, figures_present: &Path) -> String {
    let c = &e.case.case;
    let mut md = String::new();
    let _ = writeln!(
        md,
        "### <a id=\"{}\"></a>{} ({})\n",
        anchor(&e.case),
        c.title,
        c.section
    );
    let run = match &e.measured {
        Some(m) => format!(
            "Full run: {} run{} in {} min on {}.",
            m.runs.len(),
            if m.runs.len() == 1 { "" } else { "s" },
            number(m.wall_minutes),
            threads_used(m)
        ),
        None if c.deck.is_some() => "Not yet run at full size.".into(),
        None => "Nothing to run here.".into(),
    };
    let _ = writeln!(md, "Case [`{}`](../{}). {run}\n", e.path, e.path);
    if let Some(why) = &c.not_in_ci {
        let _ = writeln!(md, "Its reduced version is not run in CI: {}\n", why.trim());
    }
    if !c.about.trim().is_empty() {
        md += c.about.trim();
        md += "\n\n";
    }
    for plot in &c.plots {
        let name = figures::file_name(&e.case, plot);
        if figures_present.join(&name).exists() {
            let _ = writeln!(md, "![{}]({figure_dir}/{name})\n", plot.title);
        }
    }
    for r in rows {
        let note = r.note.trim();
        if !note.is_empty() {
            let _ = writeln!(md, "- **{}** ({}): {note}", r.id, r.status);
        }
    }
    md += "\n";
    md
}

#[cfg(test)]
mod tests {
    use super::cell;

    /// An absolute value in a row's text stays inside its cell of the table.
    #[test]
    fn a_bar_in_a_table_cell_is_escaped() {
        assert_eq!(
            cell("the largest |angle| to x"),
            "the largest \\|angle\\| to x"
        );
        assert_eq!(cell("no bar"), "no bar");
    }
}
