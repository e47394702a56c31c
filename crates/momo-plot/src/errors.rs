//! Frame-to-frame rotation errors over path length and speed.

use crate::PlotError;
use crate::render::{FONT, Figure, color, draw_err, range, render};
use momo_core::Pose;
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;

/// The rotation error of one frame pair `(frame - 1, frame)` and where it happened.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ErrorSample {
    /// The frame k of the pair (k-1, k).
    pub frame: usize,
    /// Distance along the ground truth (camera 0 positions) from frame 0 to frame k, metres.
    pub path_length: f64,
    /// Ground-truth speed over the pair: camera 0's displacement times the frame rate, m/s.
    pub speed: f64,
    /// Angle of `R_gt(k-1,k)ᵀ R_est(k-1,k)`, degrees
    /// ([`momo_eval::frame_to_frame_rotation_errors`]).
    pub error_deg: f64,
}

/// The frame-to-frame rotation errors of an estimate with the path length and speed of the
/// ground truth at each frame pair (`frame_rate` in Hz, 10 for KITTI). Covers the frame pairs
/// both trajectories have.
pub fn rotation_error_samples(
    ground_truth: &[Pose<f64>],
    estimate: &[Pose<f64>],
    frame_rate: f64,
) -> Vec<ErrorSample> {
    let errors = momo_eval::frame_to_frame_rotation_errors(ground_truth, estimate);
    let mut path_length = 0.0;
    errors
        .iter()
        .enumerate()
        .map(|(i, &error_deg)| {
            let k = i + 1;
            let step = (ground_truth[k].translation - ground_truth[k - 1].translation).norm();
            path_length += step;
            ErrorSample {
                frame: k,
                path_length,
                speed: step * frame_rate,
                error_deg,
            }
        })
        .collect()
}

struct ErrorsFigure {
    series: Vec<(String, Vec<ErrorSample>)>,
}

/// Draws the frame-to-frame rotation errors of each estimate against the ground truth: over
/// the path length along the ground truth (upper panel, lines) and over the ground-truth speed
/// (lower panel, points), one colour per estimate, named in the legends.
///
/// `frame_rate` (Hz, 10 for KITTI) turns displacements per frame into speeds. The format
/// follows the extension of `path` (`.png` or `.svg`); the file is written atomically. Fails
/// with [`PlotError::Input`] if `frame_rate` is not a positive number.
pub fn plot_rotation_errors(
    ground_truth: &[Pose<f64>],
    estimates: &[(&str, &[Pose<f64>])],
    frame_rate: f64,
    path: impl AsRef<Path>,
) -> Result<(), PlotError> {
    if !(frame_rate.is_finite() && frame_rate > 0.0) {
        return Err(PlotError::Input(format!(
            "the frame rate must be a positive number, found {frame_rate}"
        )));
    }
    let series = estimates
        .iter()
        .map(|(name, est)| {
            (
                (*name).to_string(),
                rotation_error_samples(ground_truth, est, frame_rate),
            )
        })
        .collect();
    render(&ErrorsFigure { series }, path.as_ref())
}

