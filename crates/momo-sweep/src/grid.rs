//! The grid: the axes of a sweep, read from TOML, and its expansion into combinations.
//!
//! ```toml
//! models = ["se3", "single_track_2d", "single_track_3d"]
//! metrics = ["angle_plane", "sampson"]
//! losses = ["cauchy", "huber", "tukey", "trivial"]
//! solvers = ["levenberg_marquardt", "gauss_newton", { type = "dogleg", max_iterations = 20 }]
//! matches = [200, "all"]     # per frame pair and camera, spread over the image
//! seed = 1                   # of the sub-sampling (optional, default 1)
//! max_frames = 300           # optional: only the first frames of every sequence
//!
//! [loss_scales]              # in the metric's units; or one list for every metric
//! angle_plane = [0.001, 0.002]
//! sampson = [0.7, 1.5]
//!
//! [odometry]                 # optional: driver options for every job (`momo config`)
//! min_matches = 8
//! ```
//!
//! - `models`, `metrics`, `losses`, `solvers` are lists of type tags as the configuration uses
//!   them (`momo config` prints them), or inline tables with `type` and options.
//! - `loss_scales` applies to every loss except `trivial` (which has no scale) and losses whose
//!   table sets its own `scale`; either a list for every metric or a table of lists keyed by
//!   metric type (each metric of the grid needs one).
//! - `matches`: a positive number keeps at most that many matches per frame pair and camera,
//!   chosen by [`momo_io::kitti::subsample_frame`]; `"all"` (or 0) keeps all.
//!
//! Unknown keys, unknown type tags and bad values are errors that name the grid file and line.

use crate::error::SweepError;
use momo_core::{MetricSpec, ModelSpec, RobustLoss, Solver};
use momo_vo::Config;
use serde::Deserialize;
use std::collections::BTreeMap;
use std::fmt;
use std::path::Path;
use toml::{Spanned, Table, Value};

/// One value of the `models`, `metrics`, `losses` or `solvers` axis: a type tag and options.
#[derive(Clone, Debug, PartialEq)]
pub struct AxisEntry {
    /// The type tag (`"se3"`).
    pub type_name: String,
    /// The configuration section, `type` included (what `[model]` etc. would hold).
    pub table: Table,
}

impl AxisEntry {
    /// The label used in results: the type tag, followed by the options in braces if any
    /// (`gauss_newton{max_iterations=20}`).
    pub fn label(&self) -> String {
        let options: Vec<String> = sorted(&self.table)
            .into_iter()
            .filter(|(k, _)| *k != "type")
            .map(|(k, v)| format!("{k}={}", canonical(v)))
            .collect();
        if options.is_empty() {
            self.type_name.clone()
        } else {
            format!("{}{{{}}}", self.type_name, options.join(","))
        }
    }
}

/// How many matches per frame pair and camera a job uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum MatchCount {
    /// All matches of the sequence.
    All,
    /// At most this many per frame pair and camera, spread over the image.
    AtMost(usize),
}

impl fmt::Display for MatchCount {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            MatchCount::All => f.write_str("all"),
            MatchCount::AtMost(n) => write!(f, "{n}"),
        }
    }
}

/// The loss scales: one list for every metric, or a list per metric type.
#[derive(Clone, Debug, PartialEq)]
pub enum LossScales {
    /// The same scales for every metric.
    All(Vec<f64>),
    /// Scales per metric type tag.
    PerMetric(BTreeMap<String, Vec<f64>>),
}

/// A sweep grid (see the [module docs](self)).
#[derive(Clone, Debug, PartialEq)]
pub struct Grid {
    /// Motion models.
    pub models: Vec<AxisEntry>,
    /// Residual metrics.
    pub metrics: Vec<AxisEntry>,
    /// Robust losses (their scale comes from `loss_scales` unless the entry sets it).
    pub losses: Vec<AxisEntry>,
    /// Loss scales.
    pub loss_scales: LossScales,
    /// Solvers.
    pub solvers: Vec<AxisEntry>,
    /// Matches per frame pair and camera.
    pub matches: Vec<MatchCount>,
    /// Seed of the sub-sampling.
    pub seed: u64,
    /// Use only the first `max_frames` frames of every sequence.
    pub max_frames: Option<usize>,
    /// `[odometry]` options for every job.
    pub odometry: Option<Table>,
}

