//! Trajectories seen from above.

use crate::PlotError;
use crate::render::{FONT, Figure, color, draw_err, range, render};
use momo_core::Pose;
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;

/// One named line of (x, z) camera positions.
struct Track {
    name: String,
    points: Vec<(f64, f64)>,
    color: RGBColor,
    width: u32,
}

struct TrajectoryFigure {
    tracks: Vec<Track>,
}

const WIDTH: u32 = 900;
const HEIGHT: u32 = 800;

/// The camera positions (x, z) of KITTI camera poses: the view from above (camera y points
/// down).
fn top_view(poses: &[Pose<f64>]) -> Vec<(f64, f64)> {
    poses
        .iter()
        .map(|p| (p.translation.x, p.translation.z))
        .filter(|(x, z)| x.is_finite() && z.is_finite())
        .collect()
}

/// Draws the ground truth (black) and each estimate (its own colour, named in the legend) as
/// seen from above: x against z of camera 0's position in camera 0's first frame (KITTI
/// camera poses, y pointing down), with equal scales on both axes.
///
/// `estimates` pairs a legend name (e.g. the file name) with the poses. The format follows the
/// extension of `path` (`.png` or `.svg`); the file is written atomically.
pub fn plot_trajectories(
    ground_truth: &[Pose<f64>],
    estimates: &[(&str, &[Pose<f64>])],
    path: impl AsRef<Path>,
) -> Result<(), PlotError> {
    render(&trajectory_figure(ground_truth, estimates), path.as_ref())
}

fn trajectory_figure(
    ground_truth: &[Pose<f64>],
    estimates: &[(&str, &[Pose<f64>])],
) -> TrajectoryFigure {
    let mut tracks = vec![Track {
        name: "ground truth".into(),
        points: top_view(ground_truth),
        color: BLACK,
        width: 3,
    }];
    for (i, (name, poses)) in estimates.iter().enumerate() {
        tracks.push(Track {
            name: (*name).to_string(),
            points: top_view(poses),
            color: color(i),
            width: 2,
        });
    }
    TrajectoryFigure { tracks }
}

impl Figure for TrajectoryFigure {
    fn size(&self) -> (u32, u32) {
        (WIDTH, HEIGHT)
    }

    fn draw<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
        text: bool,
    ) -> Result<(), PlotError> {
        let all = || self.tracks.iter().flat_map(|t| t.points.iter());
        let (mut x0, mut x1) = range(all().map(|p| p.0), 0.05);
        let (mut z0, mut z1) = range(all().map(|p| p.1), 0.05);
        // Equal metres per pixel on both axes (approximately: the plotting area is the figure
        // less the margins and label areas).
        let (label_x, label_y) = if text { (45, 70) } else { (0, 0) };
        let caption = if text { 40 } else { 0 };
        let area_w = f64::from(WIDTH - 30 - label_y);
        let area_h = f64::from(HEIGHT - 30 - label_x - caption);
        let scale = ((x1 - x0) / area_w).max((z1 - z0) / area_h);
        let (cx, cz) = ((x0 + x1) / 2.0, (z0 + z1) / 2.0);
        (x0, x1) = (cx - scale * area_w / 2.0, cx + scale * area_w / 2.0);
        (z0, z1) = (cz - scale * area_h / 2.0, cz + scale * area_h / 2.0);

        let mut builder = ChartBuilder::on(root);
        builder
            .margin(15)
            .x_label_area_size(label_x)
            .y_label_area_size(label_y);
        if text {
            builder.caption("Trajectories from above (camera 0)", (FONT, 24));
        }
        let mut chart = builder
            .build_cartesian_2d(x0..x1, z0..z1)
            .map_err(draw_err)?;
        if text {
            chart
                .configure_mesh()
                .x_desc("x [m]")
                .y_desc("z [m]")
                .label_style((FONT, 15))
                .draw()
                .map_err(draw_err)?;
        } else {
            chart
                .plotting_area()
                .draw(&Rectangle::new([(x0, z0), (x1, z1)], BLACK.stroke_width(1)))
                .map_err(draw_err)?;
        }
        for track in &self.tracks {
            let style = track.color.stroke_width(track.width);
            chart
                .draw_series(LineSeries::new(track.points.iter().copied(), style))
                .map_err(draw_err)?
                .label(track.name.clone())
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 24, y)], style));
            if let Some(&start) = track.points.first() {
                chart
                    .draw_series(std::iter::once(Circle::new(start, 5, track.color.filled())))
                    .map_err(draw_err)?;
            }
        }
        if text {
            chart
                .configure_series_labels()
                .background_style(WHITE.mix(0.85))
                .border_style(BLACK)
                .label_font((FONT, 15))
                .position(SeriesLabelPosition::UpperLeft)
                .draw()
                .map_err(draw_err)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::render_with;
    use nalgebra::{Matrix3, Vector3};

    fn circle(n: usize, r: f64, drift: f64) -> Vec<Pose<f64>> {
        (0..n)
            .map(|k| {
                let a = k as f64 * 0.05;
                Pose::new(
                    Matrix3::identity(),
                    Vector3::new(r * (1.0 - a.cos()) + drift * a, 0.0, r * a.sin()),
                )
            })
            .collect()
    }

    #[test]
    fn writes_png_and_svg() -> Result<(), Box<dyn std::error::Error>> {
        let gt = circle(100, 30.0, 0.0);
        let a = circle(100, 30.0, 1.0);
        let b = circle(100, 29.0, -0.5);
        let dir = tempfile::tempdir()?;
        for name in ["t.png", "t.svg"] {
            let out = dir.path().join(name);
            plot_trajectories(&gt, &[("a.txt", &a), ("b.txt", &b)], &out)?;
            let bytes = std::fs::read(&out)?;
            assert!(bytes.len() > 1000, "{name}: {} bytes", bytes.len());
        }
        let png = std::fs::read(dir.path().join("t.png"))?;
        assert_eq!(&png[1..4], b"PNG");
        let svg = std::fs::read_to_string(dir.path().join("t.svg"))?;
        assert!(svg.contains("<svg"));
        if crate::font_available() {
            assert!(svg.contains("a.txt") && svg.contains("ground truth"));
        }
        // No temporary files left behind.
        assert_eq!(std::fs::read_dir(dir.path())?.count(), 2);
        Ok(())
    }

    #[test]
    fn draws_without_text_and_degenerate_data() -> Result<(), Box<dyn std::error::Error>> {
        let dir = tempfile::tempdir()?;
        let single = vec![Pose::identity()];
        for (gt, name) in [(circle(20, 5.0, 0.0), "x.png"), (single.clone(), "y.svg")] {
            let fig = trajectory_figure(&gt, &[("e", &single)]);
            render_with(&fig, &dir.path().join(name), false)?;
            assert!(std::fs::metadata(dir.path().join(name))?.len() > 0);
        }
        // Empty input still makes a (blank) figure.
        plot_trajectories(&[], &[], dir.path().join("empty.svg"))?;
        Ok(())
    }

    #[test]
    fn unknown_extension_writes_nothing() -> Result<(), Box<dyn std::error::Error>> {
        let dir = tempfile::tempdir()?;
        let out = dir.path().join("t.jpg");
        let err = plot_trajectories(&circle(5, 1.0, 0.0), &[], &out);
        assert!(matches!(err, Err(PlotError::Format(_))));
        assert_eq!(std::fs::read_dir(dir.path())?.count(), 0);
        Ok(())
    }
}
