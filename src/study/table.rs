//! The numbers a study reads from one run: a CSV table (header, rows of numbers) and the
//! reductions that turn one of its columns into a scalar (final, max, peak, min, max |·|, the time a
//! level is first passed, the time of the largest value, the mean, the count of values, the
//! Pearson correlation with a second column, the angle of a path's first part, the opening of
//! the first fork), optionally over a window of time, and a column's value at a given time.

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
    /// The largest value if the last row holds less (the curve has turned: a peak load);
    /// none while the column is still at its largest at the end.
    Peak,
    /// The largest fall from one row to the next, over the largest value (both of the
    /// window); none without two rows or with a largest value not above 0.
    LargestDrop,
    Min,
    MaxAbs,
    /// The `time` of the first row whose value exceeds the level.
    FirstTimeAbove(f64),
    /// The `time` of the first row where the column is within the given distance of its
    /// largest value (when a crack tip's y stops rising: the crack turns horizontal).
    TimeOfMax(f64),
    /// The arithmetic mean of the column's values (a crack speed over a window).
    Mean,
    /// How many rows have a value (forks in `branching.csv`, samples of a tip).
    Count,
    /// 1 when the window's last row has a value, else 0 (a tip in its box at the run's end).
    Present,
    /// The Pearson correlation of the column with a second one, over the rows where both have
    /// values (seed 003 Eq. 17: a crack path against its reference).
    Pearson(usize),
    /// The largest |column − second column| over the rows where both have values (how far a
    /// crack path strays from its reference at the same abscissa).
    MaxDistance(usize),
    /// The least-squares slope of the column against a second one (the abscissa), over the
    /// rows whose value of the column lies in [low, high] when given (a crack tip's x against
    /// time between the notch and the far edge: its speed as a plot of the tip shows it).
    Slope {
        against: usize,
        between: Option<[f64; 2]>,
    },
    /// The angle in degrees, atan of the least-squares slope, of the column against the
    /// column `against` over the rows whose `against` lies within `first` of the first row's
    /// (the direction of a crack path's first part), of the rows whose value of the column
    /// lies in [low, high] when given (one of two cracks in one path file); a point repeated
    /// in successive rows (a tip sampled while it stands still) counts once.
    Angle {
        against: usize,
        first: f64,
        between: Option<[f64; 2]>,
    },
    /// The largest minus the smallest value of the column over the rows of the first group
    /// (rows sharing a value of the given column, in the order the groups first appear) that
    /// has two values: the angle between the outer branches of the first fork of
    /// `branching.csv`, grouped by `fork` (a fork whose branches were too short to fit an
    /// angle is passed over).
    ForkOpening(usize),
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
            (true, Reduction::FirstTimeAbove(_) | Reduction::TimeOfMax(_)) | (false, _) => {
                Some(self.column("time")?)
            }
            _ => None,
        };
        let windowed: Vec<&Vec<f64>> = self
            .rows
            .iter()
            .filter(|r| time.is_none_or(|t| r.get(t).is_some_and(|&v| window.holds(v))))
            .collect();
        let has_value = |r: &&Vec<f64>| r.get(c).is_some_and(|v| !v.is_nan());
        let rows: Vec<&Vec<f64>> = windowed.iter().copied().filter(has_value).collect();
        let values = || rows.iter().map(|r| r[c]);
        // (the other column's value, this column's) in the rows where the other has one.
        let paired = |other: usize| {
            rows.iter()
                .filter_map(move |r| r.get(other).filter(|v| !v.is_nan()).map(|&o| (o, r[c])))
        };
        Ok(match how {
            Reduction::Final => values().next_back(),
            Reduction::Max => values().reduce(f64::max),
            Reduction::Peak => {
                let last = values().next_back();
                values()
                    .reduce(f64::max)
                    .filter(|&m| last.is_some_and(|l| l < m))
            }
            Reduction::LargestDrop => {
                let falls = values()
                    .zip(values().skip(1))
                    .map(|(a, b)| (a - b).max(0.0));
                let top = values().reduce(f64::max).filter(|&m| m > 0.0);
                top.and_then(|top| falls.reduce(f64::max).map(|fall| fall / top))
            }
            Reduction::Min => values().reduce(f64::min),
            Reduction::MaxAbs => values().map(f64::abs).reduce(f64::max),
            Reduction::FirstTimeAbove(level) => rows
                .iter()
                .find(|r| r[c] > level)
                .and_then(|r| time.and_then(|t| r.get(t).copied())),
            Reduction::TimeOfMax(within) => {
                let largest = values().reduce(f64::max);
                rows.iter()
                    .find(|r| largest.is_some_and(|m| r[c] >= m - within))
                    .and_then(|r| time.and_then(|t| r.get(t).copied()))
            }
            Reduction::Mean => {
                (!rows.is_empty()).then(|| values().sum::<f64>() / rows.len() as f64)
            }
            Reduction::Count => Some(rows.len() as f64),
            Reduction::Present => windowed.last().map(|r| has_value(r) as u8 as f64),
            Reduction::Pearson(other) => {
                let (y, x): (Vec<f64>, Vec<f64>) = paired(other).unzip();
                pearson(&x, &y)
            }
            Reduction::MaxDistance(other) => {
                paired(other).map(|(o, v)| (v - o).abs()).reduce(f64::max)
            }
            Reduction::Slope { against, between } => {
                let points: Vec<(f64, f64)> = paired(against)
                    .filter(|&(_, v)| inside(between, v))
                    .collect();
                least_squares_slope(&points)
            }
            Reduction::Angle {
                against,
                first,
                between,
            } => {
                let mut points: Vec<(f64, f64)> = paired(against)
                    .filter(|&(_, v)| inside(between, v))
                    .collect();
                // A tip sampled while it stands still repeats its point: the path is its
                // distinct points, not the time spent at each.
                points.dedup();
                let start = points.first().map(|p| p.0);
                let part: Vec<(f64, f64)> = points
                    .into_iter()
                    .filter(|p| start.is_some_and(|s| (p.0 - s).abs() <= first))
                    .collect();
                least_squares_slope(&part).map(|m| m.atan().to_degrees())
            }
            Reduction::ForkOpening(fork) => {
                let mut forks: Vec<f64> = paired(fork).map(|(f, _)| f).collect();
                forks.dedup();
                forks.into_iter().find_map(|f| {
                    let angles = || paired(fork).filter(move |&(g, _)| g == f).map(|(_, a)| a);
                    let widest = angles().reduce(f64::max)? - angles().reduce(f64::min)?;
                    (angles().count() >= 2).then_some(widest)
                })
            }
        })
    }

    /// The value of `column` at `time`, interpolated linearly between the first two successive
    /// rows (in the file's order) whose times bracket it; `Ok(None)` when no two do (the time
    /// is outside the rows). Rows without a value of the column are skipped. In a long-format
    /// file (`crack_speed.csv`: one branch after the other) the first branch's rows come first.
    pub fn value_at(&self, column: &str, time: f64) -> Result<Option<f64>, String> {
        let c = self.column(column)?;
        let t = self.column("time")?;
        let points: Vec<(f64, f64)> = self
            .rows
            .iter()
            .filter_map(|r| match (r.get(t), r.get(c)) {
                (Some(&tr), Some(&v)) if !(tr.is_nan() || v.is_nan()) => Some((tr, v)),
                _ => None,
            })
            .collect();
        Ok(points.windows(2).find_map(|w| {
            let ((t0, v0), (t1, v1)) = (w[0], w[1]);
            if !(t0 <= time && time <= t1) {
                return None;
            }
            Some(if t1 > t0 {
                v0 + (v1 - v0) * (time - t0) / (t1 - t0)
            } else {
                v0
            })
        }))
    }
}

