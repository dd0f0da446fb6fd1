//! `formica run SCENARIO`: run one seed, or a range of seeds in parallel; or, with
//! `--db STUDY.db --trial N`, replay stored trials and check that they end as stored.

use crate::provenance::{Provenance, Stamped};
use crate::replay::{self, Replay, Replayer};
use crate::{output, stats, CliError};
use anyhow::Context;
use formica::experiment::{Run, RunOptions};
use formica::{Overrides, RunResult, Scenario};
use rayon::prelude::*;
use std::path::PathBuf;

/// Arguments of `formica run`.
#[derive(clap::Args)]
pub struct Args {
    /// Scenario file (TOML).
    #[arg(required_unless_present = "db")]
    pub scenario: Option<PathBuf>,
    /// Seed (default: the file's `run.seed`).
    #[arg(long, conflicts_with = "seeds")]
    pub seed: Option<u64>,
    /// Run seeds A to B inclusive in parallel, e.g. `--seeds 1..100`.
    #[arg(long, value_name = "A..B", allow_hyphen_values = true)]
    pub seeds: Option<String>,
    /// Simulated time limit in seconds (default: the file's `run.duration_s`).
    #[arg(long)]
    pub duration: Option<f32>,
    /// Use this controller for every robot group (the file's `params` are kept: where they
    /// are another controller's, set them with `--set 'robots.0.params={...}'`).
    #[arg(long)]
    pub controller: Option<String>,
    /// Override any scenario key, as sweep files do: `--set robots.0.count=10`,
    /// `--set 'robots.0.params.perception="camera"'` (the value is TOML; a bare word is taken
    /// as a string). Repeatable.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    /// Write trajectories (CSV), the result (JSON) and a picture (PNG) into this folder.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Print JSON lines instead of text.
    #[arg(long)]
    pub json: bool,
    /// Worker threads (default: all cores): one trial each with `--seeds`, else the sensing
    /// and control of one large swarm (400 robots or more). Results do not depend on it.
    #[arg(long)]
    pub threads: Option<usize>,
    /// Run even if the physics step is too coarse for contacts to hold (see `formica check`).
    #[arg(long)]
    pub force: bool,
    /// Replay trials of this result store (see `--trial`) instead of running a scenario file.
    #[arg(long, value_name = "STUDY.db", requires = "trial",
          conflicts_with_all = ["scenario", "seed", "seeds", "duration", "controller", "set"])]
    pub db: Option<PathBuf>,
    /// With `--db`: which trial to replay (its number, as `formica report` lists it), `A..B`
    /// or `all`. Each replay must end exactly as stored (exit 1 otherwise).
    #[arg(long, requires = "db", value_name = "N|A..B|all")]
    pub trial: Option<String>,
}

/// Parses a seed range `A..B` (inclusive; `A..=B` and one seed `N` also accepted) of at most
/// [`MAX_TRIALS`](formica::limits::MAX_TRIALS) seeds, each at most
/// [`MAX_SEED`](formica::limits::MAX_SEED); the error says what was expected.
pub fn seed_range(s: &str) -> Result<std::ops::RangeInclusive<u64>, String> {
    use formica::limits::{MAX_SEED, MAX_TRIALS};
    let expected =
        || format!("expected A..B with 0 <= A <= B <= {MAX_SEED}, or one seed N, got `{s}`");
    // One seed `N` is the range `N..N`.
    let (a, b) = s.split_once("..").unwrap_or((s, s));
    let a: u64 = a.trim().parse().map_err(|_| expected())?;
    let b: u64 = b
        .trim()
        .trim_start_matches('=')
        .trim()
        .parse()
        .map_err(|_| expected())?;
    if a > b || b > MAX_SEED {
        return Err(expected());
    }
    if b - a >= MAX_TRIALS {
        return Err(format!(
            "`{s}` is {} seeds; at most {MAX_TRIALS} trials a call (split the range)",
            (b - a).saturating_add(1)
        ));
    }
    Ok(a..=b)
}

/// Parses `--seeds A..B`.
pub fn parse_seeds(s: &str) -> Result<std::ops::RangeInclusive<u64>, CliError> {
    let seeds = seed_range(s).map_err(|m| CliError::Input(format!("--seeds: {m}")))?;
    let max = formica::limits::MAX_RUN_SEEDS;
    if seeds.end() - seeds.start() >= max {
        return Err(CliError::Input(format!(
            "--seeds: `{s}` is {} seeds; formica run keeps every result for its summary, at \
             most {max} (a sweep file stores each trial as it ends, resumes, and \
             takes up to {} trials)",
            (seeds.end() - seeds.start()).saturating_add(1),
            formica::limits::MAX_TRIALS
        )));
    }
    Ok(seeds)
}

