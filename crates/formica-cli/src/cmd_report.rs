//! `formica report DB --out DIR`: plots (PNG and SVG) and a Markdown summary of a result store.
//!
//! - `success-KEY`: success rate with 95 % Wilson intervals against each varied key;
//! - `survival`: Kaplan-Meier curves of completion time (timeouts censored at their time;
//!   wall failures never complete);
//! - `path-efficiency-KEY`: mean path efficiency (successful trials) with a 95 % interval;
//! - `time-vs-robots`: censored median completion time (bars: censored quartiles) against the
//!   number of robots;
//! - `trajectories`: the object's paths, coloured by outcome (if the store has them);
//! - `fill-KEY`: convexity after filling and cavity filled (if the trials report them);
//! - `extra-FIELD-KEY`: the mean of each numeric end-of-run field that loop functions added
//!   (`RunResult::extra`), with a 95 % interval;
//! - `summary.md`: one table row per parameter set (end-of-run fields: their means), the
//!   provenance of the store, and the failed trials of each parameter set with the command that
//!   replays each and a gallery of pictures of how the first ones ended (`failures/trial-N.png`);
//! - `trials.csv`: every trial, one row each, as `formica export` writes it.

use crate::gallery::Listed;
use crate::plots::{self, CategoryPlot, Estimate, LinePlot};
use crate::stats::{censored_median, mean_of, wilson95};
use crate::store::{Store, StoredTrial};
use crate::CliError;
use anyhow::Context;
use formica::{Outcome, RunResult};
use std::collections::{BTreeMap, HashMap, HashSet};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Arguments of `formica report`.
#[derive(clap::Args)]
pub struct Args {
    /// Result store (SQLite) written by `formica sweep` or `formica merge`.
    pub db: PathBuf,
    /// Folder for the plots, `summary.md` and `trials.csv`.
    #[arg(long)]
    pub out: PathBuf,
    /// At most this many trajectories in the overlay.
    #[arg(long, default_value_t = 300)]
    pub max_trajectories: usize,
    /// List at most this many failed trials per parameter set.
    #[arg(long, default_value_t = 20)]
    pub failures: usize,
    /// Draw how this many failed trials per parameter set ended (replaying them); 0: none.
    #[arg(long, default_value_t = 3)]
    pub gallery: usize,
}

impl Args {
    /// The options given that are not their defaults, as they would be typed (each with a
    /// leading space), so that the report says how to remake it.
    fn options(&self) -> String {
        let mut o = String::new();
        if self.max_trajectories != 300 {
            o += &format!(" --max-trajectories {}", self.max_trajectories);
        }
        if self.failures != 20 {
            o += &format!(" --failures {}", self.failures);
        }
        if self.gallery != 3 {
            o += &format!(" --gallery {}", self.gallery);
        }
        o
    }
}

thread_local! {
    /// Scenario file stems that name more than one file among the report's trials
    /// (`a/seed-transport.toml` and `b/seed-transport.toml`): those are labelled by path.
    static SHARED_STEMS: std::cell::RefCell<std::collections::HashSet<String>> =
        std::cell::RefCell::default();
}

/// A scenario path's file stem (`qm-open` for `../scenarios/qm-open.toml`).
fn stem(path: &str) -> String {
    Path::new(path)
        .file_stem()
        .map_or_else(|| path.to_string(), |x| x.to_string_lossy().into_owned())
}

/// Notes which scenario stems of `rows` name more than one file, for [`label`].
fn note_shared_stems(rows: &[StoredTrial]) {
    let mut paths: HashMap<String, std::collections::HashSet<&str>> = HashMap::new();
    for r in rows {
        if let Some(serde_json::Value::String(s)) = r.params.get("scenario") {
            paths.entry(stem(s)).or_default().insert(s);
        }
    }
    SHARED_STEMS.with(|shared| {
        *shared.borrow_mut() = paths
            .into_iter()
            .filter(|(_, p)| p.len() > 1)
            .map(|(stem, _)| stem)
            .collect();
    });
}

/// A short label of a parameter value (a scenario by its file's stem, or its path where two
/// files share the stem).
fn label(key: &str, v: &serde_json::Value) -> String {
    match v {
        serde_json::Value::String(s) if key == "scenario" => {
            let short = stem(s);
            if SHARED_STEMS.with(|shared| shared.borrow().contains(&short)) {
                s.clone()
            } else {
                short
            }
        }
        serde_json::Value::String(s) => s.clone(),
        other => other.to_string(),
    }
}

/// File-name-safe form of a key.
fn slug(key: &str) -> String {
    key.chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '-' })
        .collect()
}

/// Longest [`slug`] kept whole in a file name.
const MAX_SLUG: usize = 60;

/// [`slug`] of `value` for a file name of its own among `taken` (which it joins): cut to
/// [`MAX_SLUG`] characters, with a short hash of the whole value after it when it was cut, is
/// not plain ASCII, or is another value's slug already (`friction α` and `friction β`).
fn unique_slug(value: &str, taken: &mut std::collections::HashSet<String>) -> String {
    let plain = slug(value);
    let lossy = plain.len() > MAX_SLUG || !value.is_ascii() || taken.contains(&plain);
    let s = if lossy {
        let hash = crate::provenance::sha256_hex(value.as_bytes());
        format!("{}-{}", &plain[..plain.len().min(MAX_SLUG)], &hash[..8])
    } else {
        plain
    };
    taken.insert(s.clone());
    s
}

