//! A full-factorial parameter sweep: every combination of the factors' values, the last factor
//! changing fastest (the order of nested loops over the factors as listed).

/// The design points of a sweep over `values[k]` for each factor k, in run order.
pub fn sweep_points(values: &[Vec<f64>]) -> Vec<Vec<f64>> {
    values.iter().fold(vec![Vec::new()], |points, factor| {
        points
            .iter()
            .flat_map(|p| {
                factor.iter().map(move |&v| {
                    let mut q = p.clone();
                    q.push(v);
                    q
                })
            })
            .collect()
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_combination_once_last_factor_fastest() {
        let points = sweep_points(&[vec![1.0, 2.0], vec![10.0, 20.0, 30.0]]);
        assert_eq!(
            points,
            vec![
                vec![1.0, 10.0],
                vec![1.0, 20.0],
                vec![1.0, 30.0],
                vec![2.0, 10.0],
                vec![2.0, 20.0],
                vec![2.0, 30.0],
            ]
        );
        assert_eq!(sweep_points(&[vec![5.0]]), vec![vec![5.0]]);
    }
}
