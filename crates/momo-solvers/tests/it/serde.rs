//! The solvers as configuration: `Box<dyn Solver>` through JSON and TOML.

#![allow(clippy::unwrap_used)]

use momo_core::Solver;
use momo_solvers::{Dogleg, GaussNewton, LevenbergMarquardt};

fn non_default() -> Vec<Box<dyn Solver>> {
    vec![
        Box::new(
            GaussNewton::default()
                .with_max_iterations(7)
                .with_function_tolerance(1e-9)
                .with_gradient_tolerance(1e-12)
                .with_parameter_tolerance(1e-11)
                .with_max_line_search_steps(4),
        ),
        Box::new(
            LevenbergMarquardt::default()
                .with_max_iterations(9)
                .with_function_tolerance(1e-8)
                .with_gradient_tolerance(1e-13)
                .with_parameter_tolerance(1e-10)
                .with_initial_lambda(1e-2)
                .with_lambda_increase(4.0)
                .with_lambda_decrease(5.0)
                .with_min_lambda(1e-20)
                .with_max_lambda(1e20),
        ),
        Box::new(
            Dogleg::default()
                .with_max_iterations(11)
                .with_function_tolerance(1e-7)
                .with_gradient_tolerance(1e-11)
                .with_parameter_tolerance(1e-9)
                .with_initial_radius(0.5)
                .with_max_radius(1e6)
                .with_min_radius(1e-20),
        ),
    ]
}

#[test]
fn json_round_trip() {
    for s in non_default() {
        let json = serde_json::to_string(&s).unwrap();
        let back: Box<dyn Solver> = serde_json::from_str(&json).unwrap();
        assert_eq!(format!("{s:?}"), format!("{back:?}"), "{json}");
    }
}

#[test]
fn toml_round_trip() {
    for s in non_default() {
        let text = toml::to_string(&s).unwrap();
        let back: Box<dyn Solver> = toml::from_str(&text).unwrap();
        assert_eq!(format!("{s:?}"), format!("{back:?}"), "{text}");
    }
}

#[test]
fn type_tags() {
    let tags: Vec<String> = non_default()
        .iter()
        .map(|s| {
            serde_json::to_value(s).unwrap()["type"]
                .as_str()
                .unwrap()
                .to_string()
        })
        .collect();
    assert_eq!(tags, ["gauss_newton", "levenberg_marquardt", "dogleg"]);
}

#[test]
fn missing_options_keep_their_defaults() {
    let s: Box<dyn Solver> =
        serde_json::from_str(r#"{"type": "levenberg_marquardt", "max_iterations": 5}"#).unwrap();
    let want = LevenbergMarquardt::default().with_max_iterations(5);
    assert_eq!(format!("{s:?}"), format!("{want:?}"));

    let s: Box<dyn Solver> = toml::from_str("type = \"dogleg\"\ninitial_radius = 2.0\n").unwrap();
    let want = Dogleg::default().with_initial_radius(2.0);
    assert_eq!(format!("{s:?}"), format!("{want:?}"));

    let s: Box<dyn Solver> = toml::from_str("type = \"gauss_newton\"").unwrap();
    assert_eq!(format!("{s:?}"), format!("{:?}", GaussNewton::default()));

    // The plain structs too.
    let lm: LevenbergMarquardt = toml::from_str("lambda_decrease = 2.5").unwrap();
    assert_eq!(lm, LevenbergMarquardt::default().with_lambda_decrease(2.5));
}

#[test]
fn unknown_type_is_an_error() {
    assert!(serde_json::from_str::<Box<dyn Solver>>(r#"{"type": "newton"}"#).is_err());
}
