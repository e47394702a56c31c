//! The elementary rotations and the circular-arc chord (`momo_models::rotation`), as public
//! functions: moved from the crate's unit tests so that `cargo test` compiles the crate once.

use momo_core::check::derivative;
use momo_core::sinc;
use momo_models::{arc_chord, arc_length_from_chord, half_angle_sinc, rot_x, rot_y, rot_z};
use nalgebra::{Matrix3, Vector3};

#[test]
fn elementary_rotations_are_rotations() {
    for a in [-0.7f64, 0.0, 0.3] {
        for r in [rot_x(a), rot_y(a), rot_z(a)] {
            assert!((r.transpose() * r - Matrix3::identity()).amax() < 1e-15);
            assert!((r.determinant() - 1.0).abs() < 1e-15);
        }
    }
    // Signs: yaw left, pitch nose down, roll right side down.
    assert!((rot_z(0.1) * Vector3::x()).y > 0.0);
    assert!((rot_y(0.1) * Vector3::x()).z < 0.0);
    assert!((rot_x(0.1) * Vector3::y()).z > 0.0);
}

#[test]
fn half_angle_sinc_is_smooth_across_the_switch() {
    for t2 in [0.0, 0.999e-6, 1.001e-6, 0.09, 4.0] {
        let theta: f64 = f64::sqrt(t2);
        let exact = if theta == 0.0 {
            1.0
        } else {
            (0.5 * theta).sin() / (0.5 * theta)
        };
        assert!((half_angle_sinc(t2) - exact).abs() < 1e-15, "{t2}");
        let (_, d) = derivative(half_angle_sinc, t2);
        // d/d(θ²) of sinc(θ/2) at 0 is -1/24
        if t2 < 1e-5 {
            assert!((d + 1.0 / 24.0).abs() < 1e-7, "{t2}: {d}");
        }
    }
    let (v, d) = derivative(half_angle_sinc, 0.0);
    assert_eq!(v, 1.0);
    assert_eq!(d, -1.0 / 24.0);
}

#[test]
fn chord_matches_the_half_angle_form() {
    for (g, l) in [(0.0f64, 1.0f64), (0.2, 2.0), (-0.5, 0.7)] {
        let t = arc_chord(g, l);
        let u = Vector3::new((0.5 * g).cos(), (0.5 * g).sin(), 0.0);
        assert!((t - u * (l * sinc(0.5 * g))).amax() < 1e-15);
        assert!((arc_length_from_chord(g, &t) - l).abs() < 1e-14);
    }
}
