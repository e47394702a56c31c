//! The cost landscape of one frame pair over yaw and arc length.

use crate::PlotError;
use crate::render::{FONT, Figure, draw_err, render};
use momo_core::{FrameObservations, SolveRequest};
use momo_io::SparseSequence;
use momo_vo::{Config, Odometry};
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;

/// Largest number of grid steps per axis accepted by [`compute_landscape`].
const MAX_STEPS: usize = 1000;

/// What [`compute_landscape`] evaluates.
#[derive(Clone, Debug, PartialEq)]
pub struct LandscapeOptions {
    /// The frame pair k = (k-1, k), at least 1.
    pub frame: usize,
    /// Half-width of the yaw axis around the estimate, degrees.
    pub range_yaw_deg: f64,
    /// Half-width of the arc-length axis around the estimate, metres.
    pub range_arc: f64,
    /// Grid points per axis (at least 2).
    pub steps: usize,
}

impl Default for LandscapeOptions {
    /// Frame 1, ±2 degrees, ±0.5 m, 81 × 81 points.
    fn default() -> Self {
        Self {
            frame: 1,
            range_yaw_deg: 2.0,
            range_arc: 0.5,
            steps: 81,
        }
    }
}

/// The cost of one frame pair on a grid of yaw × arc length, the other parameters held at
/// the estimate.
#[derive(Clone, Debug, PartialEq)]
pub struct Landscape {
    /// The frame pair k.
    pub frame: usize,
    /// The model's parameter names (with `yaw` and `arc_length` among them).
    pub param_names: Vec<String>,
    /// The estimated parameters of frame k (the odometry run over frames 1..=k).
    pub estimate: Vec<f64>,
    /// Yaw values of the grid, degrees (increasing).
    pub yaw_deg: Vec<f64>,
    /// Arc-length values of the grid, metres (increasing).
    pub arc_length: Vec<f64>,
    /// `cost[i * yaw_deg.len() + j]`: the cost `½ Σ ρ(|r|²)` at `arc_length[i]`, `yaw_deg[j]`.
    pub cost: Vec<f64>,
}

impl Landscape {
    /// `(yaw in degrees, arc length, cost)` of the lowest finite grid cost, if any.
    pub fn minimum(&self) -> Option<(f64, f64, f64)> {
        let n = self.yaw_deg.len();
        self.cost
            .iter()
            .enumerate()
            .filter(|(_, c)| c.is_finite())
            .min_by(|a, b| a.1.total_cmp(b.1))
            .map(|(i, &c)| (self.yaw_deg[i % n], self.arc_length[i / n], c))
    }

    /// The estimate's `(yaw in degrees, arc length)`.
    pub fn estimate_point(&self) -> (f64, f64) {
        let get = |name: &str| {
            self.param_names
                .iter()
                .position(|p| p == name)
                .and_then(|i| self.estimate.get(i).copied())
                .unwrap_or(0.0)
        };
        (get("yaw").to_degrees(), get("arc_length"))
    }
}

fn param_index(names: &[&str], name: &str) -> Option<usize> {
    names.iter().position(|n| *n == name)
}

fn axis(centre: f64, half: f64, steps: usize) -> Vec<f64> {
    (0..steps)
        .map(|i| centre - half + 2.0 * half * i as f64 / (steps - 1) as f64)
        .collect()
}

