//! Tests of the sweep library: grid parsing and its errors, expansion, failing and panicking
//! combinations as rows, the CSV round trip and merge's checks.

use momo_core::{Manifold, Pose, Scalar};
use momo_sweep::{
    COLUMNS, Grid, MatchCount, Plan, RunOptions, Status, SweepError, merge, read_csv, run_jobs,
    write_csv,
};
use nalgebra::{Matrix3, Vector3};
use serde::{Deserialize, Serialize};

/// A model that panics when evaluated: a combination that crashes.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
struct Exploding;

impl Manifold for Exploding {
    const PARAMS: &'static [&'static str] = &["arc_length"];
    const ARC_LENGTH: Option<usize> = Some(0);
    fn motion<T: Scalar>(&self, p: &[T]) -> Pose<T> {
        if p[0] > T::zero() {
            panic!("exploding model evaluated");
        }
        Pose::new(
            Matrix3::identity(),
            Vector3::new(p[0], T::zero(), T::zero()),
        )
    }
}
momo_models::register_model!(Exploding, "test_exploding");

const SMALL: &str = r#"
models = ["soft_single_track", "single_track_2d"]
metrics = ["angle_plane", "geo_line"]
losses = ["cauchy", "trivial"]
solvers = ["levenberg_marquardt", { type = "gauss_newton", max_iterations = 7 }]
matches = [40, "all"]

[loss_scales]
angle_plane = [0.001, 0.002]
geo_line = [1.0]
"#;

fn grid_err(text: &str) -> (usize, String) {
    match Grid::from_toml_str(text, "g.toml") {
        Err(SweepError::Grid { line, reason, .. }) => (line, reason),
        other => panic!("expected a grid error, got {other:?}"),
    }
}

#[test]
fn grid_expands_in_a_fixed_order() {
    let g = Grid::from_toml_str(SMALL, "g.toml").expect("valid grid");
    let c = g.combinations();
    // models 2 x [angle_plane: cauchy x 2 scales + trivial, geo_line: cauchy x 1 + trivial]
    // x solvers 2 x matches 2.
    assert_eq!(c.len(), 2 * (3 + 2) * 2 * 2);
    assert_eq!(
        c[0].label(),
        "soft_single_track / angle_plane / cauchy 0.001 / levenberg_marquardt / 40"
    );
    assert_eq!(
        c[3].label(),
        "soft_single_track / angle_plane / cauchy 0.001 / gauss_newton{max_iterations=7} / all"
    );
    assert_eq!(c[4].loss_scale, Some(0.002));
    let trivial = c.iter().find(|c| c.loss == "trivial").expect("trivial");
    assert_eq!(trivial.loss_scale, None);
    assert!(c.iter().all(|c| c.build_config().is_ok()));
    // Exactly one combination is the default configuration (soft_single_track, angle_plane, cauchy 0.001,
    // LM with default options); the one with a changed GN is not.
    let defaults: Vec<_> = c.iter().filter(|c| c.is_default()).collect();
    assert_eq!(defaults.len(), 2, "one per match count"); // 40 and all
    assert!(defaults.iter().all(|d| d.solver == "levenberg_marquardt"));
    assert_eq!(g.matches, vec![MatchCount::AtMost(40), MatchCount::All]);
}

#[test]
fn grid_errors_name_the_line() {
    let (line, reason) = grid_err(&SMALL.replace("\"single_track_2d\"", "\"single_track_9d\""));
    assert_eq!(line, 2);
    assert!(reason.contains("single_track_9d"), "{reason}");

    let (line, reason) = grid_err(&SMALL.replace("geo_line = [1.0]", "geo_line = [-1.0]"));
    assert_eq!(line, 8, "{reason}");
    assert!(reason.contains("> 0"), "{reason}");

    let (_, reason) = grid_err(&SMALL.replace("geo_line = [1.0]\n", ""));
    assert!(reason.contains("no list for metric `geo_line`"), "{reason}");

    let (line, reason) = grid_err(&SMALL.replace("[40, \"all\"]", "[40, -3]"));
    assert_eq!(line, 6);
    assert!(reason.contains("matches"), "{reason}");

    let (line, reason) = grid_err(&format!("bogus = 1\n{SMALL}"));
    assert!(reason.contains("bogus"), "{reason}");
    assert_eq!(line, 1);

    let (_, reason) = grid_err(&SMALL.replace(
        "models = [\"soft_single_track\", ",
        "models = [\"soft_single_track\", \"soft_single_track\", ",
    ));
    assert!(reason.contains("twice"), "{reason}");

    let (line, reason) = grid_err(&format!("{SMALL}\n[odometry]\nmin_matches = -4\n"));
    assert!(line >= 10, "{line}: {reason}");
}