/// One `--set KEY=VALUE`: the value is TOML (`10`, `[1.0, 2.0]`, `"camera"`, `{ a = 1 }`); a
/// bare word that TOML does not take (`camera`) is the string it spells. Anything else that is
/// not TOML (a number out of range, an unclosed list, a line break) is an error naming it.
pub fn parse_set(item: &str) -> Result<(String, toml::Value), CliError> {
    let (key, value) = item
        .split_once('=')
        .ok_or_else(|| CliError::Input(format!("--set: expected KEY=VALUE, got `{item}`")))?;
    if item.contains(['\n', '\r']) {
        return Err(CliError::Input(format!(
            "--set `{}`: one KEY=VALUE per --set, without line breaks",
            item.escape_debug()
        )));
    }
    let (key, value) = (key.trim(), value.trim());
    if key.is_empty() {
        return Err(CliError::Input(format!(
            "--set: expected KEY=VALUE, got `{item}` (no key)"
        )));
    }
    let parsed = toml::from_str::<toml::Table>(&format!("v = {value}"))
        .map_err(|e| e.message().to_string())
        .and_then(|mut t| t.remove("v").ok_or_else(String::new));
    match parsed {
        Ok(v) => Ok((key.to_string(), v)),
        Err(_) if is_bare_word(value) => {
            Ok((key.to_string(), toml::Value::String(value.to_string())))
        }
        Err(_) if value.trim_start_matches(['-', '+']).parse::<u128>().is_ok() => {
            Err(CliError::Input(format!(
                "--set {key}={value}: number out of range (whole numbers are 64-bit, up to \
                 {})",
                i64::MAX
            )))
        }
        Err(e) => Err(CliError::Input(format!(
            "--set {key}={value}: not a TOML value ({}); quote a string as '{key}=\"...\"'",
            if e.is_empty() {
                "nothing given"
            } else {
                e.trim()
            }
        ))),
    }
}

/// Whether `v` reads as a word meant as a string: letters, digits, `-`, `_`, `.`, `/` and
/// `:`, starting with a letter (so that a malformed number, list or table is not taken for
/// one).
fn is_bare_word(v: &str) -> bool {
    v.starts_with(|c: char| c.is_alphabetic())
        && v.chars()
            .all(|c| c.is_alphanumeric() || matches!(c, '-' | '_' | '.' | '/' | ':'))
}

/// Loads the scenario with the `--set` overrides applied. A sweep file or a result store
/// given instead gets an error that says so and names the command that takes it.
pub fn load(path: &std::path::Path, set: &[String]) -> Result<Scenario, CliError> {
    load_scenario(path, set).map_err(|e| match crate::not_a_scenario_hint(path) {
        Some(hint) => CliError::Input(hint),
        None => e,
    })
}

/// [`load`], with every robot group's controller replaced by `controller` (its params kept),
/// as `run --controller` does it: for commands that build their world from the file alone
/// (`check`, `serve`).
pub(crate) fn load_with_controller(
    path: &std::path::Path,
    set: &[String],
    controller: Option<&str>,
) -> Result<Scenario, CliError> {
    crate::check_controller(controller)?;
    let sc = load(path, set)?;
    let Some(c) = controller else {
        return Ok(sc);
    };
    let name = toml::Value::String(c.to_string());
    let mut sets = set.to_vec();
    sets.extend((0..sc.spec.robots.len()).map(|g| format!("robots.{g}.controller={name}")));
    load(path, &sets)
}

fn load_scenario(path: &std::path::Path, set: &[String]) -> Result<Scenario, CliError> {
    if set.is_empty() {
        return Ok(Scenario::load(path)?);
    }
    let file = path.display().to_string();
    let text = formica::limits::read_text(path)
        .map_err(|e| CliError::from(formica::limits::read_error(&file, &e)))?;
    let mut overrides = Vec::with_capacity(set.len());
    for item in set {
        let (key, value) = parse_set(item)?;
        overrides.push((key, value));
    }
    let origin = set.join("\n");
    Ok(Scenario::parse_with_overrides(
        &text,
        &file,
        &overrides,
        ("--set", &origin),
    )?)
}

fn overrides(a: &Args, seed: Option<u64>) -> Overrides {
    Overrides {
        seed,
        duration_s: a.duration,
        controller: a.controller.clone(),
    }
}