/// Distinct values of `key` in trial order (numbers sorted numerically), then `-` if some
/// parameter sets (cases) do not set it, so that no trial drops out of a plot split by it.
fn values_of(rows: &[StoredTrial], key: &str) -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    let mut numeric = true;
    let mut unset = false;
    for r in rows {
        let l = if let Some(v) = r.params.get(key) {
            numeric &= v.is_number();
            label(key, v)
        } else if let Some(l) = ran_controller(r, key) {
            numeric = false;
            l
        } else {
            unset = true;
            continue;
        };
        if !out.contains(&l) {
            out.push(l);
        }
    }
    if numeric {
        out.sort_by(|a, b| {
            let (x, y) = (
                a.parse::<f64>().unwrap_or(0.0),
                b.parse::<f64>().unwrap_or(0.0),
            );
            x.total_cmp(&y)
        });
    }
    if unset {
        out.push("-".into());
    }
    out
}

fn value(r: &StoredTrial, key: &str) -> String {
    match r.params.get(key) {
        Some(v) => label(key, v),
        None => ran_controller(r, key).unwrap_or_else(|| "-".into()),
    }
}

/// For a controller key the trial leaves unset (its case keeps the scenario file's controller),
/// the controller the trial ran, as its result records it.
fn ran_controller(r: &StoredTrial, key: &str) -> Option<String> {
    (key.ends_with(".controller") && !r.result.controller.is_empty())
        .then(|| r.result.controller.clone())
}

/// The key to split series by when plotting against `x_key`: another varied key with 2 to 6
/// values, a controller key first, else the one with the fewest values.
fn series_key(rows: &[StoredTrial], keys: &[String], x_key: Option<&str>) -> Option<String> {
    let mut cands: Vec<(bool, usize, String)> = keys
        .iter()
        .filter(|k| Some(k.as_str()) != x_key)
        .map(|k| {
            (
                !k.contains("controller"),
                values_of(rows, k).len(),
                k.clone(),
            )
        })
        .filter(|(_, n, _)| (2..=6).contains(n))
        .collect();
    cands.sort();
    cands.into_iter().next().map(|(_, _, k)| k)
}

/// Completion-time quantile with failures at +infinity.
fn censored_quantile(rs: &[&RunResult], q: f64) -> f64 {
    let mut t: Vec<f64> = rs
        .iter()
        .filter(|r| r.outcome == Outcome::Success)
        .map(|r| r.sim_time_s)
        .collect();
    t.sort_by(f64::total_cmp);
    let n = rs.len();
    if n == 0 {
        return f64::INFINITY;
    }
    let i = ((q * n as f64).ceil() as usize).max(1) - 1;
    t.get(i).copied().unwrap_or(f64::INFINITY)
}

/// Kaplan-Meier estimate of P(not yet at the goal at t): successes are events, timeouts are
/// censored at their time, wall failures never complete (censored at +infinity).
pub fn kaplan_meier(rs: &[&RunResult]) -> Vec<(f64, f64)> {
    let mut times: Vec<(f64, bool)> = rs
        .iter()
        .map(|r| match r.outcome {
            Outcome::Success => (r.sim_time_s, true),
            Outcome::Timeout => (r.sim_time_s, false),
            Outcome::Wall => (f64::INFINITY, false),
        })
        .collect();
    times.sort_by(|a, b| a.0.total_cmp(&b.0).then(b.1.cmp(&a.1)));
    let mut at_risk = times.len();
    let mut s = 1.0;
    let mut out = vec![(0.0, 1.0)];
    let mut i = 0;
    let mut last_t = 0.0f64;
    while i < times.len() {
        let t = times[i].0;
        let (mut d, mut c) = (0usize, 0usize);
        while i < times.len() && times[i].0 == t {
            if times[i].1 {
                d += 1;
            } else {
                c += 1;
            }
            i += 1;
        }
        if d > 0 && at_risk > 0 {
            s *= 1.0 - d as f64 / at_risk as f64;
            out.push((t, s));
        }
        if t.is_finite() {
            last_t = last_t.max(t);
        }
        at_risk -= d + c;
    }
    // Extend to the last time any trial ended (censored timeouts and wall hits included), so
    // that a set whose every trial hit a wall is drawn flat, not left out.
    let last_t = rs
        .iter()
        .map(|r| r.sim_time_s)
        .filter(|t| t.is_finite())
        .fold(last_t, f64::max);
    if out.last().is_some_and(|p| p.0 < last_t) {
        out.push((last_t, s));
    }
    out
}

fn mean_ci(xs: &[f64]) -> Option<Estimate> {
    if xs.is_empty() {
        return None;
    }
    let n = xs.len() as f64;
    let m = xs.iter().sum::<f64>() / n;
    let sd = if xs.len() > 1 {
        (xs.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (n - 1.0)).sqrt()
    } else {
        0.0
    };
    let h = 1.96 * sd / n.sqrt();
    Some(Estimate {
        y: m,
        lo: m - h,
        hi: m + h,
    })
}

