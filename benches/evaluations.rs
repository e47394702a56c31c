//! The issue's measure of the driver's cost: the time of `Odometry::process` divided by the
//! time of one cost evaluation (`Problem::cost`: every residual and the loss) of the same frame
//! pair, for the two speed targets (the default configuration on one pinhole camera x 300
//! matches; `single_track_3d` on four fisheye cameras x 100), plus one linearisation with the
//! metric's fused kernel and with automatic differentiation (`Problem::with_automatic`).
//! Same data as `benches/matrix.rs` (a curve, 90 % inliers with 0.5 px noise, 10 % outliers,
//! the arc length known, warm-started by a previous frame).
//!
//! Two measurements of the same quantities:
//!
//! - criterion: `evaluations/{case}/{cost,linearize,linearize_automatic,odometry}`;
//! - printed ratios from an interleaved timing (per round, bulk-timed cost evaluations then
//!   processes; medians over the rounds), which the machine's load moves far less than two
//!   separate measurements. `MOMO_EVAL_ROUNDS` sets the rounds (31 by default).
//!
//! `MOMO_EVAL_SOLVER` adds lines to the driver's `[solver]` section (`;` separates them), e.g.
//! `MOMO_EVAL_SOLVER='max_step_extrapolation = 2.0'`.
//!
//! `MOMO_EVAL_CONFIG=FILE` runs the processes with a configuration file's solver, `[odometry]`,
//! `[trust]` and refinement loss (a preset such as `configs/realtime.toml`; sections it omits keep
//! their defaults) and the case's model, metric and loss; `MOMO_EVAL_SOLVER` is then ignored.
//!
//! For instruction counts (repeatable on a loaded machine), run under callgrind with few
//! rounds and a filter that matches no criterion benchmark, and read the inclusive counts of
//! `evaluations::timed_cost`, `timed_linearize`, `timed_linearize_automatic` and
//! `timed_process` per call (`MOMO_EVAL_CASE` keeps the cases whose name contains it):
//!
//! ```text
//! cargo bench --bench evaluations                       # criterion and printed ratios
//! MOMO_EVAL_ROUNDS=3 MOMO_EVAL_CASE=pinhole valgrind --tool=callgrind \
//!     target/release/deps/evaluations-* --bench none
//! ```

use criterion::{BatchSize, Criterion, criterion_group, criterion_main};
use momo_core::{FrameObservations, LeastSquares, ParamVec, Problem, ResidualMetric};
use std::hint::black_box;
use std::time::{Duration, Instant};

#[path = "support/frames.rs"]
mod frames;
use frames::{frame, start, target_cases, truth};

#[inline(never)]
fn timed_cost<R: ResidualMetric>(p: &Problem<'_, R>, x: &ParamVec) -> f64 {
    p.cost(black_box(x))
}

#[inline(never)]
fn timed_linearize<R: ResidualMetric>(p: &Problem<'_, R>, x: &ParamVec) -> f64 {
    p.linearize(black_box(x)).cost
}

#[inline(never)]
fn timed_linearize_automatic<R: ResidualMetric>(p: &Problem<'_, R>, x: &ParamVec) -> f64 {
    // Not the same body as `timed_linearize`, which the compiler would merge it with.
    p.linearize(black_box(x)).gradient[0]
}

#[inline(never)]
fn timed_process(vo: &mut momo_vo::Odometry, obs: &FrameObservations, arc: f64) -> usize {
    vo.process(obs, Some(arc)).diagnostics.iterations
}