impl ErrorsFigure {
    fn panel<DB: DrawingBackend>(
        &self,
        area: &DrawingArea<DB, Shift>,
        text: bool,
        over_speed: bool,
    ) -> Result<(), PlotError> {
        let samples = || self.series.iter().flat_map(|(_, s)| s.iter());
        let x = |s: &ErrorSample| if over_speed { s.speed } else { s.path_length };
        let (x0, x1) = range(samples().map(x).chain([0.0]), 0.02);
        let (_, y1) = range(samples().map(|s| s.error_deg).chain([0.0]), 0.05);
        let mut builder = ChartBuilder::on(area);
        builder
            .margin(15)
            .x_label_area_size(if text { 45 } else { 0 })
            .y_label_area_size(if text { 70 } else { 0 });
        if text {
            let caption = if over_speed {
                "Frame-to-frame rotation error over speed"
            } else {
                "Frame-to-frame rotation error over path length"
            };
            builder.caption(caption, (FONT, 22));
        }
        let mut chart = builder
            .build_cartesian_2d(x0..x1, 0.0..y1)
            .map_err(draw_err)?;
        if text {
            chart
                .configure_mesh()
                .x_desc(if over_speed {
                    "speed [m/s]"
                } else {
                    "path length [m]"
                })
                .y_desc("rotation error [deg]")
                .label_style((FONT, 15))
                .draw()
                .map_err(draw_err)?;
        } else {
            chart
                .plotting_area()
                .draw(&Rectangle::new(
                    [(x0, 0.0), (x1, y1)],
                    BLACK.stroke_width(1),
                ))
                .map_err(draw_err)?;
        }
        for (i, (name, samples)) in self.series.iter().enumerate() {
            let c = color(i);
            let points = samples
                .iter()
                .map(|s| (x(s), s.error_deg))
                .filter(|(a, b)| a.is_finite() && b.is_finite());
            let drawn = if over_speed {
                chart
                    .draw_series(points.map(|p| Circle::new(p, 2, c.mix(0.6).filled())))
                    .map_err(draw_err)?
            } else {
                chart
                    .draw_series(LineSeries::new(points, c.stroke_width(1)))
                    .map_err(draw_err)?
            };
            drawn.label(name.clone()).legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 24, y)], c.stroke_width(3))
            });
        }
        if text && !self.series.is_empty() {
            chart
                .configure_series_labels()
                .background_style(WHITE.mix(0.85))
                .border_style(BLACK)
                .label_font((FONT, 15))
                .position(SeriesLabelPosition::UpperRight)
                .draw()
                .map_err(draw_err)?;
        }
        Ok(())
    }
}

impl Figure for ErrorsFigure {
    fn size(&self) -> (u32, u32) {
        (1000, 900)
    }

    fn draw<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
        text: bool,
    ) -> Result<(), PlotError> {
        let (upper, lower) = root.split_vertically(450);
        self.panel(&upper, text, false)?;
        self.panel(&lower, text, true)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::render_with;
    use nalgebra::{Matrix3, Vector3};

    fn rz(a: f64) -> Matrix3<f64> {
        let (s, c) = a.sin_cos();
        Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0)
    }

    /// Straight along z at 1 m per frame; the estimate turns by `noise(k)` radians at frame k.
    fn drive(n: usize, noise: impl Fn(usize) -> f64) -> Vec<Pose<f64>> {
        let mut yaw = 0.0;
        (0..n)
            .map(|k| {
                yaw += if k > 0 { noise(k) } else { 0.0 };
                Pose::new(rz(yaw), Vector3::new(0.0, 0.0, k as f64))
            })
            .collect()
    }

    #[test]
    fn samples_have_path_length_speed_and_error() {
        let gt = drive(11, |_| 0.0);
        let est = drive(11, |k| if k == 4 { 0.01 } else { 0.0 });
        let s = rotation_error_samples(&gt, &est, 10.0);
        assert_eq!(s.len(), 10);
        assert_eq!(s[0].frame, 1);
        assert!((s[9].path_length - 10.0).abs() < 1e-12);
        assert!(s.iter().all(|s| (s.speed - 10.0).abs() < 1e-12));
        assert!((s[3].error_deg - 0.01f64.to_degrees()).abs() < 1e-9);
        assert!(s[2].error_deg.abs() < 1e-9);
    }

    #[test]
    fn writes_png_and_svg() -> Result<(), Box<dyn std::error::Error>> {
        let gt = drive(60, |_| 0.0);
        let a = drive(60, |k| 0.001 * ((k * 7) % 5) as f64);
        let b = drive(60, |k| 0.002 * ((k * 3) % 4) as f64);
        let dir = tempfile::tempdir()?;
        for name in ["e.png", "e.svg"] {
            let out = dir.path().join(name);
            plot_rotation_errors(&gt, &[("a.txt", &a), ("b.txt", &b)], 10.0, &out)?;
            assert!(std::fs::metadata(&out)?.len() > 1000);
            let fig = ErrorsFigure {
                series: vec![("a".into(), rotation_error_samples(&gt, &a, 10.0))],
            };
            render_with(&fig, &dir.path().join(format!("plain-{name}")), false)?;
        }
        assert!(plot_rotation_errors(&gt, &[], 0.0, dir.path().join("x.svg")).is_err());
        assert!(!dir.path().join("x.svg").exists());
        Ok(())
    }
}