fn fmt_opt(x: Option<f64>, digits: usize) -> String {
    x.map_or_else(|| "–".into(), |v| format!("{v:.digits$}"))
}

/// End-of-run fields (`RunResult::extra`) that some trial reports as a number, by name.
fn numeric_extras(rows: &[StoredTrial]) -> Vec<String> {
    let mut out: std::collections::BTreeSet<&String> = std::collections::BTreeSet::new();
    for r in rows {
        out.extend(
            r.result
                .extra
                .iter()
                .filter(|(_, v)| v.is_number())
                .map(|(k, _)| k),
        );
    }
    out.into_iter().cloned().collect()
}

/// The numeric values of end-of-run field `field` in `rs` (trials without it left out).
fn extra_values<'a>(rs: impl Iterator<Item = &'a RunResult>, field: &str) -> Vec<f64> {
    rs.filter_map(|r| r.extra.get(field).and_then(serde_json::Value::as_f64))
        .filter(|x| x.is_finite())
        .collect()
}

/// The trials of each parameter set, in the order the sets first appear.
pub fn by_set(rows: &[StoredTrial]) -> Vec<(&str, Vec<&StoredTrial>)> {
    let mut at: HashMap<&str, usize> = HashMap::new();
    let mut out: Vec<(&str, Vec<&StoredTrial>)> = Vec::new();
    for r in rows {
        let i = *at.entry(r.params_json.as_str()).or_insert_with(|| {
            out.push((r.params_json.as_str(), Vec::new()));
            out.len() - 1
        });
        out[i].1.push(r);
    }
    out
}

/// Groups rows by (x value, series value).
fn grouped(
    rows: &[StoredTrial],
    x: impl Fn(&StoredTrial) -> String,
    s: impl Fn(&StoredTrial) -> String,
) -> BTreeMap<(String, String), Vec<&RunResult>> {
    let mut g: BTreeMap<(String, String), Vec<&RunResult>> = BTreeMap::new();
    for r in rows {
        g.entry((x(r), s(r))).or_default().push(&r.result);
    }
    g
}

/// One category plot per metric estimator, against `x_key` values, split by `s_key`.
#[expect(
    clippy::too_many_arguments,
    reason = "one call per figure, each argument named at the call"
)]
fn category_plot(
    rows: &[StoredTrial],
    x_key: &str,
    x_cats: Vec<String>,
    x_of: &dyn Fn(&StoredTrial) -> String,
    s_key: Option<&str>,
    est: &dyn Fn(&[&RunResult]) -> Option<Estimate>,
    title: String,
    y_desc: &str,
    y_range: Option<(f64, f64)>,
) -> CategoryPlot {
    let s_vals = s_key.map_or_else(|| vec![String::new()], |k| values_of(rows, k));
    let g = grouped(rows, x_of, |r| {
        s_key.map_or_else(String::new, |k| value(r, k))
    });
    let series = s_vals
        .iter()
        .map(|sv| {
            let name = s_key.map_or_else(String::new, |k| format!("{k} = {sv}"));
            let ests = x_cats
                .iter()
                .map(|xv| g.get(&(xv.clone(), sv.clone())).and_then(|rs| est(rs)))
                .collect();
            (name, ests)
        })
        .collect();
    let connect = x_cats.iter().all(|c| c.parse::<f64>().is_ok());
    CategoryPlot {
        connect,
        title,
        x_desc: x_key.to_string(),
        y_desc: y_desc.to_string(),
        categories: x_cats,
        series,
        y_range,
    }
}

/// Parameter sets (their canonical JSON) whose scenario has no success rule (no goal to reach
/// and no `stop.on_filled`: static filling; [`formica::Scenario::has_success_rule`]), read
/// from the scenarios the store keeps. A set whose scenario cannot be rebuilt, or with a
/// trial that succeeded, counts as having one.
fn sets_without_success_rule(db: &Path, rows: &[StoredTrial]) -> HashSet<String> {
    let Ok(mut replayer) = crate::replay::Replayer::open(db) else {
        return HashSet::new();
    };
    by_set(rows)
        .into_iter()
        .filter(|(_, rs)| {
            rs.iter().all(|r| r.result.outcome != Outcome::Success)
                && replayer
                    .trial(rs[0].trial)
                    .is_ok_and(|r| !r.scenario.has_success_rule())
        })
        .map(|(set, _)| set.to_string())
        .collect()
}