fn evaluations(c: &mut Criterion) {
    let rounds: usize = std::env::var("MOMO_EVAL_ROUNDS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(31)
        .max(1);
    let mut group = c.benchmark_group("evaluations");
    group
        .sample_size(40)
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_secs(2));
    // The two target cases (se3 on the pinhole camera, as the issue measured it) and the
    // default model (`soft_single_track`) on the same pinhole frames.
    let mut cases = Vec::from(target_cases());
    cases.push((
        "soft_single_track_pinhole_300",
        momo_testing::canned::pinhole_rig(),
        Box::new(momo_models::SoftSingleTrack::default()),
        300,
    ));
    // Extra `[solver]` lines for the driver (e.g. `max_step_extrapolation = 2.0`).
    let solver_extra = std::env::var("MOMO_EVAL_SOLVER").unwrap_or_default();
    let loss = momo_costs::Cauchy::new(0.001);
    let only = std::env::var("MOMO_EVAL_CASE").unwrap_or_default();
    for (name, rig, model, n) in cases {
        if !name.contains(&only) {
            continue;
        }
        let obs = frame(&rig, n, 7);
        let prev = frame(&rig, n, 8);
        let est = model.build(&momo_costs::AnglePlane).expect("registered");
        let (init, fixed) = start(est.as_ref());
        let manifold = model.manifold();
        let p = Problem::new(
            manifold.as_ref(),
            &momo_costs::AnglePlane,
            &loss,
            &rig,
            &obs,
            &init,
        )
        .expect("fits")
        .with_fixed(&fixed);
        let auto = p.clone().with_automatic(true);
        let x = p.free_params();
        let config_toml = format!(
            "[model]\ntype = \"{}\"\n[metric]\ntype = \"angle_plane\"\n[loss]\ntype = \"cauchy\"\nscale = 0.001\n[solver]\ntype = \"levenberg_marquardt\"\n{}\n",
            model.typetag_name(),
            solver_extra.replace(';', "\n")
        );
        let arc = truth().translation.norm();
        // The preset's text, parsed for every driver (outside the timed part: the solver and
        // losses are trait objects, so a parsed `Config` is not `Clone`).
        let preset = std::env::var("MOMO_EVAL_CONFIG").ok().map(|path| {
            let text = std::fs::read_to_string(&path).expect("MOMO_EVAL_CONFIG readable");
            (path, text)
        });
        let primed = || {
            let mut config = momo_vo::Config::from_toml_str(&config_toml, "bench").expect("valid");
            if let Some((path, text)) = &preset {
                let p = momo_vo::Config::from_toml_str(text, path).expect("MOMO_EVAL_CONFIG valid");
                config.solver = p.solver;
                config.odometry = p.odometry;
                config.trust = p.trust;
                config.refine_loss = p.refine_loss;
            }
            let mut vo = momo_vo::Odometry::new(rig.clone(), config).expect("fits");
            vo.process(&prev, Some(arc));
            vo
        };
        // Interleaved rounds: bulk-timed cost evaluations, linearisations (fused and
        // automatic) and processes of primed drivers.
        let mut t = [Vec::new(), Vec::new(), Vec::new(), Vec::new()];
        let mut iterations = 0;
        for _ in 0..rounds {
            let clock = Instant::now();
            for _ in 0..200 {
                black_box(timed_cost(&p, &x));
            }
            t[0].push(clock.elapsed().as_secs_f64() / 200.0);
            let clock = Instant::now();
            for _ in 0..50 {
                black_box(timed_linearize(&p, &x));
            }
            t[1].push(clock.elapsed().as_secs_f64() / 50.0);
            let clock = Instant::now();
            for _ in 0..50 {
                black_box(timed_linearize_automatic(&auto, &x));
            }
            t[2].push(clock.elapsed().as_secs_f64() / 50.0);
            let mut drivers: Vec<_> = (0..50).map(|_| primed()).collect();
            let clock = Instant::now();
            for vo in &mut drivers {
                iterations = black_box(timed_process(vo, &obs, arc));
            }
            t[3].push(clock.elapsed().as_secs_f64() / 50.0);
        }
        let [tc, tl, ta, tp] = t.map(|mut v| {
            v.sort_by(f64::total_cmp);
            v[v.len() / 2]
        });
        eprintln!(
            "evaluations/{name}: cost {:.2} us; linearisation {:.2} us fused, {:.2} us automatic \
             ({:.2}x); Odometry::process {:.1} us = {:.2} cost evaluations ({iterations} solver \
             iterations)",
            tc * 1e6,
            tl * 1e6,
            ta * 1e6,
            ta / tl,
            tp * 1e6,
            tp / tc
        );
        group.bench_function(format!("{name}/cost"), |b| {
            b.iter(|| black_box(timed_cost(&p, &x)))
        });
        group.bench_function(format!("{name}/linearize"), |b| {
            b.iter(|| black_box(timed_linearize(&p, &x)))
        });
        group.bench_function(format!("{name}/linearize_automatic"), |b| {
            b.iter(|| black_box(timed_linearize_automatic(&auto, &x)))
        });
        group.bench_function(format!("{name}/odometry"), |b| {
            b.iter_batched(
                primed,
                |mut vo| black_box(timed_process(&mut vo, &obs, arc)),
                BatchSize::SmallInput,
            )
        });
    }
    group.finish();
}

criterion_group!(benches, evaluations);
criterion_main!(benches);
