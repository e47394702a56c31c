//! The deterministic expansion of a grid into jobs (combination x sequence) and the shards.

use crate::error::SweepError;
use crate::grid::{Combination, Grid};
use std::fmt;
use std::str::FromStr;

/// One job: a combination of the grid on one sequence.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Job {
    /// The job number, `combination * sequences + sequence`, in `0..Plan::jobs()`.
    pub index: usize,
    /// Index into [`Plan::combinations`].
    pub combination: usize,
    /// Index into [`Plan::sequences`].
    pub sequence: usize,
}

/// The I-th of N disjoint slices of a sweep (`--shard I/N`, 1-based): job `i` belongs to shard
/// `i % N + 1`. Round robin, so that every shard gets a similar mix of cheap and expensive
/// combinations; the shards of one N are disjoint and together hold every job.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shard {
    /// 1-based shard number.
    pub index: usize,
    /// Number of shards.
    pub count: usize,
}

impl Shard {
    /// Whether job number `job` belongs to this shard.
    pub fn contains(&self, job: usize) -> bool {
        job % self.count + 1 == self.index
    }
}

impl fmt::Display for Shard {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

impl FromStr for Shard {
    type Err = SweepError;

    /// `I/N` with `1 <= I <= N`.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let bad = || {
            SweepError::Input(format!(
                "--shard {s}: expected I/N with 1 <= I <= N (e.g. 3/8)"
            ))
        };
        let (i, n) = s.split_once('/').ok_or_else(bad)?;
        let index: usize = i.trim().parse().map_err(|_| bad())?;
        let count: usize = n.trim().parse().map_err(|_| bad())?;
        if index == 0 || count == 0 || index > count {
            return Err(bad());
        }
        Ok(Shard { index, count })
    }
}

/// The jobs of a grid on named sequences, and the id that ties shards of one sweep together.
#[derive(Clone, Debug)]
pub struct Plan {
    /// The grid's combinations in order ([`Grid::combinations`]).
    pub combinations: Vec<Combination>,
    /// Sequence names (directory names), in the order given.
    pub sequences: Vec<String>,
    /// A 64-bit FNV-1a hash (hex) of the grid's canonical form and the sequence names: equal
    /// for every shard of one sweep, different for another grid.
    pub grid_id: String,
    /// The index of the combination equal to [`momo_vo::Config::default`], if the grid has it.
    pub default_combination: Option<usize>,
}

/// FNV-1a, 64 bit: a stable hash that does not depend on the Rust version.
fn fnv1a(text: &str) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in text.bytes() {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    h
}

impl Plan {
    /// The plan of `grid` on sequences named `sequences` (names must be unique).
    pub fn new(grid: &Grid, sequences: &[String]) -> Result<Self, SweepError> {
        if sequences.is_empty() {
            return Err(SweepError::Input("no sequences given".into()));
        }
        for (i, s) in sequences.iter().enumerate() {
            if sequences[..i].contains(s) {
                return Err(SweepError::Input(format!(
                    "two sequences are named `{s}`: results are keyed by directory name, rename one"
                )));
            }
        }
        let combinations = grid.combinations();
        let grid_id = format!(
            "{:016x}",
            fnv1a(&format!(
                "{}#{}",
                grid.canonical(),
                sequences.join("\u{1f}")
            ))
        );
        let default_combination = combinations.iter().position(Combination::is_default);
        Ok(Self {
            combinations,
            sequences: sequences.to_vec(),
            grid_id,
            default_combination,
        })
    }

    /// Number of jobs: combinations x sequences.
    pub fn jobs(&self) -> usize {
        self.combinations.len() * self.sequences.len()
    }

    /// Job number `index` (`index < jobs()`).
    pub fn job(&self, index: usize) -> Job {
        let s = self.sequences.len().max(1);
        Job {
            index,
            combination: index / s,
            sequence: index % s,
        }
    }

    /// The jobs of a shard (all jobs for `None`), in job order.
    pub fn jobs_of(&self, shard: Option<Shard>) -> Vec<Job> {
        (0..self.jobs())
            .filter(|&i| shard.is_none_or(|s| s.contains(i)))
            .map(|i| self.job(i))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shards_are_disjoint_and_cover_every_job() {
        for n in 1..6 {
            let mut seen = vec![0; 23];
            for i in 1..=n {
                let s: Shard = format!("{i}/{n}").parse().expect("valid");
                for j in 0..23 {
                    if s.contains(j) {
                        seen[j] += 1;
                    }
                }
            }
            assert!(seen.iter().all(|&c| c == 1), "n = {n}: {seen:?}");
        }
    }

    #[test]
    fn bad_shards_are_rejected() {
        for s in ["0/2", "3/2", "1/0", "1", "a/b", "1/2/3", ""] {
            assert!(s.parse::<Shard>().is_err(), "{s}");
        }
        assert_eq!(
            " 2 / 5 ".trim().parse::<Shard>().ok(),
            Some(Shard { index: 2, count: 5 })
        );
    }

    #[test]
    fn fnv_is_stable() {
        // Published FNV-1a 64 test vectors.
        assert_eq!(fnv1a(""), 0xcbf2_9ce4_8422_2325);
        assert_eq!(fnv1a("a"), 0xaf63_dc4c_8601_ec8c);
    }
}
