//! Scalar functions of time that scale boundary conditions and loads.

use serde::{Deserialize, Serialize};

/// f(t), dimensionless; a boundary condition prescribes `value · f(t)`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum TimeFunction {
    /// f = 1.
    #[default]
    Constant,
    /// Linear ramp from 0 at t = 0 to 1 at t = `duration`, then held at 1.
    Ramp { duration: f64 },
    /// Piecewise-linear through `points = [[t0, f0], [t1, f1], …]` (t increasing), held
    /// constant before the first and after the last point.
    Table { points: Vec<[f64; 2]> },
}

impl TimeFunction {
    /// Checks the parameters; the message says what is wrong and what is expected.
    pub fn validate(&self) -> Result<(), String> {
        match self {
            TimeFunction::Constant => Ok(()),
            TimeFunction::Ramp { duration } => {
                if duration.is_finite() && *duration > 0.0 {
                    Ok(())
                } else {
                    Err(format!(
                        "ramp duration must be a positive time in seconds, found {duration}"
                    ))
                }
            }
            TimeFunction::Table { points } => {
                if points.is_empty() {
                    return Err("table needs at least one [time, value] point".into());
                }
                if points.iter().flatten().any(|v| !v.is_finite()) {
                    return Err("table points must be finite numbers".into());
                }
                for w in points.windows(2) {
                    if w[1][0] <= w[0][0] {
                        return Err(format!(
                            "table times must increase strictly, found {} after {}",
                            w[1][0], w[0][0]
                        ));
                    }
                }
                Ok(())
            }
        }
    }

    /// f(t).
    pub fn value(&self, t: f64) -> f64 {
        match self {
            TimeFunction::Constant => 1.0,
            TimeFunction::Ramp { duration } => (t / duration).clamp(0.0, 1.0),
            TimeFunction::Table { points } => {
                let (first, last) = (points[0], points[points.len() - 1]);
                if t <= first[0] {
                    return first[1];
                }
                if t >= last[0] {
                    return last[1];
                }
                let k = points.partition_point(|p| p[0] <= t);
                let (a, b) = (points[k - 1], points[k]);
                a[1] + (b[1] - a[1]) * (t - a[0]) / (b[0] - a[0])
            }
        }
    }

    /// df/dt (right derivative at kinks).
    pub fn rate(&self, t: f64) -> f64 {
        match self {
            TimeFunction::Constant => 0.0,
            TimeFunction::Ramp { duration } => {
                if (0.0..*duration).contains(&t) {
                    1.0 / duration
                } else {
                    0.0
                }
            }
            TimeFunction::Table { points } => {
                if t < points[0][0] || t >= points[points.len() - 1][0] {
                    return 0.0;
                }
                let k = points.partition_point(|p| p[0] <= t);
                let (a, b) = (points[k - 1], points[k]);
                (b[1] - a[1]) / (b[0] - a[0])
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ramp_then_hold() {
        let f = TimeFunction::Ramp { duration: 2.0 };
        assert_eq!(f.value(1.0), 0.5);
        assert_eq!(f.value(3.0), 1.0);
        assert_eq!(f.rate(1.0), 0.5);
        assert_eq!(f.rate(3.0), 0.0);
    }

    #[test]
    fn table_interpolates_and_holds() {
        let f = TimeFunction::Table {
            points: vec![[0.0, 0.0], [1.0, 2.0], [3.0, 2.0]],
        };
        assert_eq!(f.value(0.5), 1.0);
        assert_eq!(f.value(5.0), 2.0);
        assert_eq!(f.rate(0.5), 2.0);
        assert_eq!(f.rate(2.0), 0.0);
        assert!(TimeFunction::Table {
            points: vec![[1.0, 0.0], [1.0, 1.0]]
        }
        .validate()
        .is_err());
    }
}