fn describe(r: &RunResult) -> String {
    let gd = r
        .goal_distance_m
        .map_or(String::new(), |d| format!(", goal distance {d:.3} m"));
    let fill = match (r.object_robots, r.convexity_after) {
        (Some(n), Some(c)) => format!(", {n} robots attached, convexity {c:.3}"),
        _ => String::new(),
    };
    let extra: String = r.extra.iter().map(|(k, v)| format!(", {k} {v}")).collect();
    let path = match (r.object_path_m, r.path_efficiency) {
        (Some(p), Some(e)) => format!(", object path {p:.3} m, path efficiency {e:.3}"),
        _ => String::new(),
    };
    format!(
        "{} seed {}: {} after {:.1} s ({} ticks, {} robots){gd}{path}{fill}{extra}, {:.2} s wall time",
        r.scenario,
        r.seed,
        r.outcome.name(),
        r.sim_time_s,
        r.ticks,
        r.robots,
        r.wall_time_s
    )
}

/// Runs the command.
pub fn main(a: Args) -> Result<(), CliError> {
    crate::check_threads(a.threads)?;
    if let Some(dir) = a.out.as_deref().filter(|d| d.is_file()) {
        return Err(CliError::Input(format!(
            "--out {}: a file, not a folder (the run writes its CSV files and picture into a folder)",
            dir.display()
        )));
    }
    if let Some(db) = &a.db {
        return replay_trials(&a, db);
    }
    if a.trial.is_some() {
        return Err(CliError::Input(
            "--trial replays a stored trial: it needs --db STUDY.db (and no scenario file)".into(),
        ));
    }
    let Some(path) = &a.scenario else {
        return Err(CliError::Input(
            "expected a scenario file, or --db STUDY.db --trial N".into(),
        ));
    };
    let sc = load(path, &a.set)?;
    crate::check_controller(a.controller.as_deref())?;
    if let (Some(w), false) = (sc.physics_warning(), a.force) {
        // At the key that sets the step: the sub-steps if the file fixes them, else the rate.
        let key = match sc.spec.run.substeps {
            formica::scenario::Substeps::Fixed(_) => "run.substeps",
            formica::scenario::Substeps::Auto => "run.tick_hz",
        };
        return Err(sc
            .error_at_key(key, format!("{w}; --force runs it anyway"))
            .into());
    }
    crate::check_duration(a.duration)?;
    crate::check_seed(a.seed)?;
    // Warnings about the controllers that will run (`--controller`'s, not the file's), as
    // `check` with the same arguments gives them.
    let with_controller;
    let warned = match a.controller.as_deref() {
        Some(c) => {
            with_controller = load_with_controller(path, &a.set, Some(c))?;
            &with_controller
        }
        None => &sc,
    };
    for w in crate::cmd_check::warnings_before_run(warned) {
        errln!("{}: warning: {w}", sc.file);
    }
    match &a.seeds {
        Some(s) => run_many(&a, &sc, parse_seeds(s)?),
        None => crate::caught(|| run_one(&a, &sc, &overrides(&a, a.seed), None)),
    }
}

/// The JSON line of a result with its provenance.
fn json_line(r: &RunResult, p: &Provenance) -> Result<String, CliError> {
    Ok(serde_json::to_string(&Stamped {
        result: r,
        provenance: p,
    })
    .context("encoding JSON")?)
}

/// `e`, a failure of one trial among several, prefixed with which (`seed 3`).
fn in_trial(e: CliError, which: &str) -> CliError {
    match e {
        CliError::Other(e) => CliError::Other(anyhow::anyhow!("{which}: {e:#}")),
        e => e,
    }
}

/// Time series of `formica run --out` are sampled this often (simulated seconds).
const TIMESERIES_EVERY_S: f64 = 0.5;

