//! The Markdown summary of a results table: per sequence, the combinations ranked, the best one
//! named, where the default configuration ranks, and which axis values rank well on average.

use crate::results::{RankBy, Row, Status};
use std::collections::BTreeMap;
use std::fmt::Write as _;

/// What the summary shows.
#[derive(Clone, Copy, Debug, Default)]
pub struct SummaryOptions {
    /// The rank criterion.
    pub rank_by: RankBy,
    /// Show at most this many ranked rows per sequence (the default configuration is always
    /// shown); `None`: all.
    pub top: Option<usize>,
}

/// The rows of one sequence, ranked: ok rows by the criterion (ties by job number), then the
/// rest (failed or unscored) in job order.
pub fn ranked(rows: &[Row], sequence: &str, by: RankBy) -> Vec<Row> {
    let mut v: Vec<Row> = rows
        .iter()
        .filter(|r| r.sequence == sequence)
        .cloned()
        .collect();
    v.sort_by(|a, b| match (a.key(by), b.key(by)) {
        (Some(x), Some(y)) => x.total_cmp(&y).then(a.job.cmp(&b.job)),
        (Some(_), None) => std::cmp::Ordering::Less,
        (None, Some(_)) => std::cmp::Ordering::Greater,
        (None, None) => a.job.cmp(&b.job),
    });
    v
}

/// The sequences in the order of their first row.
fn sequences(rows: &[Row]) -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    for r in rows {
        if !out.contains(&r.sequence) {
            out.push(r.sequence.clone());
        }
    }
    out
}

fn f(v: Option<f64>, digits: usize) -> String {
    v.map_or("-".into(), |x| format!("{x:.digits$}"))
}

fn table_header(out: &mut String) {
    out.push_str(
        "| rank | combination | mean | median | p95 | max | >1° | t_err % | r_err °/100m | iter | µs/frame |\n\
         | ---: | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |\n",
    );
}

fn table_row(out: &mut String, rank: usize, r: &Row) {
    let name = if r.is_default {
        format!("**{}** (default)", r.combination)
    } else {
        r.combination.clone()
    };
    let _ = writeln!(
        out,
        "| {rank} | {name} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
        f(r.rot_mean_deg, 4),
        f(r.rot_median_deg, 4),
        f(r.rot_p95_deg, 4),
        f(r.rot_max_deg, 3),
        r.above_1deg.map_or("-".into(), |v| v.to_string()),
        f(r.t_err_percent, 2),
        f(r.r_err_deg_per_100m, 3),
        f(r.mean_iterations, 1),
        f(r.us_per_frame, 0),
    );
}

/// Mean rank of each value of each axis over the ranked combinations of one sequence.
fn axis_ranks(ranked: &[Row], by: RankBy) -> BTreeMap<(usize, String), (f64, usize)> {
    let mut acc: BTreeMap<(usize, String), (f64, usize)> = BTreeMap::new();
    for (i, r) in ranked.iter().enumerate() {
        if r.key(by).is_none() {
            continue;
        }
        let scale = r.loss_scale.map_or(String::new(), |s| format!(" {s}"));
        let values = [
            r.model.clone(),
            r.metric.clone(),
            format!("{}{scale}", r.loss),
            r.solver.clone(),
            r.matches.clone(),
        ];
        for (a, v) in values.into_iter().enumerate() {
            let e = acc.entry((a, v)).or_insert((0.0, 0));
            e.0 += (i + 1) as f64;
            e.1 += 1;
        }
    }
    acc
}

const AXES: [&str; 5] = ["model", "metric", "loss", "solver", "matches"];