/// Runs the odometry of `config` over frame pairs 1..=`options.frame` of `sequence` and
/// evaluates the cost of the last one on a grid of yaw × arc length around its estimate (the
/// other parameters held at the estimate).
///
/// The configuration's model is used if it has parameters named `yaw` and `arc_length`
/// (`single_track_2d`, `single_track_3d`); otherwise it is replaced by `single_track_2d`.
/// Metric, loss and solver are the configuration's.
pub fn compute_landscape(
    sequence: &SparseSequence,
    config: Config,
    options: &LandscapeOptions,
) -> Result<Landscape, PlotError> {
    let k = options.frame;
    let n = sequence.num_frames;
    if k == 0 || k >= n {
        return Err(PlotError::Input(format!(
            "frame {k} is not a frame pair of the sequence (frames 1..={})",
            n.saturating_sub(1)
        )));
    }
    if !(2..=MAX_STEPS).contains(&options.steps) {
        return Err(PlotError::Input(format!(
            "the grid needs 2 to {MAX_STEPS} steps per axis, found {}",
            options.steps
        )));
    }
    for (name, v) in [
        ("yaw range", options.range_yaw_deg),
        ("arc-length range", options.range_arc),
    ] {
        if !(v.is_finite() && v > 0.0) {
            return Err(PlotError::Input(format!(
                "the {name} must be a positive number, found {v}"
            )));
        }
    }
    let empty = FrameObservations::new(sequence.rig.len());
    let observations = sequence.frame(k).unwrap_or(&empty);
    if observations.is_empty() {
        return Err(PlotError::Input(format!("frame {k} has no matches")));
    }

    let mut config = config;
    let model = config.model.manifold();
    let names = model.params();
    if param_index(names, "yaw").is_none() || param_index(names, "arc_length").is_none() {
        config.model = Box::new(momo_models::SingleTrack2d);
    }
    let mut vo = Odometry::new(sequence.rig.clone(), config)?;
    let mut estimate = Vec::new();
    for i in 1..=k {
        let obs = sequence.frame(i).unwrap_or(&empty);
        let arc = sequence.arc_length(i);
        estimate = vo.process(obs, arc).diagnostics.params;
    }

    let estimator = vo.estimator();
    let names = estimator.param_names();
    let (Some(iy), Some(ia)) = (param_index(names, "yaw"), param_index(names, "arc_length")) else {
        return Err(PlotError::Input(
            "the model has no `yaw` and `arc_length` parameters".into(),
        ));
    };
    if estimate.len() != names.len() || estimate.iter().any(|p| !p.is_finite()) {
        return Err(PlotError::Input(format!(
            "frame {k}: the estimator returned no usable parameters"
        )));
    }
    let yaw_deg = axis(
        estimate[iy].to_degrees(),
        options.range_yaw_deg,
        options.steps,
    );
    let arc_length = axis(estimate[ia], options.range_arc, options.steps);
    let fixed = vec![false; names.len()];
    let request = SolveRequest {
        rig: vo.rig(),
        observations,
        loss: vo.config().loss.as_ref(),
        solver: vo.config().solver.as_ref(),
        initial: &estimate,
        fixed: &fixed,
        rotation_only: false,
        motion_prior: None,
    };
    let mut cost = Vec::with_capacity(yaw_deg.len() * arc_length.len());
    let mut params = estimate.clone();
    for &a in &arc_length {
        for &y in &yaw_deg {
            params[iy] = y.to_radians();
            params[ia] = a;
            cost.push(estimator.cost(&request, &params)?);
        }
    }
    Ok(Landscape {
        frame: k,
        param_names: names.iter().map(|s| s.to_string()).collect(),
        estimate,
        yaw_deg,
        arc_length,
        cost,
    })
}

/// Draws a [`Landscape`] as a heat map (viridis-like colours on a logarithmic scale of the cost
/// above its minimum, grey where the cost is not finite) with the grid minimum marked by a
/// white cross and the estimate by a red circle, plus a colour bar.
///
/// The format follows the extension of `path` (`.png` or `.svg`); the file is written
/// atomically. Fails with [`PlotError::Input`] if the grid's sizes do not match.
pub fn plot_landscape(landscape: &Landscape, path: impl AsRef<Path>) -> Result<(), PlotError> {
    let (ny, na) = (landscape.yaw_deg.len(), landscape.arc_length.len());
    if ny < 2 || na < 2 || landscape.cost.len() != ny * na {
        return Err(PlotError::Input(format!(
            "a landscape needs at least 2 × 2 grid points and one cost per point, found {ny} × {na} points and {} costs",
            landscape.cost.len()
        )));
    }
    let values = landscape.yaw_deg.iter().chain(&landscape.arc_length);
    if values.into_iter().any(|v| !v.is_finite()) {
        return Err(PlotError::Input("the grid axes must be finite".into()));
    }
    render(&LandscapeFigure { landscape }, path.as_ref())
}

/// Viridis, sampled at 0, 0.25, 0.5, 0.75 and 1.
const VIRIDIS: [(f64, f64, f64); 5] = [
    (68.0, 1.0, 84.0),
    (59.0, 82.0, 139.0),
    (33.0, 145.0, 140.0),
    (94.0, 201.0, 98.0),
    (253.0, 231.0, 37.0),
];

fn viridis(t: f64) -> RGBColor {
    let t = t.clamp(0.0, 1.0) * (VIRIDIS.len() - 1) as f64;
    let i = (t.floor() as usize).min(VIRIDIS.len() - 2);
    let f = t - i as f64;
    let (a, b) = (VIRIDIS[i], VIRIDIS[i + 1]);
    let mix = |x: f64, y: f64| (x + (y - x) * f).round().clamp(0.0, 255.0) as u8;
    RGBColor(mix(a.0, b.0), mix(a.1, b.1), mix(a.2, b.2))
}