fn run_one(
    a: &Args,
    sc: &Scenario,
    ov: &Overrides,
    replay: Option<&Replay>,
) -> Result<(), CliError> {
    let opts = RunOptions {
        overrides: ov.clone(),
        record: a.out.is_some(),
        robot_every: 1,
        // One world: large swarms sense and control on every core (same results).
        threads: formica::world::threads_for(
            sc.robot_count(),
            a.threads.unwrap_or_else(crate::available_threads),
        ),
    };
    let provenance = Provenance::of(sc, ov);
    let mut run = Run::new(sc, &opts)?;
    let mut series = a
        .out
        .is_some()
        .then(|| formica::timeseries::TimeSeries::new(&run.world, TIMESERIES_EVERY_S, usize::MAX));
    crate::cmd_sweep::run_with_series(&mut run, series.as_mut());
    let result = run.result();
    if a.json {
        outln!("{}", json_line(&result, &provenance)?);
    } else {
        outln!("{}", describe(&result));
    }
    let check = replay.map(|r| (r, r.differences(&result)));
    if let Some((r, diffs)) = &check {
        let line = if diffs.is_empty() {
            format!(
                "replay of trial {} (seed {}) ends as stored: {}{}",
                r.trial,
                r.seed,
                r.stored_outcome(),
                r.not_compared(&result)
            )
        } else {
            format!(
                "replay of trial {} (seed {}) does NOT end as stored ({}): {}",
                r.trial,
                r.seed,
                r.stored_outcome(),
                diffs.join("; ")
            )
        };
        if a.json {
            errln!("{line}");
        } else {
            outln!("{line}");
        }
    }
    if let Some(dir) = &a.out {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
        if let Some(tr) = run.trajectories() {
            output::write_trajectories(dir, tr)?;
            let path: Vec<_> = tr
                .object
                .iter()
                .map(|s| formica::geometry::Vec2::new(s.x, s.y))
                .collect();
            let overlay = formica_render::Overlay {
                path: &path,
                goal_radius: run.goal_radius(),
            };
            formica_render::save_png(&run.world, 900, &overlay, &dir.join("final.png"))
                .map_err(anyhow::Error::msg)?;
        }
        if let Some(s) = &series {
            std::fs::write(dir.join("timeseries.csv"), s.to_csv())
                .with_context(|| format!("writing {}", dir.join("timeseries.csv").display()))?;
        }
        let json = serde_json::to_string_pretty(&Stamped {
            result: &result,
            provenance: &provenance,
        })
        .context("encoding JSON")?;
        std::fs::write(dir.join("result.json"), json + "\n")
            .with_context(|| format!("writing {}", dir.join("result.json").display()))?;
        if !a.json {
            outln!(
                "wrote {}/{{object.csv, robots.csv, timeseries.csv, result.json, final.png}}",
                dir.display()
            );
        }
    }
    match check {
        Some((r, diffs)) if !diffs.is_empty() => Err(CliError::Other(anyhow::anyhow!(
            "the replay of trial {} differs from the store",
            r.trial
        ))),
        _ => Ok(()),
    }
}

/// `--db STUDY.db --trial N|A..B|all`: replays, each checked against the store.
fn replay_trials(a: &Args, db: &std::path::Path) -> Result<(), CliError> {
    let mut replayer = Replayer::open(db)?;
    let which = replay::parse_trials(a.trial.as_deref().unwrap_or("all"))?;
    if let Some(range) = &which {
        if range.start() == range.end() {
            let r = replayer.trial(*range.start())?;
            return crate::caught(|| run_one(a, &r.scenario, &r.overrides(), Some(&r)));
        }
    }
    if a.out.is_some() {
        return Err(CliError::Input(
            "--out: give one --trial N to write its files".into(),
        ));
    }
    let numbers: Vec<usize> = replayer
        .trial_numbers()?
        .into_iter()
        .filter(|n| which.as_ref().is_none_or(|r| r.contains(n)))
        .collect();
    if numbers.is_empty() {
        return Err(CliError::Input(format!(
            "--trial: {} holds no trials in that range",
            replay::store_name(db)
        )));
    }
    let replays: Vec<Replay> = numbers
        .iter()
        .map(|&n| replayer.trial(n))
        .collect::<Result<_, _>>()?;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(a.threads.unwrap_or(0))
        .build()
        .context("starting worker threads")?;
    let results: Vec<Result<RunResult, CliError>> = pool.install(|| {
        replays
            .par_iter()
            .with_max_len(1)
            .map(|r| {
                let opts = RunOptions {
                    overrides: r.overrides(),
                    ..Default::default()
                };
                crate::caught(|| formica::run(&r.scenario, &opts).map(|(res, _)| res))
                    .map_err(|e| in_trial(e, &format!("trial {}", r.trial)))
            })
            .collect()
    });
    let mut differ = 0usize;
    for (r, res) in replays.iter().zip(results) {
        let res = res?;
        let diffs = r.differences(&res);
        if a.json {
            outln!("{}", json_line(&res, &replay::provenance_of(r))?);
        }
        let line = if diffs.is_empty() {
            format!(
                "trial {} (seed {}): ends as stored, {}{}",
                r.trial,
                r.seed,
                r.stored_outcome(),
                r.not_compared(&res)
            )
        } else {
            differ += 1;
            format!(
                "trial {} (seed {}): DIFFERS from the store: {}",
                r.trial,
                r.seed,
                diffs.join("; ")
            )
        };
        if a.json {
            errln!("{line}");
        } else {
            outln!("{line}");
        }
    }
    let summary = format!(
        "{}: replayed {} trials, {} end as stored, {differ} differ",
        replay::store_name(db),
        replays.len(),
        replays.len() - differ
    );
    if a.json {
        errln!("{summary}");
    } else {
        outln!("{summary}");
    }
    if differ > 0 {
        return Err(CliError::Other(anyhow::anyhow!(
            "{differ} of {} replays differ from the store",
            replays.len()
        )));
    }
    Ok(())
}

