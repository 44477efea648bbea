//! A parameter that is the same for every node (the fast path) or set node by node.

/// A value that is the same for every node (the fast path) or set per node (blocks,
/// variable horizons). Bond loops read it with `at`, a branch the CPU predicts perfectly.
#[derive(Debug, Clone, PartialEq)]
pub enum PerNode {
    Uniform(f64),
    Varying(Vec<f64>),
}

impl PerNode {
    #[inline(always)]
    pub fn at(&self, i: usize) -> f64 {
        match self {
            PerNode::Uniform(v) => *v,
            PerNode::Varying(v) => v[i],
        }
    }

    /// Builds the per-node form from a value per node, collapsing to `Uniform` when all agree.
    pub fn from_values(values: Vec<f64>) -> Self {
        match values.first() {
            Some(&first) if values.iter().all(|&v| v == first) => PerNode::Uniform(first),
            None => PerNode::Uniform(0.0),
            _ => PerNode::Varying(values),
        }
    }

    /// The single value, if uniform.
    pub fn uniform(&self) -> Option<f64> {
        match self {
            PerNode::Uniform(v) => Some(*v),
            PerNode::Varying(_) => None,
        }
    }

    /// Smallest and largest value.
    pub fn range(&self) -> (f64, f64) {
        match self {
            PerNode::Uniform(v) => (*v, *v),
            PerNode::Varying(v) => v
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
                    (a.min(x), b.max(x))
                }),
        }
    }
}