/// Maps costs to [0, 1]: logarithmic in the cost above the minimum.
struct ColorScale {
    min: f64,
    eps: f64,
    span: f64,
}

impl ColorScale {
    fn new(costs: &[f64]) -> Self {
        let finite = || costs.iter().copied().filter(|c| c.is_finite());
        let min = finite().fold(f64::INFINITY, f64::min);
        let max = finite().fold(f64::NEG_INFINITY, f64::max);
        let (min, max) = if min <= max { (min, max) } else { (0.0, 1.0) };
        let eps = ((max - min) * 1e-3).max(f64::MIN_POSITIVE);
        let span = ((max - min + eps) / eps).ln().max(f64::MIN_POSITIVE);
        Self { min, eps, span }
    }

    fn t(&self, c: f64) -> f64 {
        ((c - self.min + self.eps) / self.eps).ln() / self.span
    }
}

struct LandscapeFigure<'a> {
    landscape: &'a Landscape,
}

/// Cell edges: midpoints between grid values, extended by half a step at both ends.
fn edges(v: &[f64]) -> Vec<f64> {
    let n = v.len();
    let mut e = Vec::with_capacity(n + 1);
    e.push(v[0] - (v[1] - v[0]) / 2.0);
    for i in 1..n {
        e.push((v[i - 1] + v[i]) / 2.0);
    }
    e.push(v[n - 1] + (v[n - 1] - v[n - 2]) / 2.0);
    e
}