/// Runs the command.
pub fn main(a: Args) -> Result<(), CliError> {
    let store = Store::open_existing(&a.db)?;
    let rows = store.results()?;
    if rows.is_empty() {
        return Err(CliError::Input(format!(
            "{}: the store holds no trials yet",
            a.db.display()
        )));
    }
    let name = store.meta("name")?.unwrap_or_else(|| "sweep".into());
    note_shared_stems(&rows);
    // Trials that can succeed: success rates, survival curves and failed trials count these
    // only; the others (static filling, `endings`) are judged by their filling metrics.
    let unjudged = sets_without_success_rule(&a.db, &rows);
    let (scored, endings): (Vec<StoredTrial>, Vec<StoredTrial>) = rows
        .iter()
        .cloned()
        .partition(|r| !unjudged.contains(&r.params_json));
    let keys: Vec<String> = store
        .keys()?
        .into_iter()
        .filter(|k| rows.iter().any(|r| r.params.contains_key(k)))
        .collect();
    if a.out.exists() && !a.out.is_dir() {
        return Err(CliError::Input(format!(
            "--out {}: a file is there; --out names a folder for the report (made if missing)",
            a.out.display()
        )));
    }
    for name in ["summary.md", "trials.csv"] {
        crate::refuse_overwriting(&a.out.join(name), &a.db, "result store")?;
    }
    std::fs::create_dir_all(&a.out).with_context(|| format!("creating {}", a.out.display()))?;
    plots::init_font()?;
    let dir = a.out.as_path();
    let mut figures: Vec<(String, String)> = Vec::new();
    let any_success = rows.iter().any(|r| r.result.outcome == Outcome::Success);

    let success = |rs: &[&RunResult]| {
        let k = rs.iter().filter(|r| r.outcome == Outcome::Success).count();
        let [lo, hi] = wilson95(k, rs.len());
        Some(Estimate {
            y: k as f64 / rs.len().max(1) as f64,
            lo,
            hi,
        })
    };
    let efficiency = |rs: &[&RunResult]| {
        let xs: Vec<f64> = rs
            .iter()
            .filter(|r| {
                if any_success {
                    r.outcome == Outcome::Success
                } else {
                    r.object_path_m.is_some_and(|p| p > 0.01)
                }
            })
            .filter_map(|r| r.path_efficiency)
            .collect();
        mean_ci(&xs)
    };
    let eff_desc = if any_success {
        "path efficiency (successful trials)"
    } else {
        "path efficiency (trials that moved the object)"
    };
    // With case labels, keys that the label decides get no figures of their own.
    let decided_by_label = |k: &str| {
        if k == "label" || !keys.iter().any(|l| l == "label") {
            return false;
        }
        let mut seen: HashMap<String, String> = HashMap::new();
        rows.iter().all(|r| {
            let v = value(r, k);
            seen.entry(value(r, "label")).or_insert_with(|| v.clone()) == &v
        })
    };
    let plotted: Vec<String> = keys
        .iter()
        .filter(|k| !decided_by_label(k))
        .cloned()
        .collect();
    // Curves split by controller split by case instead when the case label decides the
    // controller and has few values: two cases that run one controller stay apart.
    let label_for_controller = keys
        .iter()
        .any(|k| k.ends_with(".controller") && decided_by_label(k))
        && (2..=6).contains(&values_of(&rows, "label").len());
    // The key to split curves by, among `ks`.
    let split_by = |ks: &[String]| {
        if label_for_controller {
            Some("label".to_string())
        } else {
            series_key(&rows, ks, None)
        }
    };
    let x_keys: Vec<Option<String>> = if plotted.is_empty() {
        vec![None]
    } else {
        plotted.iter().cloned().map(Some).collect()
    };
    let moved = rows
        .iter()
        .any(|r| r.result.object_path_m.is_some_and(|p| p > 0.01));
    let extras = numeric_extras(&rows);
    for xk in &x_keys {
        let (x_name, cats, stem): (String, Vec<String>, String) = match xk {
            Some(k) => (k.clone(), values_of(&rows, k), slug(k)),
            None => ("all trials".into(), vec!["all".into()], "all".into()),
        };
        let x_of = |r: &StoredTrial| xk.as_ref().map_or_else(|| "all".into(), |k| value(r, k));
        let s_key = series_key(&rows, &plotted, xk.as_deref());
        if !scored.is_empty() {
            let p = category_plot(
                &scored,
                &x_name,
                cats.clone(),
                &x_of,
                s_key.as_deref(),
                &success,
                format!("{name}: success rate (95 % Wilson)"),
                "success rate",
                Some((0.0, 1.0)),
            );
            let f = format!("success-{stem}");
            plots::save_category(dir, &f, &p)?;
            figures.push((f, format!("Success rate against {x_name}")));
        }
        if moved {
            let p = category_plot(
                &rows,
                &x_name,
                cats.clone(),
                &x_of,
                s_key.as_deref(),
                &efficiency,
                format!("{name}: path efficiency (mean, 95 % CI)"),
                eff_desc,
                Some((0.0, 1.05)),
            );
            let f = format!("path-efficiency-{stem}");
            plots::save_category(dir, &f, &p)?;
            figures.push((f, format!("Path efficiency against {x_name}")));
        }
        if rows.iter().any(|r| r.result.convexity_after.is_some()) {
            let g = grouped(&rows, x_of, |_| String::new());
            let metric = |f: fn(&RunResult) -> Option<f64>| {
                cats.iter()
                    .map(|c| {
                        g.get(&(c.clone(), String::new())).and_then(|rs| {
                            let xs: Vec<f64> = rs.iter().filter_map(|r| f(r)).collect();
                            mean_ci(&xs)
                        })
                    })
                    .collect::<Vec<_>>()
            };
            let p = CategoryPlot {
                connect: cats.iter().all(|c| c.parse::<f64>().is_ok()),
                title: format!("{name}: filling (mean, 95 % CI)"),
                x_desc: x_name.clone(),
                y_desc: "fraction".into(),
                categories: cats.clone(),
                series: vec![
                    ("convexity before".into(), metric(|r| r.convexity_before)),
                    ("convexity after".into(), metric(|r| r.convexity_after)),
                    ("cavity filled".into(), metric(|r| r.cavity_filled)),
                ],
                y_range: Some((0.0, 1.05)),
            };
            let f = format!("fill-{stem}");
            plots::save_category(dir, &f, &p)?;
            figures.push((f, format!("Filling metrics against {x_name}")));
        }
        for field in &extras {
            let mean = |rs: &[&RunResult]| mean_ci(&extra_values(rs.iter().copied(), field));
            let p = category_plot(
                &rows,
                &x_name,
                cats.clone(),
                &x_of,
                s_key.as_deref(),
                &mean,
                format!("{name}: {field} (mean, 95 % CI)"),
                field,
                None,
            );
            let f = format!("extra-{}-{stem}", slug(field));
            plots::save_category(dir, &f, &p)?;
            figures.push((f, format!("{field} against {x_name}")));
        }
    }

    // Survival curves (of trials that can succeed): per parameter set if few, else per value
    // of the series key.
    let scored_sets = by_set(&scored);
    let by_set = by_set(&rows);
    let sets: Vec<String> = by_set.iter().map(|(s, _)| s.to_string()).collect();
    let set_label = |r: &StoredTrial| {
        if keys.is_empty() {
            "all trials".to_string()
        } else {
            keys.iter()
                .filter(|k| r.params.contains_key(*k))
                .map(|k| format!("{k}={}", value(r, k)))
                .collect::<Vec<_>>()
                .join(", ")
        }
    };
    let (groups, by): (Vec<(String, Vec<&RunResult>)>, String) = if scored_sets.len() <= 8 {
        let mut g: Vec<(String, Vec<&RunResult>)> = Vec::new();
        for (_, rs) in &scored_sets {
            g.push((set_label(rs[0]), rs.iter().map(|r| &r.result).collect()));
        }
        (g, "parameter set".into())
    } else {
        let k = split_by(&keys).or_else(|| keys.first().cloned());
        match k {
            Some(k) => {
                let vals = values_of(&scored, &k);
                let g = vals
                    .iter()
                    .take(10)
                    .map(|v| {
                        (
                            format!("{k} = {v}"),
                            scored
                                .iter()
                                .filter(|r| &value(r, &k) == v)
                                .map(|r| &r.result)
                                .collect(),
                        )
                    })
                    .collect();
                let by = if vals.len() > 10 {
                    format!("{k} (its first 10 values of {})", vals.len())
                } else {
                    k
                };
                (g, by)
            }
            None => (
                vec![(
                    "all trials".into(),
                    scored.iter().map(|r| &r.result).collect(),
                )],
                "all".into(),
            ),
        }
    };
    let p = LinePlot {
        title: format!("{name}: completion time (Kaplan-Meier, timeouts censored)"),
        x_desc: "simulated time (s)".into(),
        y_desc: "fraction not yet at the goal".into(),
        curves: groups
            .iter()
            .map(|(l, rs)| (l.clone(), kaplan_meier(rs)))
            .collect(),
        steps: true,
        y_range: Some((0.0, 1.02)),
        equal_axes: false,
        legend: true,
        colors: Vec::new(),
    };
    if !scored.is_empty() {
        plots::save_lines(dir, "survival", &p)?;
        figures.push((
            "survival".into(),
            format!("Completion-time survival curves, by {by}"),
        ));
    }

    // Time against swarm size.
    let mut sizes: Vec<usize> = scored.iter().map(|r| r.result.robots).collect();
    sizes.sort_unstable();
    sizes.dedup();
    if sizes.len() > 1 && any_success {
        let count_key = keys.iter().find(|k| k.ends_with("count")).cloned();
        let others: Vec<String> = keys
            .iter()
            .filter(|k| Some(*k) != count_key.as_ref())
            .cloned()
            .collect();
        let s_key = split_by(&others);
        let cats: Vec<String> = sizes.iter().map(|n| n.to_string()).collect();
        let p = category_plot(
            &scored,
            "robots",
            cats,
            &|r: &StoredTrial| r.result.robots.to_string(),
            s_key.as_deref(),
            &|rs: &[&RunResult]| {
                let owned: Vec<RunResult> = rs.iter().map(|r| (*r).clone()).collect();
                censored_median(&owned).map(|m| Estimate {
                    y: m,
                    lo: censored_quantile(rs, 0.25),
                    hi: censored_quantile(rs, 0.75),
                })
            },
            format!("{name}: completion time against swarm size"),
            "median completion time (s; bars: quartiles)",
            None,
        );
        plots::save_category(dir, "time-vs-robots", &p)?;
        figures.push((
            "time-vs-robots".into(),
            "Completion time against swarm size (failures censored)".into(),
        ));
        // Survival curves by swarm size: one figure per value of the series key (at most 6).
        let parts: Vec<(String, Vec<&StoredTrial>)> = match &s_key {
            Some(k) => values_of(&scored, k)
                .into_iter()
                .take(6)
                .map(|v| {
                    let rs = scored.iter().filter(|r| value(r, k) == v).collect();
                    (v, rs)
                })
                .collect(),
            None => vec![(String::new(), scored.iter().collect())],
        };
        let mut taken = std::collections::HashSet::new();
        for (v, rs) in &parts {
            let curves: Vec<(String, Vec<(f64, f64)>)> = sizes
                .iter()
                .filter_map(|n| {
                    let g: Vec<&RunResult> = rs
                        .iter()
                        .filter(|r| r.result.robots == *n)
                        .map(|r| &r.result)
                        .collect();
                    (!g.is_empty()).then(|| (format!("N = {n}"), kaplan_meier(&g)))
                })
                .collect();
            let (stem, of) = if v.is_empty() {
                ("survival-robots".to_string(), String::new())
            } else {
                (
                    format!("survival-robots-{}", unique_slug(v, &mut taken)),
                    format!(", {v}"),
                )
            };
            let p = LinePlot {
                title: format!("{name}: completion time by swarm size{of}"),
                x_desc: "simulated time (s)".into(),
                y_desc: "fraction not yet at the goal".into(),
                curves,
                steps: true,
                y_range: Some((0.0, 1.02)),
                equal_axes: false,
                legend: true,
                colors: Vec::new(),
            };
            plots::save_lines(dir, &stem, &p)?;
            figures.push((
                stem,
                format!("Completion-time survival curves by swarm size{of}"),
            ));
        }
    }

    // Trajectories.
    let trajs = store.trajectories(a.max_trajectories)?;
    if !trajs.is_empty() {
        let outcome: BTreeMap<(String, u64), Outcome> = rows
            .iter()
            .map(|r| ((r.params_json.clone(), r.result.seed), r.result.outcome))
            .collect();
        let mut seen = [false; 3];
        let mut curves = Vec::new();
        let mut colors = Vec::new();
        for (p, seed, samples) in &trajs {
            let o = outcome
                .get(&(p.clone(), *seed))
                .copied()
                .unwrap_or(Outcome::Timeout);
            let ci = match o {
                Outcome::Success => 2,
                Outcome::Wall => 3,
                Outcome::Timeout => 7,
            };
            let slot = match o {
                Outcome::Success => 0,
                Outcome::Wall => 1,
                Outcome::Timeout => 2,
            };
            let name = if seen[slot] {
                String::new()
            } else {
                seen[slot] = true;
                o.name().to_string()
            };
            curves.push((name, samples.iter().map(|s| (s[1], s[2])).collect()));
            colors.push(ci);
        }
        let p = LinePlot {
            title: {
                let all = store.trajectory_count()?;
                if all > trajs.len() {
                    format!(
                        "{name}: object trajectories ({} of {all} trials, every set alike)",
                        trajs.len()
                    )
                } else {
                    format!("{name}: object trajectories ({} trials)", trajs.len())
                }
            },
            x_desc: "x (m)".into(),
            y_desc: "y (m)".into(),
            curves,
            steps: false,
            y_range: None,
            equal_axes: true,
            legend: true,
            colors,
        };
        plots::save_lines(dir, "trajectories", &p)?;
        figures.push(("trajectories".into(), "Object trajectories".into()));
    }

    // summary.md
    let mut md = String::new();
    let n = scored.len();
    let k = scored
        .iter()
        .filter(|r| r.result.outcome == Outcome::Success)
        .count();
    let [lo, hi] = wilson95(k, n);
    let _ = writeln!(md, "# {name}\n");
    let _ = write!(
        md,
        "{} trials in `{}`, {} parameter set(s)",
        rows.len(),
        crate::replay::store_name(&a.db),
        sets.len(),
    );
    if !unjudged.is_empty() {
        let _ = write!(
            md,
            "; {} of them, in {} parameter set(s), have no success rule (no goal to reach and no `stop.on_filled`: static filling, judged by the filling columns below) and are left out of success rates, survival curves and failed trials",
            rows.len() - n,
            unjudged.len()
        );
    }
    if n > 0 {
        let _ = write!(
            md,
            "; {k} successes{} ({:.1} %, 95 % Wilson CI {:.1}–{:.1} %)",
            if unjudged.is_empty() {
                String::new()
            } else {
                format!(" of the other {n}")
            },
            100.0 * k as f64 / n as f64,
            100.0 * lo,
            100.0 * hi
        );
    }
    md.push_str(".\n\n");
    let grid: Option<usize> = store.meta("grid_trials")?.and_then(|g| g.parse().ok());
    if let Some(grid) = grid.filter(|g| *g > rows.len()) {
        let _ = writeln!(
            md,
            "**A partial store**: it holds {} of the {grid} trials of its sweep (stopped early, \
             run with `--limit`, or one shard); `formica sweep` with the same file and store \
             runs the rest. Everything below covers the trials it holds.\n",
            rows.len()
        );
    }
    let _ = writeln!(
        md,
        "Every trial, one row each: [trials.csv](trials.csv) (the columns of `formica export`).\n"
    );
    let fill = rows.iter().any(|r| r.result.convexity_after.is_some());
    let mut head: Vec<String> = keys.iter().map(|k| format!("`{k}`")).collect();
    head.extend(
        [
            "trials",
            "success",
            "rate (95 % CI)",
            "wall",
            "timeout",
            "median time (s)",
            "path efficiency",
        ]
        .iter()
        .map(|s| s.to_string()),
    );
    if fill {
        head.extend(
            [
                "robots attached",
                "convexity before",
                "convexity after",
                "cavity filled",
                "cavity robots / capacity",
                "runs without false stops",
            ]
            .iter()
            .map(|s| s.to_string()),
        );
    }
    head.extend(extras.iter().map(|f| format!("`{f}` (mean)")));
    let _ = writeln!(md, "| {} |", head.join(" | "));
    let _ = writeln!(md, "|{}", "---|".repeat(head.len()));
    for (set, rs) in &by_set {
        let has_rule = !unjudged.contains(*set);
        let res: Vec<RunResult> = rs.iter().map(|r| r.result.clone()).collect();
        let refs: Vec<&RunResult> = res.iter().collect();
        let count = |o: Outcome| res.iter().filter(|r| r.outcome == o).count();
        let ok = count(Outcome::Success);
        let [lo, hi] = wilson95(ok, res.len());
        let mut cells: Vec<String> = keys.iter().map(|k| value(rs[0], k)).collect();
        let mean = |f: &dyn Fn(&RunResult) -> Option<f64>| mean_of(&res, f);
        cells.push(res.len().to_string());
        if has_rule {
            cells.push(ok.to_string());
            cells.push(format!(
                "{:.0} % ({:.0}–{:.0} %)",
                100.0 * ok as f64 / res.len() as f64,
                100.0 * lo,
                100.0 * hi
            ));
        } else {
            cells.push("–".to_string());
            cells.push("no success rule".to_string());
        }
        cells.push(count(Outcome::Wall).to_string());
        cells.push(count(Outcome::Timeout).to_string());
        cells.push(fmt_opt(censored_median(&res), 1));
        cells.push(fmt_opt(efficiency(&refs).map(|e| e.y), 3));
        if fill {
            cells.push(fmt_opt(mean(&|r| r.object_robots.map(|n| n as f64)), 1));
            cells.push(fmt_opt(mean(&|r| r.convexity_before), 3));
            cells.push(fmt_opt(mean(&|r| r.convexity_after), 3));
            cells.push(fmt_opt(mean(&|r| r.cavity_filled), 3));
            // Mean robots in the cavity over its capacity (the same test counts both).
            let robots = mean(&|r| r.cavity_robots.map(|n| n as f64));
            let cap = mean(&|r| r.cavity_capacity.map(|n| n as f64));
            cells.push(match (robots, cap) {
                (Some(n), Some(c)) if c > 0.0 => format!("{n:.1} / {c:.0} = {:.2}", n / c),
                (Some(n), Some(c)) => format!("{n:.1} / {c:.0}"),
                _ => "–".to_string(),
            });
            let judged = res.iter().filter(|r| r.false_stops.is_some()).count();
            let clean = res.iter().filter(|r| r.false_stops == Some(0)).count();
            cells.push(if judged > 0 {
                format!("{clean} / {judged}")
            } else {
                "–".to_string()
            });
        }
        for field in &extras {
            let xs = extra_values(res.iter(), field);
            let m = (!xs.is_empty()).then(|| xs.iter().sum::<f64>() / xs.len() as f64);
            cells.push(fmt_opt(m, 3));
        }
        // A value may hold `|` or a line break: neither may end the table's row.
        let cells: Vec<String> = cells
            .iter()
            .map(|c| c.replace('|', "\\|").replace(['\r', '\n'], " "))
            .collect();
        let _ = writeln!(md, "| {} |", cells.join(" | "));
    }
    let _ = writeln!(
        md,
        "\nMedian time: completion time by which half of the trials had succeeded (failures censored; – unless more than half did). Path efficiency: {eff_desc}, mean.\n"
    );
    let _ = writeln!(md, "## Figures\n");
    for (f, title) in &figures {
        let _ = writeln!(md, "### {title}\n\n![{title}]({f}.png) ([SVG]({f}.svg))\n");
    }
    // A case's label, and the varied keys it does not decide (cases x [vary]: each set apart).
    let short_label = |r: &StoredTrial| match r.params.get("label").and_then(|v| v.as_str()) {
        Some(l) => std::iter::once(l.to_string())
            .chain(
                plotted
                    .iter()
                    .filter(|k| *k != "label" && r.params.contains_key(*k))
                    .map(|k| format!("{k}={}", value(r, k))),
            )
            .collect::<Vec<_>>()
            .join(", "),
        None => set_label(r),
    };
    // Failed trials always have their section; trials without a success rule only if any.
    for (listed, trials) in [(Listed::Failed, &scored), (Listed::Unjudged, &endings)] {
        if listed == Listed::Unjudged && trials.is_empty() {
            continue;
        }
        md.push_str(&crate::gallery::trials_section(
            listed,
            &a.db,
            trials,
            &sets,
            &short_label,
            dir,
            a.failures,
            a.gallery,
        )?);
    }
    md.push_str(&crate::gallery::provenance_section(
        &store,
        &rows,
        &a.db,
        &a.out,
        &a.options(),
    )?);
    std::fs::write(dir.join("summary.md"), md).context("writing summary.md")?;
    let csv = dir.join("trials.csv");
    let file =
        std::fs::File::create(&csv).with_context(|| format!("creating {}", csv.display()))?;
    crate::cmd_export::write_trials(&store, &mut std::io::BufWriter::new(file))?;
    outln!(
        "wrote {} figures (PNG and SVG), summary.md and trials.csv to {}",
        figures.len(),
        dir.display()
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn r(outcome: Outcome, t: f64) -> RunResult {
        RunResult {
            scenario: "x".into(),
            seed: 1,
            outcome,
            sim_time_s: t,
            ticks: 0,
            robots: 1,
            controller: "c".into(),
            ..RunResult::default()
        }
    }

    /// A stored successful trial with these parameters, run by `controller`.
    fn stored(params: serde_json::Value, controller: &str) -> StoredTrial {
        let params = params.as_object().cloned().unwrap_or_default();
        StoredTrial {
            trial: 0,
            provenance: Default::default(),
            params_json: serde_json::Value::Object(params.clone()).to_string(),
            params,
            result: RunResult {
                controller: controller.into(),
                ..r(Outcome::Success, 1.0)
            },
        }
    }

    #[test]
    fn a_key_some_cases_leave_unset_keeps_their_trials_as_dash() {
        let trial = |params: serde_json::Value| stored(params, "c");
        let key = "robots.0.params.object_reach";
        let rows = [
            trial(serde_json::json!({ key: 0.83 })),
            trial(serde_json::json!({ "label": "fill" })),
            trial(serde_json::json!({ key: 0.62 })),
        ];
        assert_eq!(values_of(&rows, key), ["0.62", "0.83", "-"]);
        assert_eq!(value(&rows[1], key), "-");
        assert_eq!(values_of(&rows[..1], key), ["0.83"]);
    }

    #[test]
    fn an_unset_controller_key_reads_the_controller_the_trial_ran() {
        let key = "robots.0.controller";
        let rows = [
            stored(serde_json::json!({ key: "occlusion" }), "occlusion"),
            stored(serde_json::json!({ "label": "u" }), "fill-transport"),
            stored(serde_json::json!({ "label": "v" }), "occlusion"),
        ];
        assert_eq!(values_of(&rows, key), ["occlusion", "fill-transport"]);
        assert_eq!(value(&rows[1], key), "fill-transport");
        assert_eq!(value(&rows[2], key), "occlusion");
        // Other keys a case leaves unset still read "-".
        assert_eq!(value(&rows[1], "robots.0.count"), "-");
    }

    #[test]
    fn trials_group_by_parameter_set_in_first_seen_order() {
        let rows = [
            stored(serde_json::json!({ "n": 2 }), "c"),
            stored(serde_json::json!({ "n": 1 }), "c"),
            stored(serde_json::json!({ "n": 2 }), "c"),
            stored(serde_json::json!({ "n": 3 }), "c"),
            stored(serde_json::json!({ "n": 1 }), "c"),
        ];
        let g = by_set(&rows);
        let sets: Vec<(&str, usize)> = g.iter().map(|(s, rs)| (*s, rs.len())).collect();
        assert_eq!(
            sets,
            [(r#"{"n":2}"#, 2), (r#"{"n":1}"#, 2), (r#"{"n":3}"#, 1)]
        );
        assert!(std::ptr::eq(g[1].1[1], &rows[4]));
    }

    #[test]
    fn kaplan_meier_censors_timeouts() {
        let rs = [
            r(Outcome::Success, 10.0),
            r(Outcome::Success, 20.0),
            r(Outcome::Timeout, 15.0),
            r(Outcome::Timeout, 30.0),
        ];
        let refs: Vec<&RunResult> = rs.iter().collect();
        let km = kaplan_meier(&refs);
        // 4 at risk at 10 -> 0.75; 2 at risk at 20 (one censored at 15) -> 0.375.
        assert_eq!(km[0], (0.0, 1.0));
        assert!((km[1].1 - 0.75).abs() < 1e-12);
        assert!((km[2].1 - 0.375).abs() < 1e-12);
        assert_eq!(km.last().map(|p| p.0), Some(30.0));
        // Only wall hits: a flat line to the last of them.
        let walls = [r(Outcome::Wall, 12.0), r(Outcome::Wall, 40.0)];
        let refs: Vec<&RunResult> = walls.iter().collect();
        assert_eq!(kaplan_meier(&refs), vec![(0.0, 1.0), (40.0, 1.0)]);
    }
}