/// One combination of the grid: everything of a job but the sequence.
#[derive(Clone, Debug, PartialEq)]
pub struct Combination {
    /// Model label ([`AxisEntry::label`]).
    pub model: String,
    /// Metric label.
    pub metric: String,
    /// Loss label (without the scale).
    pub loss: String,
    /// The loss scale (`None` for `trivial`).
    pub loss_scale: Option<f64>,
    /// Solver label.
    pub solver: String,
    /// Matches per frame pair and camera.
    pub matches: MatchCount,
    /// The estimator configuration as TOML (`[model]`, `[metric]`, `[loss]`, `[solver]`,
    /// optional `[odometry]`).
    pub config: Table,
}

impl Combination {
    /// `model / metric / loss scale / solver / matches`.
    pub fn label(&self) -> String {
        let scale = self.loss_scale.map_or(String::new(), |s| format!(" {s}"));
        format!(
            "{} / {} / {}{} / {} / {}",
            self.model, self.metric, self.loss, scale, self.solver, self.matches
        )
    }

    /// The estimator configuration of this combination (validated).
    pub fn build_config(&self) -> Result<Config, momo_vo::ConfigError> {
        let name = self.label();
        let mut table = self.config.clone();
        if self.loss == "trivial" {
            // The rotation prior is measured in units of the loss scale, which a trivial loss
            // does not have (issue 15: momo_vo rejects the pair): off unless the grid sets it.
            if let Value::Table(odometry) = table
                .entry("odometry")
                .or_insert_with(|| Value::Table(Default::default()))
            {
                odometry
                    .entry("rotation_change_sigma")
                    .or_insert(Value::Float(0.0));
            }
        }
        let config: Config = Value::Table(table)
            .try_into()
            .map_err(|e: toml::de::Error| momo_vo::ConfigError::Parse {
                path: name.clone(),
                line: 1,
                reason: e.message().trim().to_string(),
            })?;
        config.validate(&name)?;
        Ok(config)
    }

    /// Whether model, metric, loss (with scale) and solver (with its options) are those of
    /// [`Config::default`] (the `[odometry]` options are not compared).
    pub fn is_default(&self) -> bool {
        let Ok(default) = Value::try_from(Config::default()) else {
            return false;
        };
        let Ok(mine) = self.build_config().and_then(|c| {
            Value::try_from(c).map_err(|e| momo_vo::ConfigError::Invalid {
                path: String::new(),
                reason: e.to_string(),
            })
        }) else {
            return false;
        };
        ["model", "metric", "loss", "solver"]
            .iter()
            .all(|k| default.get(k) == mine.get(k))
    }
}

/// The grid file as written.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawGrid {
    models: Spanned<Vec<Spanned<Value>>>,
    metrics: Spanned<Vec<Spanned<Value>>>,
    losses: Spanned<Vec<Spanned<Value>>>,
    loss_scales: Spanned<Value>,
    solvers: Spanned<Vec<Spanned<Value>>>,
    #[serde(default)]
    matches: Option<Spanned<Vec<Spanned<Value>>>>,
    #[serde(default)]
    seed: Option<u64>,
    #[serde(default)]
    max_frames: Option<Spanned<usize>>,
    #[serde(default)]
    odometry: Option<Spanned<Table>>,
}

/// Locates byte offsets as lines of the grid text.
struct Locator<'a> {
    text: &'a str,
    name: &'a str,
}

impl Locator<'_> {
    fn line(&self, offset: usize) -> usize {
        self.text[..offset.min(self.text.len())]
            .matches('\n')
            .count()
            + 1
    }

    fn err(&self, offset: usize, reason: impl Into<String>) -> SweepError {
        SweepError::Grid {
            path: self.name.into(),
            line: self.line(offset),
            reason: reason.into(),
        }
    }
}

/// Which configuration trait an axis entry must deserialise into.
#[derive(Clone, Copy)]
enum Axis {
    Model,
    Metric,
    Loss,
    Solver,
}

impl Axis {
    fn name(self) -> &'static str {
        match self {
            Axis::Model => "models",
            Axis::Metric => "metrics",
            Axis::Loss => "losses",
            Axis::Solver => "solvers",
        }
    }

    /// Checks that the section deserialises (type tag known, options valid).
    fn check(self, table: &Table) -> Result<(), String> {
        let v = Value::Table(table.clone());
        let r = match self {
            Axis::Model => v.try_into::<Box<dyn ModelSpec>>().map(drop),
            Axis::Metric => v.try_into::<Box<dyn MetricSpec>>().map(drop),
            Axis::Loss => v.try_into::<Box<dyn RobustLoss>>().map(drop),
            Axis::Solver => v.try_into::<Box<dyn Solver>>().map(drop),
        };
        r.map_err(|e| e.message().trim().to_string())
    }
}

