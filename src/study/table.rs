//! The numbers a study reads from one run: a CSV table (header, rows of numbers) and the
//! reductions that turn one of its columns into a scalar (final, max, min, max |·|, the time a
//! level is first passed, the mean, the count of values, the Pearson correlation with a second
//! column), optionally over a window of time.

use crate::analysis::crack_path::pearson;

/// A CSV file of numbers with a header row.
#[derive(Debug, Clone, PartialEq)]
pub struct Table {
    pub header: Vec<String>,
    pub rows: Vec<Vec<f64>>,
}

/// How a column becomes one number (the study file's `reduce`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Reduction {
    Final,
    Max,
    Min,
    MaxAbs,
    /// The `time` of the first row whose value exceeds the level.
    FirstTimeAbove(f64),
    /// The arithmetic mean of the column's values (a crack speed over a window).
    Mean,
    /// How many rows have a value (forks in `branching.csv`, samples of a tip).
    Count,
    /// The Pearson correlation of the column with a second one, over the rows where both have
    /// values (seed 003 Eq. 17: a crack path against its reference).
    Pearson(usize),
}

/// The rows of a table that count: those with `from` ≤ time ≤ `until` (each bound optional).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Window {
    pub from: Option<f64>,
    pub until: Option<f64>,
}

impl Window {
    fn is_open(&self) -> bool {
        self.from.is_none() && self.until.is_none()
    }

    fn holds(&self, t: f64) -> bool {
        self.from.is_none_or(|f| t >= f) && self.until.is_none_or(|u| t <= u)
    }
}

impl Table {
    /// Parses CSV text: a header, then rows of numbers (a cell that is not a number reads as
    /// NaN, so that a column of labels cannot be mistaken for data).
    pub fn parse(text: &str) -> Result<Table, String> {
        let mut lines = text.lines().filter(|l| !l.trim().is_empty());
        let header: Vec<String> = lines
            .next()
            .ok_or("the file is empty")?
            .split(',')
            .map(|h| h.trim().to_string())
            .collect();
        let rows = lines
            .map(|l| {
                l.split(',')
                    .map(|c| c.trim().parse::<f64>().unwrap_or(f64::NAN))
                    .collect::<Vec<f64>>()
            })
            .collect();
        Ok(Table { header, rows })
    }

    /// The index of the column `name`.
    pub fn column(&self, name: &str) -> Result<usize, String> {
        self.header.iter().position(|h| h == name).ok_or_else(|| {
            format!(
                "no column `{name}` (the columns are: {})",
                self.header.join(", ")
            )
        })
    }