/// Renders the summary of `rows` (any order; several sequences).
pub fn summary_markdown(rows: &[Row], options: &SummaryOptions) -> String {
    let by = options.rank_by;
    let seqs = sequences(rows);
    let mut out = String::new();
    let grid = rows.first().map_or("-", |r| r.grid_id.as_str());
    let failed = rows.iter().filter(|r| r.status != Status::Ok).count();
    let combos = rows
        .iter()
        .map(|r| r.combination.as_str())
        .collect::<std::collections::BTreeSet<_>>()
        .len();
    let _ = writeln!(
        out,
        "# momo sweep\n\n{} jobs ({} combinations on {} sequence(s), grid `{grid}`), {failed} failed. \
         Ranked by the {} (lower is better). Rotation errors are frame to frame, in degrees \
         (mean, median, 95th percentile, max, count above 1°); t_err and r_err are the KITTI \
         devkit's (\"-\": path shorter than 100 m); iter is the mean solver iterations per frame \
         pair; µs/frame the estimator's mean compute time per frame pair, measured while other \
         jobs ran in parallel (indicative only).\n",
        rows.len(),
        combos,
        seqs.len(),
        by.describe()
    );

    out.push_str("## Best combination per sequence\n\n");
    out.push_str(
        "| sequence | best combination | mean | median | max | >1° | t_err % | µs/frame | default's rank |\n\
         | --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | --- |\n",
    );
    let mut rankings = Vec::new();
    for s in &seqs {
        let r = ranked(rows, s, by);
        let scored = r.iter().filter(|x| x.key(by).is_some()).count();
        let default_rank =
            r.iter()
                .position(|x| x.is_default)
                .map_or("not in grid".to_string(), |i| {
                    if r[i].key(by).is_some() {
                        format!("{} of {scored}", i + 1)
                    } else {
                        "failed".into()
                    }
                });
        match r.first().filter(|x| x.key(by).is_some()) {
            Some(best) => {
                let _ = writeln!(
                    out,
                    "| {s} | {} | {} | {} | {} | {} | {} | {} | {default_rank} |",
                    best.combination,
                    f(best.rot_mean_deg, 4),
                    f(best.rot_median_deg, 4),
                    f(best.rot_max_deg, 3),
                    best.above_1deg.map_or("-".into(), |v| v.to_string()),
                    f(best.t_err_percent, 2),
                    f(best.us_per_frame, 0),
                );
            }
            None => {
                let _ = writeln!(out, "| {s} | (no run succeeded) | | | | | | | |");
            }
        }
        rankings.push((s, r));
    }

    out.push_str(
        "\n## Axis values: mean rank over the combinations that use them (lower is better)\n\n",
    );
    let per_seq: Vec<_> = rankings.iter().map(|(_, r)| axis_ranks(r, by)).collect();
    let mut keys: Vec<(usize, String)> = per_seq.iter().flat_map(|m| m.keys().cloned()).collect();
    keys.sort();
    keys.dedup();
    let _ = write!(out, "| axis | value |");
    for (s, _) in &rankings {
        let _ = write!(out, " {s} |");
    }
    out.push_str("\n| --- | --- |");
    for _ in &rankings {
        out.push_str(" ---: |");
    }
    out.push('\n');
    for key in &keys {
        let _ = write!(out, "| {} | {} |", AXES[key.0], key.1);
        for m in &per_seq {
            let cell = m
                .get(key)
                .map_or("-".into(), |(sum, n)| format!("{:.1}", sum / *n as f64));
            let _ = write!(out, " {cell} |");
        }
        out.push('\n');
    }

    for (s, r) in &rankings {
        let _ = writeln!(out, "\n## {s}\n");
        table_header(&mut out);
        let ok: Vec<&Row> = r.iter().filter(|x| x.key(by).is_some()).collect();
        let limit = options.top.unwrap_or(usize::MAX);
        for (i, row) in ok.iter().enumerate() {
            if i < limit || row.is_default {
                table_row(&mut out, i + 1, row);
            }
        }
        if ok.len() > limit {
            let _ = writeln!(
                out,
                "\n{} more ranked combinations in results.csv.",
                ok.len() - limit
            );
        }
        let bad: Vec<&Row> = r.iter().filter(|x| x.key(by).is_none()).collect();
        if !bad.is_empty() {
            let _ = writeln!(out, "\nNot ranked ({}):\n", bad.len());
            for b in bad {
                let what = match b.status {
                    Status::Ok => "no value to rank by".to_string(),
                    Status::Error => format!("error: {}", b.error),
                    Status::Panic => format!("panic: {}", b.error),
                };
                let _ = writeln!(out, "- {}: {}", b.combination, what.replace('\n', " "));
            }
        }
    }
    out
}
