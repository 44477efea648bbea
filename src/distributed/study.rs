//! A study's runs spread over ranks (`mpirun -np N peridyn study`): each run is a
//! single-process run on one rank. The pending runs go out in rounds of one per rank (rank r
//! runs the round's r-th), and after each round rank 0 collects the outcomes in run order.
//! Static rounds rather than a queue through rank 0: the runs of a study are one deck with
//! other numbers, of about the same length, so a round waits little for its slowest run, and
//! rank 0 can rewrite `runs.csv` after each round exactly as the serial study does after the
//! same runs (so a stopped study continues the same way).

use crate::solver::ranks::Ranks;

/// What one run of the study gave: its status ("ok" or "failed: …"), its outputs and its
/// wall time.
#[derive(Debug, Clone, PartialEq)]
pub struct Outcome {
    pub status: String,
    pub outputs: Vec<Option<f64>>,
    pub seconds: f64,
}

/// The runs (indices into the design) of each round on `size` ranks: the pending ones in
/// order, `size` at a time.
pub fn rounds(pending: &[usize], size: usize) -> impl Iterator<Item = &[usize]> {
    pending.chunks(size.max(1))
}

/// Every rank's outcome of a round of `runs` runs on rank 0, in rank (= run) order; `mine`
/// is this rank's (`None` on ranks past the round's end). A study error on any rank (a file
/// it cannot write) is every rank's: the lowest rank's message.
pub fn collect(
    ranks: &dyn Ranks,
    runs: usize,
    mine: Option<Result<Outcome, String>>,
) -> Result<Option<Vec<Outcome>>, String> {
    let error = mine.as_ref().and_then(|m| m.as_ref().err().cloned());
    if let Some(message) = ranks.first_message(error) {
        return Err(message);
    }
    let words = mine.and_then(Result::ok).map_or(Vec::new(), |o| encode(&o));
    let Some(all) = ranks.gather(&words) else {
        return Ok(None);
    };
    let mut rest = all.as_slice();
    let outcomes = (0..runs).map(|_| decode(&mut rest)).collect();
    Ok(Some(outcomes))
}

/// An outcome as f64 words: seconds, the status's length and UTF-8 bytes, the number of
/// outputs, then a flag (1: a value) and the value of each. Every word is exact.
fn encode(o: &Outcome) -> Vec<f64> {
    let mut w = vec![o.seconds, o.status.len() as f64];
    w.extend(o.status.bytes().map(f64::from));
    w.push(o.outputs.len() as f64);
    for v in &o.outputs {
        w.extend([v.is_some() as u8 as f64, v.unwrap_or(0.0)]);
    }
    w
}

/// Reads one `encode`d outcome off the front of `words`.
fn decode(words: &mut &[f64]) -> Outcome {
    let mut take = |n: usize| {
        let (head, tail) = words.split_at(n);
        *words = tail;
        head
    };
    let seconds = take(1)[0];
    let len = take(1)[0] as usize;
    let bytes: Vec<u8> = take(len).iter().map(|&b| b as u8).collect();
    let n = take(1)[0] as usize;
    let outputs = take(2 * n)
        .chunks_exact(2)
        .map(|p| (p[0] == 1.0).then_some(p[1]))
        .collect();
    Outcome {
        status: String::from_utf8_lossy(&bytes).into_owned(),
        outputs,
        seconds,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::distributed::thread_ranks::ThreadRanks;

    fn outcome(k: usize) -> Outcome {
        Outcome {
            status: if k == 1 {
                "failed: Δx, ½".into()
            } else {
                "ok".into()
            },
            outputs: vec![Some(0.1 * k as f64 + f64::EPSILON), None, Some(-0.0)],
            seconds: k as f64 + 0.5,
        }
    }

    #[test]
    fn rounds_take_one_pending_run_per_rank() {
        let pending = [1, 2, 4, 5, 6];
        let r: Vec<&[usize]> = rounds(&pending, 2).collect();
        assert_eq!(r, [&[1, 2][..], &[4, 5], &[6]]);
    }

    #[test]
    fn rank_zero_collects_every_outcome_bit_for_bit_in_run_order() {
        // A round of 2 runs on 3 ranks: rank 2 has none.
        let got = ThreadRanks::run(3, |ranks| {
            let r = ranks.rank();
            collect(&*ranks, 2, (r < 2).then(|| Ok(outcome(r))))
        });
        let outcomes = got[0].clone().unwrap().unwrap();
        assert_eq!(outcomes, vec![outcome(0), outcome(1)]);
        assert_eq!(
            outcomes[0].outputs[2].unwrap().to_bits(),
            (-0.0f64).to_bits()
        );
        assert!(got[1].as_ref().unwrap().is_none() && got[2].as_ref().unwrap().is_none());
        // An error on rank 1 ends the round on every rank.
        let got = ThreadRanks::run(2, |ranks| {
            let mine = match ranks.rank() {
                1 => Err("cannot write runs/run_0001".to_string()),
                _ => Ok(outcome(0)),
            };
            collect(&*ranks, 2, Some(mine))
        });
        for g in got {
            assert_eq!(g.unwrap_err(), "cannot write runs/run_0001");
        }
    }
}