fn run_many(a: &Args, sc: &Scenario, seeds: std::ops::RangeInclusive<u64>) -> Result<(), CliError> {
    // Check the scenario builds before fanning out, so errors are reported once.
    Run::new(
        sc,
        &RunOptions {
            overrides: overrides(a, Some(*seeds.start())),
            ..Default::default()
        },
    )?;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(a.threads.unwrap_or(0))
        .build()
        .context("starting worker threads")?;
    let provenance = Provenance::of(sc, &overrides(a, None));
    // Seeds run in chunks of a few per thread, each chunk's lines printed in seed order as
    // soon as it is done: a long call shows its trials as they end, not all at the close.
    let chunk = (8 * pool.current_num_threads()).max(64);
    let all: Vec<u64> = seeds.clone().collect();
    let mut results: Vec<RunResult> = Vec::with_capacity(all.len());
    for part in all.chunks(chunk) {
        let done: Vec<Result<RunResult, CliError>> = pool.install(|| {
            part.par_iter()
                .map(|&seed| {
                    let opts = RunOptions {
                        overrides: overrides(a, Some(seed)),
                        ..Default::default()
                    };
                    crate::caught(|| formica::run(sc, &opts).map(|(r, _)| r))
                        .map_err(|e| in_trial(e, &format!("seed {seed}")))
                })
                .collect()
        });
        for r in done {
            let r = r?;
            if a.json {
                outln!("{}", json_line(&r, &provenance)?);
            } else {
                outln!("{}", describe(&r));
            }
            results.push(r);
        }
    }
    let summary = stats::summarize(&sc.name, &results, sc.has_success_rule());
    if a.json {
        outln!(
            "{}",
            serde_json::to_string(&summary).context("encoding JSON")?
        );
    } else if let (Some(rate), Some([lo, hi])) = (summary.success_rate, summary.success_ci95) {
        outln!(
            "{}: {} trials, success {:.1} % (95 % CI {:.1}-{:.1} %), median time {}, mean path efficiency {}",
            summary.scenario,
            summary.trials,
            100.0 * rate,
            100.0 * lo,
            100.0 * hi,
            summary.median_time_s.map_or("n/a (half or fewer succeeded)".into(), |t| format!("{t:.1} s")),
            summary.mean_path_efficiency.map_or("n/a (none succeeded)".into(), |e| format!("{e:.3} (successes)"))
        );
    } else {
        outln!("{}", unjudged_summary(&sc.name, &results));
    }
    if let Some(dir) = &a.out {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
        let mut lines = String::new();
        for r in &results {
            lines += &(json_line(r, &provenance)? + "\n");
        }
        std::fs::write(dir.join("results.jsonl"), lines).context("writing results.jsonl")?;
        std::fs::write(
            dir.join("summary.json"),
            serde_json::to_string_pretty(&summary).context("encoding JSON")? + "\n",
        )
        .context("writing summary.json")?;
    }
    Ok(())
}

/// The closing line of `formica run --seeds` for a scenario with no success rule (static
/// filling): its filling figures instead of a success rate that could only read 0 %.
fn unjudged_summary(name: &str, results: &[RunResult]) -> String {
    let mean = |f: &dyn Fn(&RunResult) -> Option<f64>| stats::mean_of(results, f);
    let mut line = format!(
        "{name}: {} trials; no success rule (no goal to reach and no stop.on_filled), so no success rate",
        results.len()
    );
    if let Some(a) = mean(&|r| r.object_robots.map(|n| n as f64)) {
        line += &format!("; robots attached {a:.1} on average");
    }
    let robots = mean(&|r| r.cavity_robots.map(|n| n as f64));
    let capacity = mean(&|r| r.cavity_capacity.map(|n| n as f64));
    if let (Some(n), Some(c)) = (robots, capacity) {
        line += &format!(", in the cavity {n:.1} of a capacity of {c:.0}");
    }
    let judged = results.iter().filter(|r| r.false_stops.is_some()).count();
    if judged > 0 {
        let clean = results.iter().filter(|r| r.false_stops == Some(0)).count();
        line += &format!(", runs without false stops {clean} of {judged}");
    }
    line
}
