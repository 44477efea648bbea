//! The numbers a study reads from one run: a CSV table (header, rows of numbers) and the
//! reductions that turn one of its columns into a scalar (final, max, min, max |·|, the time a
//! level is first passed), optionally up to a time.

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

    fn column(&self, name: &str) -> Result<usize, String> {
        self.header.iter().position(|h| h == name).ok_or_else(|| {
            format!(
                "no column `{name}` (the columns are: {})",
                self.header.join(", ")
            )
        })
    }

    /// `column` reduced over the rows with `time` ≤ `until` (all rows without it). `Ok(None)`:
    /// no row qualifies, or the level is never passed.
    pub fn reduce(
        &self,
        column: &str,
        how: Reduction,
        until: Option<f64>,
    ) -> Result<Option<f64>, String> {
        let c = self.column(column)?;
        let time = match (until, how) {
            (None, Reduction::Final | Reduction::Max | Reduction::Min | Reduction::MaxAbs) => None,
            _ => Some(self.column("time")?),
        };
        let rows = self.rows.iter().filter(|r| match (time, until) {
            (Some(t), Some(limit)) => r.get(t).is_some_and(|&v| v <= limit),
            _ => true,
        });
        let values =
            rows.filter_map(|r| Some((r.get(c).copied()?, time.and_then(|t| r.get(t).copied()))));
        let mut out: Option<f64> = None;
        for (v, t) in values {
            out = match how {
                Reduction::Final => Some(v),
                Reduction::Max => Some(out.map_or(v, |o| o.max(v))),
                Reduction::Min => Some(out.map_or(v, |o| o.min(v))),
                Reduction::MaxAbs => Some(out.map_or(v.abs(), |o| o.max(v.abs()))),
                Reduction::FirstTimeAbove(level) => {
                    if v > level {
                        return Ok(t);
                    }
                    None
                }
            };
        }
        Ok(out)
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
        let r = |c, how, until| t.reduce(c, how, until).unwrap();
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
    fn a_missing_column_names_the_columns_there_are() {
        let t = Table::parse(CSV).unwrap();
        let e = t
            .reduce("reaction_bottom_y", Reduction::Max, None)
            .unwrap_err();
        assert!(e.contains("no column `reaction_bottom_y`"), "{e}");
        assert!(
            e.contains("time, step, broken_bonds, reaction_top_y"),
            "{e}"
        );
        assert!(Table::parse("").is_err());
    }
}