/// Whether `v` lies in [low, high] (always, without bounds).
fn inside(between: Option<[f64; 2]>, v: f64) -> bool {
    between.is_none_or(|[low, high]| (low..=high).contains(&v))
}

/// The slope of the least-squares line y = a + m x through `points` (x, y); `None` with fewer
/// than two distinct x.
fn least_squares_slope(points: &[(f64, f64)]) -> Option<f64> {
    let n = points.len() as f64;
    let mean_x = points.iter().map(|p| p.0).sum::<f64>() / n;
    let mean_y = points.iter().map(|p| p.1).sum::<f64>() / n;
    let sxx: f64 = points.iter().map(|p| (p.0 - mean_x).powi(2)).sum();
    let sxy: f64 = points.iter().map(|p| (p.0 - mean_x) * (p.1 - mean_y)).sum();
    (sxx > 0.0).then(|| sxy / sxx)
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
    fn the_largest_drop_is_the_largest_fall_between_rows_over_the_largest_value() {
        let drop = |csv: &str| {
            Table::parse(csv)
                .unwrap()
                .reduce("load", Reduction::LargestDrop, Window::default())
                .unwrap()
        };
        // Softening step by step: falls of 0.5 and 1 from a top of 10.
        assert_eq!(drop("time,load\n0,0\n1,10\n2,9.5\n3,8.5\n"), Some(0.1));
        // A sudden failure: 10 to 1 in one row.
        assert_eq!(drop("time,load\n0,0\n1,10\n2,1\n3,0.5\n"), Some(0.9));
        // Still rising: no fall at all.
        assert_eq!(drop("time,load\n0,0\n1,5\n2,10\n"), Some(0.0));
        // One row, or nothing above zero: no value.
        assert_eq!(drop("time,load\n0,3\n"), None);
        assert_eq!(drop("time,load\n0,0\n1,-2\n"), None);
    }

    #[test]
    fn a_peak_is_a_largest_value_the_column_has_turned_down_from() {
        let t = Table::parse("time,load\n0,0\n1,5\n2,7\n3,6.5\n").unwrap();
        let r = |until| {
            t.reduce("load", Reduction::Peak, Window { from: None, until })
                .unwrap()
        };
        assert_eq!(r(None), Some(7.0));
        // Cut off while still rising (or at the top): no peak yet, where `max` has one.
        assert_eq!(r(Some(2.0)), None);
        assert_eq!(
            t.reduce(
                "load",
                Reduction::Max,
                Window {
                    from: None,
                    until: Some(2.0)
                }
            )
            .unwrap(),
            Some(7.0)
        );
    }

    #[test]
    fn the_time_a_column_reaches_its_largest_value() {
        // A tip's y rises to 3 at t = 2, stays there, dips and comes back to 3: the first time
        // it is largest is 2.
        let t = Table::parse("time,y\n0,,\n1,1\n2,3\n3,3\n4,2\n5,3\n").unwrap();
        let r = |w| t.reduce("y", Reduction::TimeOfMax(0.0), w).unwrap();
        assert_eq!(r(Window::default()), Some(2.0));
        // Over a window that starts after it: the largest value there is first met at 3.
        let from = |f| Window {
            from: Some(f),
            until: None,
        };
        assert_eq!(r(from(2.5)), Some(3.0));
        assert_eq!(r(from(3.5)), Some(5.0));
        assert_eq!(r(from(9.0)), None);
        // Within 1.5 of the largest (3): first met at t = 2; within 2.5, the 1 at t = 1 counts.
        let within = |d| {
            t.reduce("y", Reduction::TimeOfMax(d), Window::default())
                .unwrap()
        };
        assert_eq!(within(1.5), Some(2.0));
        assert_eq!(within(2.5), Some(1.0));
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
        // A tip in the last row (of the table, of a window), none in the first.
        assert_eq!(r("speed", Reduction::Present, w(None, None)), Some(1.0));
        assert_eq!(
            r("speed", Reduction::Present, w(None, Some(0.5))),
            Some(0.0)
        );
        assert_eq!(r("speed", Reduction::Present, w(Some(9.0), None)), None);
        // Perfectly linear over the first three rows, r = 1; the last row bends it.
        let reference = t.column("reference").unwrap();
        let first_three = r("path", Reduction::Pearson(reference), w(None, Some(2.0)));
        assert!((first_three.unwrap() - 1.0).abs() < 1e-15);
        let all = r("path", Reduction::Pearson(reference), w(None, None)).unwrap();
        assert!(all < 1.0 && all > 0.98, "{all}");
        // The path strays furthest from its reference on the last row (4 against 7).
        let furthest = r("path", Reduction::MaxDistance(reference), w(None, None));
        assert_eq!(furthest, Some(3.0));
        assert_eq!(
            r(
                "path",
                Reduction::MaxDistance(reference),
                w(None, Some(1.0))
            ),
            Some(2.0)
        );
        // A tip's speed: the reference against time, 2 per unit in the band [2, 6], bent by
        // the last row (7) outside it.
        let time = t.column("time").unwrap();
        let speed = |between| {
            r(
                "reference",
                Reduction::Slope {
                    against: time,
                    between,
                },
                w(None, None),
            )
        };
        assert_eq!(speed(Some([2.0, 6.0])), Some(2.0));
        assert!((speed(None).unwrap() - 1.7).abs() < 1e-12);
        assert_eq!(speed(Some([6.5, 7.0])), None, "one point has no slope");
        // One pair: undefined.
        assert_eq!(
            r("path", Reduction::Pearson(reference), w(None, Some(0.0))),
            None
        );
    }

    #[test]
    fn a_value_at_a_time_is_interpolated_between_the_rows_around_it() {
        // A long-format speed table: branch "crack" (labels read as NaN), then branch "b",
        // whose times start again.
        let t = Table::parse(
            "branch,time,speed\ncrack,1,100\ncrack,2,300\ncrack,4,200\nb,1,900\nb,3,700\n",
        )
        .unwrap();
        assert_eq!(t.value_at("speed", 1.5).unwrap(), Some(200.0));
        assert_eq!(t.value_at("speed", 3.0).unwrap(), Some(250.0));
        // A row's own time gives its value; the first branch's rows are found first.
        assert_eq!(t.value_at("speed", 2.0).unwrap(), Some(300.0));
        assert_eq!(t.value_at("speed", 1.0).unwrap(), Some(100.0));
        // Outside the rows: no value.
        assert_eq!(t.value_at("speed", 0.5).unwrap(), None);
        assert_eq!(t.value_at("speed", 4.5).unwrap(), None);
        assert!(t.value_at("v", 1.0).unwrap_err().contains("no column `v`"));
    }

    #[test]
    fn the_angle_of_a_paths_first_part() {
        // A path rising at 30° for x in [0, 2], then flat: the first part's angle is 30°, the
        // whole path's smaller.
        let r3 = 3f64.sqrt();
        let csv = format!(
            "x,y\n0,0\n1,{}\n2,{}\n3,{}\n4,{}\n",
            1.0 / r3,
            2.0 / r3,
            2.0 / r3,
            2.0 / r3
        );
        let t = Table::parse(&csv).unwrap();
        let x = t.column("x").unwrap();
        let angle = |first| {
            t.reduce(
                "y",
                Reduction::Angle {
                    against: x,
                    first,
                    between: None,
                },
                Window::default(),
            )
            .unwrap()
        };
        assert!((angle(2.0).unwrap() - 30.0).abs() < 1e-12);
        assert!((angle(2.5).unwrap() - 30.0).abs() < 1e-12);
        let all = angle(10.0).unwrap();
        assert!(all > 5.0 && all < 25.0, "{all}");
        // One point: no line.
        assert_eq!(angle(0.5), None);
        // A tip that stands still at its first point for three samples, then moves to (1, 0)
        // and (2, 2): the three distinct points give a slope of 1 (45°); weighting the
        // repeated point would give 0.875 (41.2°).
        let t = Table::parse("time,x,y\n0,0,0\n1,0,0\n2,0,0\n3,1,0\n4,2,2\n").unwrap();
        let x = t.column("x").unwrap();
        let a = t
            .reduce(
                "y",
                Reduction::Angle {
                    against: x,
                    first: 3.0,
                    between: None,
                },
                Window::default(),
            )
            .unwrap();
        assert!((a.unwrap() - 45.0).abs() < 1e-12, "{a:?}");
        // A path falling to the right has a negative angle.
        let down = Table::parse("x,y\n0,0\n1,-1\n").unwrap();
        let a = down
            .reduce(
                "y",
                Reduction::Angle {
                    against: 0,
                    first: 1.0,
                    between: None,
                },
                Window::default(),
            )
            .unwrap();
        assert!((a.unwrap() + 45.0).abs() < 1e-12);
        // Two cracks in one path file (y against x): one falling at 45° below y = 1, one
        // rising at 30° above y = 2; `between` picks each.
        let csv = format!("x,y\n0,1\n1,0\n3,2\n4,{}\n", 2.0 + 1.0 / r3);
        let two = Table::parse(&csv).unwrap();
        let angle = |between| {
            two.reduce(
                "y",
                Reduction::Angle {
                    against: 0,
                    first: 10.0,
                    between: Some(between),
                },
                Window::default(),
            )
            .unwrap()
            .unwrap()
        };
        assert!((angle([0.0, 1.0]) + 45.0).abs() < 1e-12);
        assert!((angle([2.0, 3.0]) - 30.0).abs() < 1e-12);
    }

    #[test]
    fn the_opening_of_the_first_fork_is_the_angle_between_its_outer_branches() {
        // branching.csv as the crack-path analysis writes it: fork 0 has branches too short
        // to fit an angle; fork 1 opens at −19.9° and +25.0° (44.9° between them); fork 2,
        // later, has three branches spread over 70°.
        let csv = "time,fork,branch,angle_deg\n\
                   1,0,0,\n1,0,1,\n\
                   2,1,0,-19.9\n2,1,1,25.0\n\
                   3,2,0,-50.0\n3,2,1,20.0\n3,2,2,-10.0\n";
        let t = Table::parse(csv).unwrap();
        let fork = t.column("fork").unwrap();
        let opening = |from| {
            t.reduce(
                "angle_deg",
                Reduction::ForkOpening(fork),
                Window { from, until: None },
            )
            .unwrap()
        };
        assert!((opening(None).unwrap() - 44.9).abs() < 1e-12);
        // From t = 2.5 on the first fork is fork 2: its outer branches are 70° apart, the
        // middle one does not count.
        assert!((opening(Some(2.5)).unwrap() - 70.0).abs() < 1e-12);
        // A fork with one fitted branch has no opening; no fork at all, no value.
        let one = Table::parse("time,fork,angle_deg\n1,0,12.0\n1,0,\n").unwrap();
        let r = one.reduce("angle_deg", Reduction::ForkOpening(1), Window::default());
        assert_eq!(r.unwrap(), None);
        let none = Table::parse("time,fork,angle_deg\n").unwrap();
        let r = none.reduce("angle_deg", Reduction::ForkOpening(1), Window::default());
        assert_eq!(r.unwrap(), None);
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