/// Scale of a loss that has none (checked against `trivial`'s registration).
fn takes_scale(table: &Table) -> bool {
    let mut t = table.clone();
    t.insert("scale".into(), Value::Float(1.0));
    Axis::Loss.check(&t).is_ok()
}

fn axis(
    loc: &Locator<'_>,
    which: Axis,
    raw: Spanned<Vec<Spanned<Value>>>,
) -> Result<Vec<AxisEntry>, SweepError> {
    let span = raw.span();
    let entries = raw.into_inner();
    if entries.is_empty() {
        return Err(loc.err(span.start, format!("`{}` is empty", which.name())));
    }
    let mut out: Vec<AxisEntry> = Vec::with_capacity(entries.len());
    for e in entries {
        let at = e.span().start;
        let table = match e.into_inner() {
            Value::String(s) => {
                let mut t = Table::new();
                t.insert("type".into(), Value::String(s));
                t
            }
            Value::Table(t) => t,
            other => {
                return Err(loc.err(
                    at,
                    format!(
                        "`{}`: expected a type name or an inline table with `type`, found {}",
                        which.name(),
                        other.type_str()
                    ),
                ));
            }
        };
        let Some(type_name) = table.get("type").and_then(Value::as_str).map(str::to_owned) else {
            return Err(loc.err(at, format!("`{}`: entry without `type`", which.name())));
        };
        // A loss is checked with a scale if it takes one (the scale comes from the axis).
        let mut checked = table.clone();
        if matches!(which, Axis::Loss) && !table.contains_key("scale") && takes_scale(&table) {
            checked.insert("scale".into(), Value::Float(1.0));
        }
        which
            .check(&checked)
            .map_err(|reason| loc.err(at, format!("`{}`: {reason}", which.name())))?;
        let entry = AxisEntry { type_name, table };
        if out.iter().any(|o| o.label() == entry.label()) {
            return Err(loc.err(
                at,
                format!("`{}`: `{}` is listed twice", which.name(), entry.label()),
            ));
        }
        out.push(entry);
    }
    Ok(out)
}

fn scale_list(loc: &Locator<'_>, at: usize, v: &Value, what: &str) -> Result<Vec<f64>, SweepError> {
    let Some(list) = v.as_array() else {
        return Err(loc.err(at, format!("{what}: expected a list of numbers")));
    };
    if list.is_empty() {
        return Err(loc.err(at, format!("{what} is empty")));
    }
    let mut out = Vec::with_capacity(list.len());
    for x in list {
        let s = match x {
            Value::Float(f) => *f,
            Value::Integer(i) => *i as f64,
            other => {
                return Err(loc.err(
                    at,
                    format!("{what}: expected numbers, found {}", other.type_str()),
                ));
            }
        };
        if !(s.is_finite() && s > 0.0) {
            return Err(loc.err(
                at,
                format!("{what}: scales must be finite and > 0, found {s}"),
            ));
        }
        if out.contains(&s) {
            return Err(loc.err(at, format!("{what}: {s} is listed twice")));
        }
        out.push(s);
    }
    Ok(out)
}

/// The largest grid file read (1 MiB).
pub const MAX_GRID_BYTES: u64 = 1 << 20;
/// The most combinations a grid may have (counted before they are expanded); at seconds per
/// job and sequence, more is weeks of computing, and each expanded combination holds its
/// configuration in memory.
pub const MAX_COMBINATIONS: usize = 20_000;

impl Grid {
    /// Reads a grid file (TOML).
    /// Files larger than [`MAX_GRID_BYTES`] are refused without reading them whole.
    pub fn from_file(path: &Path) -> Result<Self, SweepError> {
        use std::io::Read;
        let read_err = |error| SweepError::Read {
            path: path.display().to_string(),
            error,
        };
        let file = std::fs::File::open(path).map_err(read_err)?;
        let mut bytes = Vec::new();
        file.take(MAX_GRID_BYTES + 1)
            .read_to_end(&mut bytes)
            .map_err(read_err)?;
        if bytes.len() as u64 > MAX_GRID_BYTES {
            return Err(SweepError::Input(format!(
                "{}: larger than {MAX_GRID_BYTES} bytes (a grid is a few kB)",
                path.display()
            )));
        }
        let text = String::from_utf8(bytes)
            .map_err(|_| SweepError::Input(format!("{}: invalid UTF-8", path.display())))?;
        Self::from_toml_str(&text, &path.display().to_string())
    }

