//! Order statistics shared by the run's memories (the road score's drop,
//! [`crate::ground_drop`]; the tilt reference, [`crate::hypotheses::HypothesisTracker::tilt_reference`];
//! the road arc lengths of `odometry.road_scale_frames`).

/// The median of `values`: the middle value of an odd count, the mean of the two middle values
/// of an even count; `None` if there are none. NaN sorts last ([`f64::total_cmp`]).
pub(crate) fn median(values: impl IntoIterator<Item = f64>) -> Option<f64> {
    let mut v: Vec<f64> = values.into_iter().collect();
    v.sort_by(f64::total_cmp);
    let n = v.len();
    match n {
        0 => None,
        _ if n % 2 == 1 => Some(v[n / 2]),
        _ => Some(0.5 * (v[n / 2 - 1] + v[n / 2])),
    }
}

/// The smallest of `values` ([`f64::total_cmp`]); `None` if there are none.
pub(crate) fn minimum(values: impl IntoIterator<Item = f64>) -> Option<f64> {
    values.into_iter().min_by(f64::total_cmp)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn median_of_even_and_odd_counts() {
        assert_eq!(median([]), None);
        assert_eq!(median([3.0, 1.0, 2.0]), Some(2.0));
        assert_eq!(median([4.0, 1.0, 2.0, 3.0]), Some(2.5));
        assert_eq!(median([0.25]), Some(0.25));
    }

    #[test]
    fn minimum_of_values() {
        assert_eq!(minimum([]), None);
        assert_eq!(minimum([0.3, -0.1, 0.2]), Some(-0.1));
    }
}
