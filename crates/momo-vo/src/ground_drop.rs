//! The road score's drop (issue 14, the trust gap of the slow pulls;
//! [`crate::separate::SeparateOptions::ground_drop`]): a frame whose chosen motion puts far
//! fewer image cells of matches on the road than the recent frames' chosen motions did is
//! flagged `weak` / `road_score_drop`.
//!
//! A motion that follows a vehicle ahead (a *slow pull*: A, and every alternative started from
//! it, 1-1.7 deg off) keeps most of the matches in its support, so neither a second motion nor
//! the covariance's checks see it, and its covariance is that of a well-constrained frame (the
//! error 5-28 sigma). What does change is the road: the static world's road points
//! triangulate onto the road plane only under the right motion at its metric scale
//! ([`crate::hypotheses::ground_mask`]), so the pulled motion's road score (the image cells of
//! its supporting road matches, [`crate::hypotheses::score`] with `spread_grid`) falls from the
//! sequence's usual 15-40 cells to 0-8. The test compares the chosen motion's score `s_k` with
//! the median `m_k` of the scores of the last [`GROUND_DROP_WINDOW`] frames' chosen motions
//! (at least [`GROUND_DROP_MIN_FRAMES`] of them): the frame is flagged where `m_k >= min` and
//! `s_k <= ratio · m_k`. A scene without a visible road (`m_k < min`) is never flagged.

use std::collections::VecDeque;

/// The frames whose chosen motions' road scores make the reference median.
pub const GROUND_DROP_WINDOW: usize = 20;

/// The fewest remembered scores before a frame may be flagged.
pub const GROUND_DROP_MIN_FRAMES: usize = 5;

/// Whether `score` dropped against the recent road scores `recent`: their median `m` is at
/// least `min` (a road was seen) and `score <= ratio · m`. False without scores.
pub fn dropped(recent: impl Iterator<Item = usize>, score: usize, ratio: f64, min: usize) -> bool {
    crate::stats::median(recent.map(|s| s as f64))
        .is_some_and(|m| m >= min as f64 && score as f64 <= ratio * m)
}

/// Whether the frame's road score `score` dropped against `history` (the last
/// [`GROUND_DROP_WINDOW`] frames' scores, before this frame's): the median `m` of at least
/// [`GROUND_DROP_MIN_FRAMES`] scores is at least `min` and `score <= ratio · m` (`ratio > 0`).
pub fn fires(history: &VecDeque<usize>, score: usize, ratio: f64, min: usize) -> bool {
    ratio > 0.0
        && history.len() >= GROUND_DROP_MIN_FRAMES
        && dropped(history.iter().copied(), score, ratio, min)
}

/// Records the chosen motion's road score `score` of the frame in `history` (the last
/// [`GROUND_DROP_WINDOW`] frames' scores) and returns whether it dropped ([`fires`], against
/// the scores before it).
pub fn observe(history: &mut VecDeque<usize>, score: usize, ratio: f64, min: usize) -> bool {
    let dropped = fires(history, score, ratio, min);
    history.push_back(score);
    while history.len() > GROUND_DROP_WINDOW {
        history.pop_front();
    }
    dropped
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_drop_below_the_ratio_of_the_recent_median_is_flagged() {
        let mut h = VecDeque::new();
        // Too few frames: never flagged.
        for s in [20, 22, 18, 25] {
            assert!(!observe(&mut h, s, 0.4, 8));
        }
        assert!(!observe(&mut h, 21, 0.4, 8));
        // Median 21: 8 <= 0.4 * 21 = 8.4 is flagged, 9 is not.
        assert!(observe(&mut h.clone(), 8, 0.4, 8));
        assert!(!observe(&mut h.clone(), 9, 0.4, 8));
        // Off.
        assert!(!observe(&mut h.clone(), 0, 0.0, 8));
        // The window keeps the last frames only.
        for _ in 0..GROUND_DROP_WINDOW {
            observe(&mut h, 3, 0.4, 8);
        }
        assert_eq!(h.len(), GROUND_DROP_WINDOW);
        // A scene without a visible road (median 3 < 8) is never flagged.
        assert!(!observe(&mut h, 0, 0.4, 8));
    }

    #[test]
    fn the_option_is_validated() {
        use crate::separate::SeparateOptions;
        for (q, ok) in [
            (0.0, true),
            (0.4, true),
            (1.0, false),
            (-0.1, false),
            (f64::NAN, false),
        ] {
            let o = SeparateOptions {
                ground_drop: q,
                ..SeparateOptions::competition_over_time()
            };
            assert_eq!(o.validate().is_ok(), ok, "ground_drop = {q}");
        }
    }
}