    /// Parses a grid; `name` is used in messages.
    pub fn from_toml_str(text: &str, name: &str) -> Result<Self, SweepError> {
        let loc = Locator { text, name };
        let raw: RawGrid = toml::from_str(text).map_err(|e| {
            loc.err(
                e.span().map_or(0, |s| s.start),
                e.message().trim().to_string(),
            )
        })?;
        let models = axis(&loc, Axis::Model, raw.models)?;
        let metrics = axis(&loc, Axis::Metric, raw.metrics)?;
        let losses = axis(&loc, Axis::Loss, raw.losses)?;
        let solvers = axis(&loc, Axis::Solver, raw.solvers)?;

        let at = raw.loss_scales.span().start;
        let loss_scales = match raw.loss_scales.get_ref() {
            v @ Value::Array(_) => LossScales::All(scale_list(&loc, at, v, "loss_scales")?),
            Value::Table(t) => {
                let mut per = BTreeMap::new();
                for (k, v) in t {
                    if !metrics.iter().any(|m| &m.type_name == k) {
                        return Err(loc.err(
                            at,
                            format!("loss_scales.{k}: `{k}` is not one of the grid's metrics"),
                        ));
                    }
                    per.insert(
                        k.clone(),
                        scale_list(&loc, at, v, &format!("loss_scales.{k}"))?,
                    );
                }
                if let Some(m) = metrics.iter().find(|m| !per.contains_key(&m.type_name)) {
                    return Err(loc.err(
                        at,
                        format!("loss_scales has no list for metric `{}`", m.type_name),
                    ));
                }
                LossScales::PerMetric(per)
            }
            other => {
                return Err(loc.err(
                    at,
                    format!(
                        "loss_scales: expected a list or a table of lists per metric, found {}",
                        other.type_str()
                    ),
                ));
            }
        };

        let matches = match raw.matches {
            None => vec![MatchCount::All],
            Some(list) => {
                let span = list.span();
                let list = list.into_inner();
                if list.is_empty() {
                    return Err(loc.err(span.start, "`matches` is empty"));
                }
                let mut out = Vec::with_capacity(list.len());
                for v in list {
                    let at = v.span().start;
                    let m = match v.get_ref() {
                        Value::Integer(0) => MatchCount::All,
                        Value::Integer(n) if *n > 0 => MatchCount::AtMost(
                            usize::try_from(*n).map_err(|_| loc.err(at, "matches: too large"))?,
                        ),
                        Value::String(s) if s == "all" => MatchCount::All,
                        other => {
                            return Err(loc.err(
                                at,
                                format!(
                                    "matches: expected a positive number or \"all\", found {other}"
                                ),
                            ));
                        }
                    };
                    if out.contains(&m) {
                        return Err(loc.err(at, format!("matches: {m} is listed twice")));
                    }
                    out.push(m);
                }
                out
            }
        };
        let max_frames = match raw.max_frames {
            Some(m) if *m.get_ref() < 2 => {
                return Err(loc.err(m.span().start, "max_frames must be at least 2"));
            }
            m => m.map(Spanned::into_inner),
        };
        let grid = Grid {
            models,
            metrics,
            losses,
            loss_scales,
            solvers,
            matches,
            seed: raw.seed.unwrap_or(1),
            max_frames,
            odometry: raw.odometry.as_ref().map(|o| o.get_ref().clone()),
        };
        // Counted before anything is expanded: a 3,000 x 3,000 grid was expanded until the
        // kernel killed the process at 24 GB.
        let count = grid.combination_count();
        if count > MAX_COMBINATIONS {
            return Err(loc.err(
                0,
                format!(
                    "the grid has {count} combinations; at most {MAX_COMBINATIONS} are supported \
                     (split it into several grids)"
                ),
            ));
        }
        // The odometry options are checked by building the first combination.
        if let Some(first) = grid.combinations().first()
            && let Err(e) = first.build_config()
        {
            let at = raw.odometry.as_ref().map_or(0, |o| o.span().start);
            return Err(loc.err(at, e.to_string()));
        }
        Ok(grid)
    }