impl Figure for LandscapeFigure<'_> {
    fn size(&self) -> (u32, u32) {
        (950, 800)
    }

    fn draw<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
        text: bool,
    ) -> Result<(), PlotError> {
        let l = self.landscape;
        let scale = ColorScale::new(&l.cost);
        let (main, bar) = root.split_horizontally(830);
        let xe = edges(&l.yaw_deg);
        let ye = edges(&l.arc_length);
        let (x0, x1) = (xe[0].min(xe[xe.len() - 1]), xe[0].max(xe[xe.len() - 1]));
        let (y0, y1) = (ye[0].min(ye[ye.len() - 1]), ye[0].max(ye[ye.len() - 1]));

        let mut builder = ChartBuilder::on(&main);
        builder
            .margin(15)
            .x_label_area_size(if text { 45 } else { 0 })
            .y_label_area_size(if text { 70 } else { 0 });
        let caption = format!(
            "Cost of frame {} over yaw and arc length ({})",
            l.frame,
            l.param_names.join(", ")
        );
        if text {
            builder.caption(caption, (FONT, 20));
        }
        let mut chart = builder
            .build_cartesian_2d(x0..x1, y0..y1)
            .map_err(draw_err)?;
        let ny = l.yaw_deg.len();
        let cells = l.cost.iter().enumerate().map(|(i, &c)| {
            let (ia, iy) = (i / ny, i % ny);
            let color = if c.is_finite() {
                viridis(scale.t(c))
            } else {
                RGBColor(128, 128, 128)
            };
            Rectangle::new([(xe[iy], ye[ia]), (xe[iy + 1], ye[ia + 1])], color.filled())
        });
        chart.draw_series(cells).map_err(draw_err)?;
        if text {
            chart
                .configure_mesh()
                .disable_mesh()
                .x_desc("yaw [deg]")
                .y_desc("arc length [m]")
                .label_style((FONT, 15))
                .draw()
                .map_err(draw_err)?;
        }
        let (ex, ey) = l.estimate_point();
        chart
            .draw_series(std::iter::once(Circle::new(
                (ex, ey),
                8,
                RED.stroke_width(3),
            )))
            .map_err(draw_err)?
            .label("estimate")
            .legend(|(x, y)| Circle::new((x + 10, y), 6, RED.stroke_width(3)));
        if let Some((mx, my, _)) = l.minimum() {
            chart
                .draw_series(std::iter::once(Cross::new(
                    (mx, my),
                    8,
                    WHITE.stroke_width(3),
                )))
                .map_err(draw_err)?
                .label("grid minimum")
                .legend(|(x, y)| Cross::new((x + 10, y), 6, BLACK.stroke_width(3)));
        }
        if text {
            chart
                .configure_series_labels()
                .background_style(WHITE.mix(0.85))
                .border_style(BLACK)
                .label_font((FONT, 15))
                .position(SeriesLabelPosition::UpperRight)
                .draw()
                .map_err(draw_err)?;
        }

        // Colour bar: cost above the minimum, logarithmic.
        let mut builder = ChartBuilder::on(&bar);
        builder
            .margin_top(if text { 55 } else { 15 })
            .margin_bottom(if text { 60 } else { 15 })
            .margin_right(if text { 5 } else { 15 })
            .y_label_area_size(if text { 60 } else { 0 });
        let mut cb = builder
            .build_cartesian_2d(0.0..1.0, 0.0..1.0)
            .map_err(draw_err)?;
        let n_bar = 100;
        cb.draw_series((0..n_bar).map(|i| {
            let (a, b) = (i as f64 / n_bar as f64, (i + 1) as f64 / n_bar as f64);
            Rectangle::new([(0.0, a), (1.0, b)], viridis((a + b) / 2.0).filled())
        }))
        .map_err(draw_err)?;
        if text {
            let fmt = |t: &f64| {
                // Invert t: cost - min = eps (exp(t span) - 1).
                let d = scale.eps * ((t * scale.span).exp() - 1.0);
                format!("{:.2e}", scale.min + d)
            };
            cb.configure_mesh()
                .disable_mesh()
                .disable_x_axis()
                .y_labels(6)
                .y_label_formatter(&fmt)
                .label_style((FONT, 12))
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

    fn bowl() -> Landscape {
        let yaw_deg = axis(1.0, 2.0, 21);
        let arc_length = axis(0.8, 0.5, 15);
        let mut cost = Vec::new();
        for a in &arc_length {
            for y in &yaw_deg {
                cost.push((y - 1.2).powi(2) + 4.0 * (a - 0.7).powi(2));
            }
        }
        cost[3] = f64::NAN;
        Landscape {
            frame: 3,
            param_names: vec!["yaw".into(), "arc_length".into()],
            estimate: vec![1.0f64.to_radians(), 0.8],
            yaw_deg,
            arc_length,
            cost,
        }
    }

    #[test]
    fn minimum_and_estimate() {
        let l = bowl();
        let (y, a, c) = l.minimum().expect("a finite cost");
        assert!((y - 1.2).abs() < 1e-9 && (a - 0.7).abs() < 0.04 && c < 0.01);
        let (ey, ea) = l.estimate_point();
        assert!((ey - 1.0).abs() < 1e-12 && (ea - 0.8).abs() < 1e-12);
    }

    #[test]
    fn writes_png_and_svg() -> Result<(), Box<dyn std::error::Error>> {
        let l = bowl();
        let dir = tempfile::tempdir()?;
        for name in ["l.png", "l.svg"] {
            let out = dir.path().join(name);
            plot_landscape(&l, &out)?;
            assert!(std::fs::metadata(&out)?.len() > 1000);
            render_with(
                &LandscapeFigure { landscape: &l },
                &dir.path().join(format!("plain-{name}")),
                false,
            )?;
        }
        let mut bad = bowl();
        bad.cost.pop();
        assert!(matches!(
            plot_landscape(&bad, dir.path().join("bad.png")),
            Err(PlotError::Input(_))
        ));
        Ok(())
    }

    #[test]
    fn landscape_of_a_simulated_frame() -> Result<(), Box<dyn std::error::Error>> {
        let cfg = momo_sim::SimConfig {
            frames: 6,
            matches_per_camera: 80,
            ..momo_sim::SimConfig::clean_pinhole()
        };
        let sim = momo_sim::simulate(&cfg)?;
        let sequence = SparseSequence::from(sim.sequence.clone());
        let options = LandscapeOptions {
            frame: 4,
            steps: 11,
            ..LandscapeOptions::default()
        };
        // The default model (se3) has no yaw: single_track_2d is used.
        let l = compute_landscape(&sequence, Config::default(), &options)?;
        assert_eq!(l.param_names, ["yaw", "arc_length"]);
        assert_eq!(l.cost.len(), 121);
        assert!(l.cost.iter().all(|c| c.is_finite() && *c >= 0.0));
        // The grid minimum is near the estimate (clean data): within a grid step or two.
        let (my, _, _) = l.minimum().expect("finite costs");
        let (ey, _) = l.estimate_point();
        assert!(
            (my - ey).abs() <= 0.8,
            "minimum {my} deg, estimate {ey} deg"
        );
        let dir = tempfile::tempdir()?;
        plot_landscape(&l, dir.path().join("l.png"))?;

        for bad in [
            LandscapeOptions {
                frame: 0,
                ..options.clone()
            },
            LandscapeOptions {
                frame: 6,
                ..options.clone()
            },
            LandscapeOptions {
                steps: 1,
                ..options.clone()
            },
            LandscapeOptions {
                range_arc: f64::NAN,
                ..options.clone()
            },
        ] {
            assert!(matches!(
                compute_landscape(&sequence, Config::default(), &bad),
                Err(PlotError::Input(_))
            ));
        }
        Ok(())
    }
}
