//! Essential matrix → camera motion: the four `(R, ±t)` candidates and the cheirality test
//! (what OpenCV's `decomposeEssentialMat` and `recoverPose` do), in this crate's convention.

use momo_core::{Observation, Pose};
use nalgebra::{Matrix3, Vector3};

/// The four camera motions `C = [R | t]` (unit `t`) with `E ∝ Rᵀ [t]ₓ` ([`momo_core::essential`]).
///
/// `Eᵀ = -[t]ₓ R` has the textbook form `[t]ₓ R`, so the textbook SVD decomposition of `Eᵀ`
/// (`R = U W Vᵀ` or `U Wᵀ Vᵀ`, `t = ±u₃`) gives `C` directly. `None` if the SVD fails or `E`
/// is not finite.
pub fn decompose_essential(e: &Matrix3<f64>) -> Option<[Pose<f64>; 4]> {
    if !e.iter().all(|v| v.is_finite()) {
        return None;
    }
    let svd = e.transpose().try_svd(true, true, f64::EPSILON, 500)?;
    let mut u = svd.u?;
    let mut v_t = svd.v_t?;
    // Sort so that the smallest singular value is the third one.
    let s = svd.singular_values;
    let k = s.imin();
    if k != 2 {
        u.swap_columns(k, 2);
        v_t.swap_rows(k, 2);
    }
    if u.determinant() < 0.0 {
        u = -u;
    }
    if v_t.determinant() < 0.0 {
        v_t = -v_t;
    }
    let w = Matrix3::new(0.0, -1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0);
    let r1 = u * w * v_t;
    let r2 = u * w.transpose() * v_t;
    let t: Vector3<f64> = u.column(2).into_owned();
    Some([
        Pose::new(r1, t),
        Pose::new(r1, -t),
        Pose::new(r2, t),
        Pose::new(r2, -t),
    ])
}

/// Depths `(λ0, λ1)` of the midpoint triangulation of a match under the camera motion `c`:
/// the least-squares solution of `λ0 f0 = λ1 R f1 + t` (the scene point in frame k-1 is
/// `λ0 f0`, in frame k `λ1 f1`). `None` for (nearly) parallel rays.
pub fn triangulate_depths(c: &Pose<f64>, obs: &Observation) -> Option<(f64, f64)> {
    let a = obs.f0.try_normalize(0.0)?;
    let b = (c.rotation * obs.f1).try_normalize(0.0)?;
    let ab = a.dot(&b);
    let det = 1.0 - ab * ab;
    if !(det > 1e-12) {
        return None;
    }
    let (at, bt) = (a.dot(&c.translation), b.dot(&c.translation));
    let l0 = (at - ab * bt) / det;
    let l1 = (ab * at - bt) / det;
    Some((l0 / obs.f0.norm(), l1 / obs.f1.norm()))
}

/// Number of matches triangulated in front of both cameras (both midpoint depths positive).
pub fn count_in_front<'a>(c: &Pose<f64>, obs: impl IntoIterator<Item = &'a Observation>) -> usize {
    obs.into_iter()
        .filter(|o| matches!(triangulate_depths(c, o), Some((l0, l1)) if l0 > 0.0 && l1 > 0.0))
        .count()
}

/// The candidate of [`decompose_essential`] with the most matches in front of both cameras
/// (`recoverPose`), and that count. `None` if the decomposition fails or no match is in front.
pub fn recover_pose<'a>(
    e: &Matrix3<f64>,
    obs: impl IntoIterator<Item = &'a Observation> + Clone,
) -> Option<(Pose<f64>, usize)> {
    let candidates = decompose_essential(e)?;
    let mut best: Option<(Pose<f64>, usize)> = None;
    for c in candidates {
        let n = count_in_front(&c, obs.clone());
        if n > 0 && best.as_ref().is_none_or(|(_, b)| n > *b) {
            best = Some((c, n));
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;
    use momo_core::{essential, so3_exp};

    fn same_up_to_scale(a: &Matrix3<f64>, b: &Matrix3<f64>) -> f64 {
        let (a, b) = (a.normalize(), b.normalize());
        (a - b).amax().min((a + b).amax())
    }

    #[test]
    fn every_candidate_reproduces_e_and_one_is_the_truth() {
        let c = Pose::new(
            so3_exp(&Vector3::new(0.1, -0.2, 0.05)),
            Vector3::new(0.3, -0.1, 0.9).normalize(),
        );
        let e = essential(&c);
        let cands = decompose_essential(&e).unwrap();
        for k in &cands {
            assert!(same_up_to_scale(&essential(k), &e) < 1e-12);
            assert!((k.rotation.determinant() - 1.0).abs() < 1e-12);
        }
        assert!(
            cands
                .iter()
                .any(|k| (k.rotation - c.rotation).amax() < 1e-12
                    && (k.translation - c.translation).amax() < 1e-12)
        );
    }

    #[test]
    fn cheirality_picks_the_true_motion() {
        let c = Pose::new(
            so3_exp(&Vector3::new(0.02, 0.1, -0.03)),
            Vector3::new(0.1, 0.05, 1.0).normalize(),
        );
        let obs: Vec<Observation> = [[1.0, 0.5, 6.0], [-2.0, 0.3, 9.0], [0.4, -1.0, 5.0]]
            .iter()
            .map(|p| {
                let x0 = Vector3::from(*p);
                let x1 = c.inverse().transform_point(&x0);
                Observation {
                    px0: Default::default(),
                    px1: Default::default(),
                    f0: x0.normalize(),
                    f1: x1.normalize(),
                }
            })
            .collect();
        let (best, n) = recover_pose(&(-essential(&c)), &obs).unwrap();
        assert_eq!(n, 3);
        assert!((best.rotation - c.rotation).amax() < 1e-12);
        assert!((best.translation - c.translation).amax() < 1e-12);
        let (l0, _) = triangulate_depths(&c, &obs[0]).unwrap();
        assert!((l0 - Vector3::new(1.0_f64, 0.5, 6.0).norm()).abs() < 1e-9);
    }
}