    /// The scales of `loss` with `metric`: `[None]` for a loss without scale or with its own.
    fn scales(&self, metric: &AxisEntry, loss: &AxisEntry) -> Vec<Option<f64>> {
        if loss.table.contains_key("scale") || !takes_scale(&loss.table) {
            return vec![None];
        }
        let list = match &self.loss_scales {
            LossScales::All(l) => l.as_slice(),
            LossScales::PerMetric(m) => m.get(&metric.type_name).map_or(&[][..], Vec::as_slice),
        };
        list.iter().copied().map(Some).collect()
    }

    /// The number of combinations, counted without expanding them (saturating at `usize::MAX`).
    pub fn combination_count(&self) -> usize {
        let mut per_model = 0usize;
        for metric in &self.metrics {
            for loss in &self.losses {
                let scales = if loss.table.contains_key("scale") || !takes_scale(&loss.table) {
                    1
                } else {
                    match &self.loss_scales {
                        LossScales::All(l) => l.len(),
                        LossScales::PerMetric(m) => m.get(&metric.type_name).map_or(0, Vec::len),
                    }
                };
                per_model = per_model.saturating_add(scales);
            }
        }
        per_model
            .saturating_mul(self.models.len())
            .saturating_mul(self.solvers.len())
            .saturating_mul(self.matches.len())
    }

    /// Every combination, in a fixed order: models, then metrics, losses, scales, solvers and
    /// match counts (the last varies fastest).
    pub fn combinations(&self) -> Vec<Combination> {
        let mut out = Vec::new();
        for model in &self.models {
            for metric in &self.metrics {
                for loss in &self.losses {
                    for scale in self.scales(metric, loss) {
                        for solver in &self.solvers {
                            for &matches in &self.matches {
                                let mut loss_table = loss.table.clone();
                                if let Some(s) = scale {
                                    loss_table.insert("scale".into(), Value::Float(s));
                                }
                                let mut config = Table::new();
                                config.insert("model".into(), Value::Table(model.table.clone()));
                                config.insert("metric".into(), Value::Table(metric.table.clone()));
                                config.insert("loss".into(), Value::Table(loss_table.clone()));
                                config.insert("solver".into(), Value::Table(solver.table.clone()));
                                if let Some(o) = &self.odometry {
                                    config.insert("odometry".into(), Value::Table(o.clone()));
                                }
                                out.push(Combination {
                                    model: model.label(),
                                    metric: metric.label(),
                                    loss: loss.label(),
                                    loss_scale: scale.or_else(|| {
                                        loss_table.get("scale").and_then(|v| match v {
                                            Value::Float(f) => Some(*f),
                                            Value::Integer(i) => Some(*i as f64),
                                            _ => None,
                                        })
                                    }),
                                    solver: solver.label(),
                                    matches,
                                    config,
                                });
                            }
                        }
                    }
                }
            }
        }
        out
    }

    /// A canonical text of everything that determines the result rows (for the grid id).
    pub fn canonical(&self) -> String {
        let combos: Vec<String> = self
            .combinations()
            .iter()
            .map(|c| {
                format!(
                    "{}|{}",
                    canonical(&Value::Table(c.config.clone())),
                    c.matches
                )
            })
            .collect();
        format!(
            "seed={};max_frames={:?};{}",
            self.seed,
            self.max_frames,
            combos.join(";")
        )
    }
}

/// The entries of a table sorted by key.
fn sorted(t: &Table) -> Vec<(&String, &Value)> {
    let mut v: Vec<_> = t.iter().collect();
    v.sort_by(|a, b| a.0.cmp(b.0));
    v
}

/// A canonical one-line rendering of a value (tables with sorted keys).
fn canonical(v: &Value) -> String {
    match v {
        Value::Table(t) => {
            let inner: Vec<String> = sorted(t)
                .into_iter()
                .map(|(k, v)| format!("{k}={}", canonical(v)))
                .collect();
            format!("{{{}}}", inner.join(","))
        }
        Value::Array(a) => {
            let inner: Vec<String> = a.iter().map(canonical).collect();
            format!("[{}]", inner.join(","))
        }
        Value::String(s) => format!("{s:?}"),
        Value::Float(f) => format!("{f:?}"),
        other => other.to_string(),
    }
}
