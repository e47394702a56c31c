//! A researcher's own `momo` tool in one file: a new motion model and a new residual metric,
//! checked against finite differences, registered by type name, and handed over to momo's
//! command line, so that `run`, `sweep`, `calibrate`, `eval` and `plot` accept them by name.
//!
//! ```sh
//! cargo run --release --example custom_cli -- run SEQ -o poses.txt -c cfg.toml
//! ```
//! with `cfg.toml` naming `[model] type = "example_model"` and `[metric] type =
//! "example_metric"`; a sweep grid may list `example_model` and `example_metric` beside the
//! built-in ones. `cargo test --example custom_cli` runs `run`, `sweep` and `calibrate` with
//! them on a simulated drive.

use momo::core::{
    Camera, Manifold, Observation, Pose, ResidualMetric, Scalar, cosc, essential, sinc,
};
use momo::models::{register_metric, register_model};
use momo_testing::{check_metric, check_model};
use nalgebra::{Matrix3, Vector3};
use serde::{Deserialize, Serialize};
use std::process::ExitCode;

/// Planar motion on a circle whose direction of travel may climb: `R = Rz(γ)` (no pitch or
/// roll of the body), `t = Ry(−c) · l (sinc γ, cosc γ, 0)` with yaw `γ`, arc length `l` and
/// climb angle `c`.
#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize)]
pub struct ExampleModel;

impl Manifold for ExampleModel {
    const PARAMS: &'static [&'static str] = &["yaw", "arc_length", "climb"];
    const ARC_LENGTH: Option<usize> = Some(1);

    fn motion<T: Scalar>(&self, p: &[T]) -> Pose<T> {
        let (yaw, l, climb) = (p[0], p[1], p[2]);
        let (s, c) = (yaw.sin(), yaw.cos());
        let r = Matrix3::new(
            c,
            -s,
            T::zero(),
            s,
            c,
            T::zero(),
            T::zero(),
            T::zero(),
            T::one(),
        );
        let (x, y) = (l * sinc(yaw), l * cosc(yaw));
        Pose::new(r, Vector3::new(x * climb.cos(), y, x * climb.sin()))
    }
}

/// The symmetric epipolar angle: `2 f1ᵀ E f0 / (|E f0| + |Eᵀ f1|)` (radians for small
/// errors), with `E` the essential matrix of the camera motion.
#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize)]
pub struct ExampleMetric;

impl ResidualMetric for ExampleMetric {
    const RESIDUALS: usize = 1;
    type Prepared<T: Scalar> = Matrix3<T>;

    fn prepare<T: Scalar>(&self, _camera: &Camera, motion: &Pose<T>) -> Matrix3<T> {
        essential(motion)
    }

    fn residuals<T: Scalar>(&self, e: &Matrix3<T>, o: &Observation, out: &mut [T]) {
        let (f0, f1) = (o.f0.map(T::c), o.f1.map(T::c));
        let n0 = e * f0;
        let n1 = e.transpose() * f1;
        let norm =
            (n0.norm_squared() + T::c(1e-30)).sqrt() + (n1.norm_squared() + T::c(1e-30)).sqrt();
        out[0] = f1.dot(&n0) * T::c(2.0) / norm;
    }
}

register_model!(ExampleModel, "example_model");
register_metric!(ExampleMetric, "example_metric");

/// The automatic derivatives of both against finite differences.
fn check() -> Result<(), String> {
    for p in [[0.0, 1.0, 0.0], [0.05, 1.3, 0.01]] {
        check_model(&ExampleModel, &p, 1e-6).map_err(|e| format!("example_model: {e}"))?;
    }
    check_metric(&ExampleMetric, 1e-6).map_err(|e| format!("example_metric: {e}"))?;
    Ok(())
}

fn main() -> ExitCode {
    if let Err(e) = check() {
        eprintln!("custom_cli: derivative check failed: {e}");
        return ExitCode::from(1);
    }
    momo_cli::main()
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    fn momo(args: &[&str]) -> ExitCode {
        momo_cli::main_from(std::iter::once("momo").chain(args.iter().copied()))
    }

    fn ok(args: &[&str]) {
        assert_eq!(momo(args), ExitCode::SUCCESS, "momo {}", args.join(" "));
    }

    fn s(p: &Path) -> &str {
        p.to_str().expect("a UTF-8 temporary path")
    }

    #[test]
    fn derivatives_agree() {
        check().expect("AD equals finite differences");
    }

    #[test]
    fn run_sweep_and_calibrate_with_the_researchers_types() {
        let dir = tempfile::tempdir().expect("a temporary directory");
        let seq = dir.path().join("seq");
        ok(&["simulate", "--frames", "60", "--seed", "7", s(&seq)]);

        // run: a configuration naming both by type.
        let config = momo::vo::Config {
            model: Box::new(ExampleModel),
            metric: Box::new(ExampleMetric),
            ..Default::default()
        };
        let cfg = dir.path().join("cfg.json");
        std::fs::write(&cfg, serde_json::to_string(&config).expect("serialisable"))
            .expect("writable");
        let poses = dir.path().join("poses.txt");
        ok(&["run", s(&seq), "-o", s(&poses), "-c", s(&cfg), "-q"]);
        let gt = momo::io::read_poses(seq.join("poses.txt")).expect("ground truth");
        let est = momo::io::read_poses(&poses).expect("estimate");
        let scores = momo::eval::evaluate(&gt, &est);
        // The model has no pitch or roll, the simulated drive has both: its own limit is
        // about 0.1 deg per frame, far below a failed estimate.
        assert!(
            scores.rotation_deg.median < 0.3,
            "{:?}",
            scores.rotation_deg
        );
        assert_eq!(scores.rotation_deg.above_one, 0);

        // sweep: {example_model, se3} x {angle_plane, example_metric}.
        let grid = dir.path().join("grid.toml");
        std::fs::write(
            &grid,
            "models = [\"example_model\", \"se3\"]\nmetrics = [\"angle_plane\", \"example_metric\"]\n\
             losses = [\"cauchy\"]\nsolvers = [\"levenberg_marquardt\"]\nmatches = [100]\n\
             seed = 1\nloss_scales = [0.001]\n",
        )
        .expect("writable");
        let out = dir.path().join("sweep");
        ok(&[
            "sweep",
            "--grid",
            s(&grid),
            "--sequences",
            s(&seq),
            "--output",
            s(&out),
            "-q",
        ]);
        let rows = momo_sweep::results::read_csv(&out.join("results.csv")).expect("results");
        assert_eq!(rows.len(), 4);
        for row in &rows {
            assert!(
                row.error.is_empty(),
                "{} x {}: {}",
                row.model,
                row.metric,
                row.error
            );
        }
        for (m, r) in [
            ("example_model", "example_metric"),
            ("se3", "example_metric"),
        ] {
            assert!(
                rows.iter()
                    .any(|row| row.model.contains(m) && row.metric.contains(r))
            );
        }

        // calibrate: the mount with the researcher's model and metric.
        let rig = dir.path().join("rig.json");
        ok(&[
            "calibrate",
            s(&seq),
            "-o",
            s(&rig),
            "-c",
            s(&cfg),
            "--model",
            "example_model",
            "-q",
        ]);
        assert!(momo::io::read_rig(&rig).is_ok());
    }
}
