//! The slow pulls of the moving-traffic family (issue 14): a bus or a lead vehicle that the
//! first motion follows part of the way, with every alternative started from it pulled too.
//! The road track (`[odometry.separate] road_track`) and the road score's drop
//! (`ground_drop`), both off by default; measured in docs/RESULTS.md §9 (seventeenth session,
//! pull31).

use crate::support::{errors_and_diagnostics, sixteenth_session_defaults};
use momo_sim::{SimConfig, Simulation, simulate};
use momo_vo::trust::Reason;
use momo_vo::{Config, FrameStatus, Odometry};

/// Per frame pair: the rotation error (deg), the status and the reason.
fn run(sim: &Simulation, toml: &str) -> Vec<(f64, FrameStatus, Option<Reason>)> {
    let config = Config::from_toml_str(toml, "test").expect("valid config");
    errors_and_diagnostics(sim, config)
        .into_iter()
        .map(|(e, d)| (e, d.status, d.reason))
        .collect()
}

fn sim(base: SimConfig, frames: usize, seed: u64) -> Simulation {
    simulate(&SimConfig {
        frames,
        seed,
        ..base
    })
    .expect("simulation")
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// The road track: the motion re-solved on the road from the previous frame's road track, not
/// from the pulled chosen motion, admitted by its road score. Built-in drive, moving traffic,
/// seed 2, 300 frames: fewer frames above 0.5 deg and a lower mean error (measured 23 -> 21,
/// 0.141 -> 0.136 deg); a static scene's estimates do not change. Measured against the
/// sixteenth session's defaults (with the seventeenth's, 12 -> 13 frames: the road track is
/// not in the default).
#[test]
fn the_road_track_is_not_carried_along_by_a_slow_pull() {
    let on = &sixteenth_session_defaults("road_track = true\n");
    let base = &sixteenth_session_defaults("");
    let s = sim(SimConfig::moving_traffic(), 300, 2);
    let (off, with) = (run(&s, base), run(&s, on));
    let above = |r: &[(f64, FrameStatus, Option<Reason>)]| r.iter().filter(|x| x.0 > 0.5).count();
    let mean = |r: &[(f64, FrameStatus, Option<Reason>)]| {
        r.iter().map(|x| x.0).sum::<f64>() / r.len() as f64
    };
    // Measured: above 0.5 deg 23 -> 21, mean 0.1414 -> 0.1358 deg.
    assert!(
        above(&with) < above(&off),
        "{} vs {}",
        above(&with),
        above(&off)
    );
    assert!(
        mean(&with) < mean(&off),
        "{} vs {}",
        mean(&with),
        mean(&off)
    );
    let s = sim(SimConfig::clean_pinhole(), 150, 1);
    assert_eq!(run(&s, base), run(&s, on), "a static scene is not changed");
}

/// The road score's drop flags the frames whose chosen motion follows a vehicle ahead: built-in
/// drive, moving traffic, seed 2, 300 frames, the flagged frames' median error at least 5x the
/// estimated frames' (measured 0.529 against 0.057 deg); a static scene (clean and outliers,
/// 150 frames) has no flagged frame and the same estimates. Measured against the sixteenth
/// session's defaults (`ground_drop = 0.4` is the default since the seventeenth).
#[test]
fn a_drop_of_the_road_score_flags_the_pulled_frames() {
    let on = &sixteenth_session_defaults("ground_drop = 0.4\n");
    let base = &sixteenth_session_defaults("");
    let s = sim(SimConfig::moving_traffic(), 300, 2);
    let r = run(&s, on);
    let flagged: Vec<f64> = r
        .iter()
        .filter(|x| x.2 == Some(Reason::RoadScoreDrop))
        .map(|x| x.0)
        .collect();
    let estimated: Vec<f64> = r
        .iter()
        .filter(|x| x.1 == FrameStatus::Estimated)
        .map(|x| x.0)
        .collect();
    // Measured: 12 flagged, median 0.529 deg; 122 estimated, median 0.057 deg.
    assert!(flagged.len() >= 6, "{} flagged", flagged.len());
    assert!(
        median(flagged.clone()) >= 5.0 * median(estimated.clone()),
        "flagged {:.3} deg against estimated {:.3}",
        median(flagged),
        median(estimated)
    );
    for (scenario, seed) in [(SimConfig::clean_pinhole(), 1), (SimConfig::outliers(), 1)] {
        let s = sim(scenario, 150, seed);
        let r = run(&s, on);
        assert!(r.iter().all(|x| x.2 != Some(Reason::RoadScoreDrop)));
        assert_eq!(r, run(&s, base), "a static scene is not changed");
    }
}

/// The road's alternatives in the covariance (`[trust] road_alternative_weight = 1`, the
/// default, against 0): on the frames whose road score dropped (flagged `road_score_drop`, or
/// `competing_motions` where two motions competed too) the reported covariance `Σ + w Σ_j d_j d_jᵀ`
/// covers the road's alternative (the previous motion re-solved on its road matches, where there
/// is one) and the previous frame's motion at one standard deviation (`dᵀ Σ'⁻¹ d <= 1/w`); with
/// `after_flag_weight = 1` (default) too, so does an estimated frame right after a flagged one cover the
/// previous frame's motion. Every other frame's covariance, every pose and every status stay as
/// without them. Built-in drive, moving traffic, seeds 2 and 3, 300 frames, the current
/// defaults (a frame that `odometry.decide_by_road` replaced covers them from the replacement).
#[test]
fn a_road_score_drop_frames_sigma_covers_the_road_alternative() {
    let (mut widened, mut road, mut after) = (0, 0, 0);
    // Two drives (seeds 2 and 3): enough frames of each kind under the current defaults.
    for seed in [2, 3] {
        let (w, r, a) = road_score_drop_frames_on(seed);
        (widened, road, after) = (widened + w, road + r, after + a);
    }
    // At least six of each over the two drives (the counts are in the message if not).
    assert!(
        widened >= 6 && road >= 6 && after >= 6,
        "{widened} road_score_drop frames widened ({road} with a road alternative), {after} \
         estimated frames after a flagged one"
    );
}

/// One drive of [`a_road_score_drop_frames_sigma_covers_the_road_alternative`]: asserts its
/// invariants and returns the counts of widened road-score-drop frames, of those with a road
/// alternative and of widened frames after a flagged one.
fn road_score_drop_frames_on(seed: u64) -> (usize, usize, usize) {
    let s = sim(SimConfig::moving_traffic(), 300, seed);
    let seq = &s.sequence;
    let results = |toml: &str| {
        let config = Config::from_toml_str(toml, "test").expect("valid config");
        let mut vo = Odometry::new(seq.rig.clone(), config).expect("valid config");
        (1..seq.num_frames())
            .map(|k| vo.process(&seq.frames[k], seq.arc_lengths.as_ref().and_then(|a| a[k])))
            .collect::<Vec<_>>()
    };
    let off = results("[trust]\nroad_alternative_weight = 0.0\nafter_flag_weight = 0.0\n");
    let on = results("");
    // The Mahalanobis distance of `c` from the frame's estimate under its reported covariance.
    let distance = |d: &momo_vo::FrameDiagnostics, c: &[f64]| -> f64 {
        let k = d.free.len();
        let cov = nalgebra::DMatrix::from_row_slice(k, k, &d.covariance);
        let v = nalgebra::DVector::from_iterator(k, d.free.iter().map(|&i| c[i] - d.params[i]));
        let inv = cov.try_inverse().expect("invertible covariance");
        (v.transpose() * inv * &v)[(0, 0)]
    };
    let flagged = |d: &momo_vo::FrameDiagnostics| {
        d.status == FrameStatus::Weak
            && matches!(
                d.reason,
                Some(Reason::RoadScoreDrop | Reason::CompetingMotions)
            )
    };
    let (mut widened, mut road, mut after) = (0, 0, 0);
    for (k, (a, b)) in off.iter().zip(&on).enumerate() {
        let (da, db) = (&a.diagnostics, &b.diagnostics);
        assert_eq!(
            a.motion, b.motion,
            "frame {}: the pose is unchanged",
            da.frame
        );
        assert_eq!(
            (da.status, da.reason),
            (db.status, db.reason),
            "frame {}",
            da.frame
        );
        // A frame flagged by two competing motions whose road score dropped too is widened
        // as a `road_score_drop` frame.
        let road_drop = db.reason == Some(Reason::RoadScoreDrop)
            || (db.reason == Some(Reason::CompetingMotions) && da.covariance != db.covariance);
        // (A frame that `trust.unconfirmed_start` flags, report only, was `estimated` when the
        // after-flag widening applied.)
        let estimated =
            db.status == FrameStatus::Estimated || db.reason == Some(Reason::UnconfirmedStart);
        let after_flag = k > 0 && estimated && flagged(&on[k - 1].diagnostics);
        if !road_drop && !after_flag {
            assert_eq!(
                da.covariance
                    .iter()
                    .map(|v| v.to_bits())
                    .collect::<Vec<_>>(),
                db.covariance
                    .iter()
                    .map(|v| v.to_bits())
                    .collect::<Vec<_>>(),
                "frame {}",
                da.frame
            );
            assert!(db.road_alternative.is_none());
            continue;
        }
        // A covariance that could not be computed (an ill-conditioned normal matrix: infinite
        // entries) covers every alternative: its sigmas are not finite.
        if !db.covariance.iter().all(|v| v.is_finite()) {
            assert!(db.free.iter().any(|&i| !db.param_sigmas[i].is_finite()));
            assert_ne!(db.status, FrameStatus::Estimated, "frame {}", db.frame);
            continue;
        }
        if let Some(c) = &db.road_alternative {
            let m = distance(db, c);
            assert!(
                m <= 1.0 + 1e-6,
                "frame {}: road alternative d'S^-1 d = {m}",
                db.frame
            );
            road += 1;
        }
        if k > 0 {
            let m = distance(db, &on[k - 1].diagnostics.params);
            assert!(
                m <= 1.0 + 1e-6,
                "frame {}: previous motion d'S^-1 d = {m}",
                db.frame
            );
        }
        assert!(
            db.free
                .iter()
                .all(|&i| db.param_sigmas[i] >= da.param_sigmas[i])
                && db.covariance != da.covariance,
            "frame {}: widened",
            db.frame
        );
        widened += usize::from(road_drop);
        after += usize::from(after_flag);
    }
    (widened, road, after)
}