#[test]
fn failing_and_panicking_combinations_become_rows() {
    let grid = Grid::from_toml_str(
        r#"
        models = ["se3", "test_exploding"]
        metrics = ["angle_plane", "geo_line"]
        losses = ["cauchy"]
        loss_scales = [0.001]
        solvers = ["levenberg_marquardt"]
        matches = [30]
        "#,
        "g.toml",
    )
    .expect("valid grid");
    // The fisheye rig: geo_line needs a pinhole camera.
    let cfg = momo_sim::SimConfig {
        frames: 6,
        matches_per_camera: 30,
        ..momo_sim::SimConfig::fisheye_surround()
    };
    let seq = momo_sim::simulate(&cfg).expect("simulates").sequence;
    let plan = Plan::new(&grid, &["fish".into()]).expect("plan");
    let rows = run_jobs(
        &grid,
        &plan,
        &[seq],
        &plan.jobs_of(None),
        &RunOptions {
            threads: Some(2),
            quiet: true,
            ..Default::default()
        },
    )
    .expect("runs");
    assert_eq!(rows.len(), 4);
    let by = |model: &str, metric: &str| {
        rows.iter()
            .find(|r| r.model == model && r.metric == metric)
            .expect("row")
    };
    let ok = by("se3", "angle_plane");
    assert_eq!(ok.status, Status::Ok, "{}", ok.error);
    assert!(ok.rot_median_deg.is_some_and(|m| m < 1.0));
    assert_eq!(
        ok.estimated + ok.standstill + ok.no_matches + ok.solver_failures,
        5
    );

    let unsupported = by("se3", "geo_line");
    assert_eq!(unsupported.status, Status::Error);
    assert!(!unsupported.error.is_empty());

    let crashed = by("test_exploding", "angle_plane");
    assert_eq!(crashed.status, Status::Panic);
    assert!(
        crashed.error.contains("exploding model evaluated"),
        "{}",
        crashed.error
    );
}

fn rows_of_a_tiny_sweep() -> (Plan, Vec<momo_sweep::Row>) {
    let grid = Grid::from_toml_str(
        r#"
        models = ["se3", "single_track_2d"]
        metrics = ["angle_plane"]
        losses = ["cauchy", "huber"]
        loss_scales = [0.002]
        solvers = ["levenberg_marquardt"]
        matches = [40]
        "#,
        "g.toml",
    )
    .expect("valid grid");
    let cfg = momo_sim::SimConfig {
        frames: 8,
        matches_per_camera: 60,
        ..momo_sim::SimConfig::outliers()
    };
    let seq = momo_sim::simulate(&cfg).expect("simulates").sequence;
    let plan = Plan::new(&grid, &["a".into(), "b".into()]).expect("plan");
    let rows = run_jobs(
        &grid,
        &plan,
        &[seq.clone(), seq],
        &plan.jobs_of(None),
        &RunOptions {
            threads: Some(1),
            quiet: true,
            ..Default::default()
        },
    )
    .expect("runs");
    (plan, rows)
}

#[test]
fn csv_round_trip_and_merge_checks() {
    let (plan, rows) = rows_of_a_tiny_sweep();
    assert_eq!(rows.len(), 8);
    assert!(rows.iter().enumerate().all(|(i, r)| r.job == i));
    let tmp = tempfile::tempdir().expect("tmp");
    let path = |n: &str| tmp.path().join(n);

    // Round trip, bit for bit (floats are written to read back exactly).
    write_csv(&path("all.csv"), &rows).expect("writes");
    assert_eq!(read_csv(&path("all.csv")).expect("reads"), rows);
    let header = std::fs::read_to_string(path("all.csv")).expect("text");
    assert_eq!(header.lines().next(), Some(COLUMNS.join(",").as_str()));

    // Two halves merge into the whole, whatever the file order.
    let (odd, even): (Vec<_>, Vec<_>) = rows.iter().cloned().partition(|r| r.job % 2 == 1);
    write_csv(&path("odd.csv"), &odd).expect("writes");
    write_csv(&path("even.csv"), &even).expect("writes");
    assert_eq!(
        merge(&[path("odd.csv"), path("even.csv")]).expect("merges"),
        rows
    );

    // Missing jobs are named.
    let err = merge(&[path("odd.csv")]).expect_err("even jobs missing");
    assert!(
        err.to_string().contains("4 of 8 jobs missing: 0, 2, 4, 6"),
        "{err}"
    );
    // Duplicates are named.
    let err = merge(&[path("odd.csv"), path("even.csv"), path("odd.csv")]).expect_err("dup");
    assert!(err.to_string().contains("appears twice"), "{err}");
    // Another grid.
    let mut other = even.clone();
    for r in &mut other {
        r.grid_id = "0000000000000000".into();
    }
    write_csv(&path("other.csv"), &other).expect("writes");
    let err = merge(&[path("odd.csv"), path("other.csv")]).expect_err("other grid");
    assert!(err.to_string().contains("different sweeps"), "{err}");
    assert_ne!(plan.grid_id, "0000000000000000");

    // A malformed file names file and line.
    let text = std::fs::read_to_string(path("odd.csv")).expect("text");
    let broken: Vec<String> = text
        .lines()
        .enumerate()
        .map(|(i, l)| {
            if i == 2 {
                let mut fields: Vec<&str> = l.split(',').collect();
                fields[1] = "three"; // the job number
                fields.join(",")
            } else {
                l.into()
            }
        })
        .collect();
    std::fs::write(path("broken.csv"), broken.join("\n")).expect("writes");
    let err = merge(&[path("broken.csv")]).expect_err("malformed");
    let msg = err.to_string();
    assert!(msg.contains("broken.csv:3: column `job`"), "{msg}");
    std::fs::write(path("foreign.csv"), "a,b\n1,2\n").expect("writes");
    let err = read_csv(&path("foreign.csv")).expect_err("foreign");
    assert!(err.to_string().contains("foreign.csv:1:"), "{err}");
}

#[test]
fn summary_ranks_and_names_the_best() {
    let (_, rows) = rows_of_a_tiny_sweep();
    let md = momo_sweep::summary_markdown(&rows, &Default::default());
    let best = momo_sweep::summary::ranked(&rows, "a", momo_sweep::RankBy::RotMean);
    assert!(best[0].rot_mean_deg <= best[1].rot_mean_deg);
    assert!(
        md.contains(&format!("| a | {} |", best[0].combination)),
        "{md}"
    );
    assert!(md.contains("## b"));
}