    /// `column` reduced over the rows of `window` (all rows when it is open). `Ok(None)`: no
    /// row qualifies, the level is never passed, or a correlation is undefined. Empty cells
    /// (read as NaN) are skipped, so a column that has a value only in some rows (a crack
    /// branch's tip) reduces over those rows.
    pub fn reduce(
        &self,
        column: &str,
        how: Reduction,
        window: Window,
    ) -> Result<Option<f64>, String> {
        let c = self.column(column)?;
        let time = match (window.is_open(), how) {
            (true, Reduction::FirstTimeAbove(_)) | (false, _) => Some(self.column("time")?),
            _ => None,
        };
        let rows: Vec<&Vec<f64>> = self
            .rows
            .iter()
            .filter(|r| time.is_none_or(|t| r.get(t).is_some_and(|&v| window.holds(v))))
            .filter(|r| r.get(c).is_some_and(|v| !v.is_nan()))
            .collect();
        let values = || rows.iter().map(|r| r[c]);
        Ok(match how {
            Reduction::Final => values().last(),
            Reduction::Max => values().reduce(f64::max),
            Reduction::Min => values().reduce(f64::min),
            Reduction::MaxAbs => values().map(f64::abs).reduce(f64::max),
            Reduction::FirstTimeAbove(level) => rows
                .iter()
                .find(|r| r[c] > level)
                .and_then(|r| time.and_then(|t| r.get(t).copied())),
            Reduction::Mean => {
                (!rows.is_empty()).then(|| values().sum::<f64>() / rows.len() as f64)
            }
            Reduction::Count => Some(rows.len() as f64),
            Reduction::Pearson(other) => {
                let pairs: Vec<(f64, f64)> = rows
                    .iter()
                    .filter_map(|r| r.get(other).filter(|v| !v.is_nan()).map(|&o| (r[c], o)))
                    .collect();
                let (x, y): (Vec<f64>, Vec<f64>) = pairs.into_iter().unzip();
                pearson(&x, &y)
            }
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const CSV: &str = "time,step,broken_bonds,reaction_top_y\n\
                       0,0,0,0\n1e-6,10,0,-2.5\n2e-6,20,4,-3.5\n3e-6,30,9,1.0\n";

    #[test]
    fn columns_reduce_to_the_numbers_a_study_reads() {
        let t = Table::parse(CSV).unwrap();
        let r = |c, how, until| t.reduce(c, how, Window { from: None, until }).unwrap();
        assert_eq!(r("reaction_top_y", Reduction::Final, None), Some(1.0));
        assert_eq!(r("reaction_top_y", Reduction::Max, None), Some(1.0));
        assert_eq!(r("reaction_top_y", Reduction::Min, None), Some(-3.5));
        assert_eq!(r("reaction_top_y", Reduction::MaxAbs, None), Some(3.5));
        assert_eq!(
            r("reaction_top_y", Reduction::Final, Some(1.5e-6)),
            Some(-2.5)
        );
        assert_eq!(
            r("broken_bonds", Reduction::FirstTimeAbove(0.0), None),
            Some(2e-6)
        );
        assert_eq!(
            r("broken_bonds", Reduction::FirstTimeAbove(5.0), None),
            Some(3e-6)
        );
        // Never passed, or passed only after `until`: no value.
        assert_eq!(
            r("broken_bonds", Reduction::FirstTimeAbove(10.0), None),
            None
        );
        assert_eq!(
            r("broken_bonds", Reduction::FirstTimeAbove(0.0), Some(1.5e-6)),
            None
        );
        assert_eq!(r("broken_bonds", Reduction::Max, Some(-1.0)), None);
    }

    #[test]
    fn mean_count_and_correlation_over_a_window() {
        // A tip seen from the second row on (empty cells before), a path and its reference.
        let t =
            Table::parse("time,speed,path,reference\n0,,1,2\n1,300,2,4\n2,500,3,6\n3,700,4,7\n")
                .unwrap();
        let w = |from, until| Window { from, until };
        let r = |c, how, win| t.reduce(c, how, win).unwrap();
        assert_eq!(r("speed", Reduction::Mean, w(None, None)), Some(500.0));
        assert_eq!(r("speed", Reduction::Mean, w(Some(2.0), None)), Some(600.0));
        assert_eq!(r("speed", Reduction::Count, w(None, None)), Some(3.0));
        assert_eq!(
            r("speed", Reduction::Count, w(Some(1.5), Some(2.5))),
            Some(1.0)
        );
        assert_eq!(r("speed", Reduction::Final, w(None, Some(0.5))), None);
        // Perfectly linear over the first three rows, r = 1; the last row bends it.
        let reference = t.column("reference").unwrap();
        let first_three = r("path", Reduction::Pearson(reference), w(None, Some(2.0)));
        assert!((first_three.unwrap() - 1.0).abs() < 1e-15);
        let all = r("path", Reduction::Pearson(reference), w(None, None)).unwrap();
        assert!(all < 1.0 && all > 0.98, "{all}");
        // One pair: undefined.
        assert_eq!(
            r("path", Reduction::Pearson(reference), w(None, Some(0.0))),
            None
        );
    }

    #[test]
    fn a_missing_column_names_the_columns_there_are() {
        let t = Table::parse(CSV).unwrap();
        let e = t
            .reduce("reaction_bottom_y", Reduction::Max, Window::default())
            .unwrap_err();
        assert!(e.contains("no column `reaction_bottom_y`"), "{e}");
        assert!(
            e.contains("time, step, broken_bonds, reaction_top_y"),
            "{e}"
        );
        assert!(Table::parse("").is_err());
    }
}
