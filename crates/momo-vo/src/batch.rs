//! Many independent frame pairs estimated in parallel (offline use: sweeps, the Python
//! bindings, re-estimating selected frames).
//!
//! Each pair goes through the whole driver ([`Odometry::process`]: checks, restarts,
//! covariance, diagnostics) as the first frame of a fresh run, started from the pair's own
//! warm start if it has one; no state passes from one pair to another, so the results do not
//! depend on the order or on the number of threads (bit-identical, tested). Work is spread
//! over a rayon pool with one driver per worker, reset between pairs ([`Odometry::reset`]).
//!
//! ```
//! use momo_vo::batch::{FramePair, estimate_batch};
//! use momo_vo::Config;
//! use momo_core::{FrameObservations, Pose, so3_exp};
//! use momo_testing::canned;
//! use nalgebra::Vector3;
//!
//! let rig = canned::pinhole_rig();
//! let truth = Pose::new(so3_exp(&Vector3::new(0.0, 0.0, 0.02)), Vector3::new(1.0, 0.01, 0.0));
//! let pairs: Vec<FramePair> = (0..4)
//!     .map(|seed| FramePair::new(canned::synthetic_observations(&rig, &truth, 100, 0, seed), Some(1.0)))
//!     .collect();
//! let results = estimate_batch(&rig, &Config::default(), &pairs, 2).unwrap();
//! assert_eq!(results.len(), 4);
//! for r in &results {
//!     let yaw = momo_core::so3_log(&r.motion.rotation).z;
//!     assert!((yaw - 0.02).abs() < 1e-6);
//! }
//! ```

use crate::config::Config;
use crate::odometry::{FrameResult, Odometry, VoError};
use momo_core::{FrameObservations, Rig};
use rayon::prelude::*;
use thiserror::Error;

/// One independent frame pair of a batch.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FramePair {
    /// The pair's matches per camera.
    pub observations: FrameObservations,
    /// The arc length travelled, if known (odometry).
    pub arc_length: Option<f64>,
    /// A warm start (full parameter vector of the model), e.g. the motion of a neighbouring
    /// frame; `None` or a vector of the wrong length: straight ahead (as a run's first frame).
    pub initial: Option<Vec<f64>>,
}

impl FramePair {
    /// A pair without a warm start.
    pub fn new(observations: FrameObservations, arc_length: Option<f64>) -> Self {
        Self {
            observations,
            arc_length,
            initial: None,
        }
    }
}

/// Errors of [`estimate_batch`].
#[derive(Debug, Error)]
pub enum BatchError {
    /// The configuration does not fit the rig (as [`Odometry::new`] reports it).
    #[error(transparent)]
    Vo(#[from] VoError),
    /// The configuration could not be copied for the workers.
    #[error("the configuration could not be copied for the workers: {0}")]
    Copy(String),
    /// The thread pool could not be built.
    #[error("the thread pool could not be built: {0}")]
    Threads(String),
}

/// A copy of a configuration (through its serialised form: the trait objects are not `Clone`).
fn copy_config(config: &Config) -> Result<Config, BatchError> {
    let value = serde_json::to_value(config).map_err(|e| BatchError::Copy(e.to_string()))?;
    let mut copy: Config =
        serde_json::from_value(value).map_err(|e| BatchError::Copy(e.to_string()))?;
    copy.origin = config.origin.clone();
    Ok(copy)
}

/// Estimates every pair independently, in parallel over `threads` threads (0: rayon's default,
/// one per core), and returns the results in the order of `pairs`. Each result's
/// `diagnostics.frame` is the pair's index plus one.
///
/// Fails only if the configuration does not fit the rig (checked once, before any pair).
pub fn estimate_batch(
    rig: &Rig,
    config: &Config,
    pairs: &[FramePair],
    threads: usize,
) -> Result<Vec<FrameResult>, BatchError> {
    // Validates the configuration against the rig (the error a run would report).
    let first = Odometry::new(rig.clone(), copy_config(config)?)?;
    drop(first);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| BatchError::Threads(e.to_string()))?;
    pool.install(|| {
        pairs
            .par_iter()
            .enumerate()
            .map_init(
                || {
                    copy_config(config)
                        .and_then(|c| Odometry::new(rig.clone(), c).map_err(BatchError::from))
                },
                |vo, (i, pair)| {
                    let vo = vo.as_mut().map_err(|e| BatchError::Copy(e.to_string()))?;
                    vo.reset(pair.initial.as_deref());
                    let mut result = vo.process(&pair.observations, pair.arc_length);
                    result.diagnostics.frame = i + 1;
                    Ok(result)
                },
            )
            .collect()
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use momo_core::{Pose, so3_exp};
    use momo_testing::canned;
    use nalgebra::Vector3;

    fn pairs(rig: &Rig, n: usize) -> Vec<FramePair> {
        (0..n)
            .map(|i| {
                let yaw = 0.01 * (i as f64 - 3.0);
                let truth = Pose::new(
                    so3_exp(&Vector3::new(0.0, 0.0, yaw)),
                    Vector3::new(1.0, 0.5 * yaw, 0.0),
                );
                let mut p = FramePair::new(
                    canned::synthetic_observations(rig, &truth, 60, 6, i as u64),
                    Some(1.0),
                );
                if i % 2 == 1 {
                    p.initial = Some(vec![0.0, 0.0, yaw, 0.5 * yaw, 0.0, 1.0]);
                }
                p
            })
            .collect()
    }

    /// The same as a fresh driver per pair, whatever the number of threads, in input order.
    #[test]
    fn independent_of_threads_and_equal_to_fresh_drivers() {
        let rig = canned::pinhole_rig();
        let pairs = pairs(&rig, 9);
        let one = estimate_batch(&rig, &Config::default(), &pairs, 1).expect("fits");
        let two = estimate_batch(&rig, &Config::default(), &pairs, 2).expect("fits");
        assert_eq!(one.len(), pairs.len());
        for (i, pair) in pairs.iter().enumerate() {
            let mut vo = Odometry::new(rig.clone(), Config::default()).expect("fits");
            if let Some(init) = &pair.initial {
                vo.reset(Some(init));
            }
            let fresh = vo.process(&pair.observations, pair.arc_length);
            for r in [&one[i], &two[i]] {
                assert_eq!(r.diagnostics.params, fresh.diagnostics.params, "pair {i}");
                assert_eq!(r.diagnostics.status, fresh.diagnostics.status);
                assert_eq!(r.diagnostics.frame, i + 1);
            }
            let yaw = momo_core::so3_log(&one[i].motion.rotation).z;
            assert!(
                (yaw - 0.01 * (i as f64 - 3.0)).abs() < 1e-4,
                "pair {i}: {yaw}"
            );
        }
    }

    /// A configuration that does not fit the rig fails before any pair.
    #[test]
    fn a_config_that_does_not_fit_fails() {
        let rig = canned::fisheye_rig();
        let config =
            Config::from_toml_str("[metric]\ntype = \"geo_line\"\n", "t.toml").expect("parses");
        let err = estimate_batch(&rig, &config, &pairs(&canned::pinhole_rig(), 2), 1);
        assert!(err.is_err());
    }
}
