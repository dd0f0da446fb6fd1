//! `formica sweep SWEEP.toml`: run a parameter grid in parallel into a SQLite result store.
//! Resumable: trials already stored are skipped.

use crate::provenance::{sha256_hex, Provenance};
use crate::store::{Row, Store};
use crate::sweep::{parse_shard, Sweep, Trial};
use crate::{stats, CliError};
use anyhow::Context;
use formica::experiment::{Run, RunOptions};
use formica::timeseries::TimeSeries;
use formica::{Outcome, Overrides};
use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;
use std::collections::HashSet;
use std::path::PathBuf;
use std::sync::mpsc;

/// Arguments of `formica sweep`.
#[derive(clap::Args)]
pub struct Args {
    /// Sweep file (TOML): base scenario, `[vary]` keys, seeds.
    pub sweep: PathBuf,
    /// Result store (SQLite; default: the sweep file with `.db` instead of `.toml`).
    #[arg(long)]
    pub db: Option<PathBuf>,
    /// Run only every N-th trial of the grid, starting at K (0-based), e.g. `--shard 2/8`.
    #[arg(long, value_name = "K/N")]
    pub shard: Option<String>,
    /// Worker threads (default: all cores). Results do not depend on it.
    #[arg(long)]
    pub threads: Option<usize>,
    /// Also store each trial's object trajectory (as the sweep's `trajectories = true`).
    #[arg(long)]
    pub trajectories: bool,
    /// Run at most this many of the missing trials, then stop (for testing and benchmarks).
    #[arg(long)]
    pub limit: Option<usize>,
    /// Print the trials that would run, and run none.
    #[arg(long)]
    pub dry_run: bool,
    /// No progress bar.
    #[arg(long, short)]
    pub quiet: bool,
    /// Add trials to a store written by a Formica whose results can differ from this one's
    /// (another results format); every row records the build that wrote it.
    #[arg(long)]
    pub allow_mixed: bool,
}

/// The default store of a sweep file.
pub fn default_db(sweep: &std::path::Path) -> PathBuf {
    sweep.with_extension("db")
}

/// Object samples every this many simulated seconds go to the store.
const TRAJECTORY_EVERY_S: f64 = 1.0;

/// The time series of a trial is sampled every this many simulated seconds.
pub const TIMESERIES_EVERY_S: f64 = 1.0;

/// Steps `run` to its end, feeding `series` (if any) every tick and at the last one.
pub fn run_with_series(run: &mut Run, mut series: Option<&mut TimeSeries>) {
    loop {
        let done = run.step().is_some();
        if let Some(s) = series.as_mut() {
            s.observe(&run.world);
            if done {
                s.sample(&run.world);
            }
        }
        if done {
            return;
        }
    }
}

fn run_trial(
    sweep: &Sweep,
    t: Trial,
    record: bool,
    provenance: &Provenance,
) -> Result<Row, formica::ScenarioError> {
    let set = &sweep.sets[t.set];
    let opts = RunOptions {
        overrides: Overrides {
            seed: Some(t.seed),
            ..Default::default()
        },
        record,
        robot_every: u64::MAX,
        // Sweeps run one world per task.
        threads: 1,
    };
    let mut run = Run::new(&set.scenario, &opts)?;
    let mut series = record.then(|| TimeSeries::new(&run.world, TIMESERIES_EVERY_S, usize::MAX));
    run_with_series(&mut run, series.as_mut());
    let result = run.result();
    let trajectory = run.trajectories().map(|tr| {
        let mut out: Vec<[f64; 4]> = Vec::new();
        let mut next = 0.0;
        let n = tr.object.len();
        for (i, s) in tr.object.iter().enumerate() {
            if s.t + 1e-9 >= next || i + 1 == n {
                out.push([s.t, f64::from(s.x), f64::from(s.y), f64::from(s.theta)]);
                next = s.t + TRAJECTORY_EVERY_S;
            }
        }
        out
    });
    Ok(Row {
        trial: t.index,
        params: set.key.clone(),
        values: sweep
            .keys
            .iter()
            .filter_map(|k| set.params.get(k).map(|v| (k.clone(), v.clone())))
            .collect(),
        result,
        trajectory,
        timeseries: series.map(|s| s.to_json().to_string()),
        provenance: provenance.clone(),
    })
}

/// Runs the command.
pub fn main(a: Args) -> Result<(), CliError> {
    crate::check_threads(a.threads)?;
    let sweep = Sweep::load(&a.sweep)?;
    let shard = a.shard.as_deref().map(parse_shard).transpose()?;
    let db = a.db.clone().unwrap_or_else(|| default_db(&a.sweep));
    let record = a.trajectories || sweep.trajectories;
    let all = sweep.trials();
    let mine: Vec<Trial> = match shard {
        Some((k, n)) => all.iter().copied().filter(|t| t.index % n == k).collect(),
        None => all.clone(),
    };
    // Check every parameter set builds before fanning out (and in a dry run), so errors are
    // reported once.
    for set in &sweep.sets {
        let run = Run::new(
            &set.scenario,
            &RunOptions {
                overrides: Overrides {
                    seed: sweep.seeds.first().copied(),
                    ..Default::default()
                },
                ..Default::default()
            },
        )
        .map_err(|e| CliError::Input(format!("{} (parameter set {})", e, set.key)))?;
        for w in crate::cmd_check::run_warnings(&set.scenario, &run.world) {
            errln!(
                "{}: warning: {w} (parameter set {})",
                set.scenario.file,
                set.key
            );
        }
    }
    // Each parameter set's provenance (the seed is not part of the scenario's digest).
    let provenance: Vec<Provenance> = sweep
        .sets
        .iter()
        .map(|set| Provenance::of(&set.scenario, &Overrides::default()))
        .collect();
    let all_scenarios: Vec<&str> = provenance
        .iter()
        .map(|p| p.scenario_sha256.as_str())
        .collect();
    if a.dry_run {
        // The trials a real run would run: those the store (if there is one) lacks, after the
        // same checks of the store, which is left untouched.
        let stored = if db.exists() {
            Store::open_existing(&db)?.would_bind(
                &sweep,
                &db,
                &sha256_hex(all_scenarios.join("\n").as_bytes()),
                a.allow_mixed,
            )?
        } else {
            HashSet::new()
        };
        let mut to_run = 0;
        for t in &mine {
            if stored.contains(&(sweep.sets[t.set].key.clone(), t.seed)) {
                continue;
            }
            to_run += 1;
            if a.limit.is_some_and(|l| to_run > l) {
                continue;
            }
            outln!(
                "trial {} seed {} {}",
                t.index,
                t.seed,
                sweep.sets[t.set].key
            );
        }
        let limited = a.limit.map_or(to_run, |l| to_run.min(l));
        outln!(
            "{}: {} parameter sets x {} seeds = {} trials, {} in this shard, {} already in {}, {} to run{}",
            sweep.name,
            sweep.sets.len(),
            sweep.seeds.len(),
            all.len(),
            mine.len(),
            mine.len() - to_run,
            db.display(),
            limited,
            if limited < to_run {
                format!(" (--limit {}; {to_run} missing)", a.limit.unwrap_or(0))
            } else {
                String::new()
            }
        );
        return Ok(());
    }
    let mut store = Store::open(&db)?;
    store.bind(
        &sweep,
        &db,
        &sha256_hex(all_scenarios.join("\n").as_bytes()),
        a.allow_mixed,
    )?;
    for (set, p) in sweep.sets.iter().zip(&provenance) {
        store.add_scenario(&p.scenario_sha256, &set.scenario.file, set.scenario.text())?;
    }
    let done = store.done()?;
    if !done.is_empty() {
        let mut index: Vec<(&str, u64, usize)> = all
            .iter()
            .filter(|t| done.contains(&(sweep.sets[t.set].key.clone(), t.seed)))
            .map(|t| (sweep.sets[t.set].key.as_str(), t.seed, t.index))
            .collect();
        // Stored trials the grid no longer has (a varied value changed or dropped, seeds
        // cut): they keep their rows, numbered after the grid so that no two trials share a
        // number, in an order every machine agrees on.
        let in_grid: HashSet<(&str, u64)> = index.iter().map(|(p, s, _)| (*p, *s)).collect();
        let mut orphans: Vec<&(String, u64)> = done
            .iter()
            .filter(|(p, s)| !in_grid.contains(&(p.as_str(), *s)))
            .collect();
        orphans.sort();
        if !orphans.is_empty() {
            errln!(
                "{}: warning: {} stored trial(s) belong to parameter sets or seeds this sweep file no longer has; they stay in {}, numbered from {} on",
                sweep.name,
                orphans.len(),
                db.display(),
                all.len()
            );
        }
        index.extend(
            orphans
                .iter()
                .enumerate()
                .map(|(k, (p, s))| (p.as_str(), *s, all.len() + k)),
        );
        store.reindex(&index)?;
    }
    let mut todo: Vec<Trial> = mine
        .iter()
        .copied()
        .filter(|t| !done.contains(&(sweep.sets[t.set].key.clone(), t.seed)))
        .collect();
    let skipped = mine.len() - todo.len();
    if let Some(l) = a.limit {
        todo.truncate(l);
    }
    let bar = if a.quiet {
        ProgressBar::hidden()
    } else {
        ProgressBar::new(todo.len() as u64)
    };
    bar.set_style(
        ProgressStyle::with_template(
            "{elapsed_precise} [{bar:30}] {pos}/{len} trials, ETA {eta} {msg}",
        )
        .context("progress bar template")?
        .progress_chars("=> "),
    );
    if skipped > 0 && !a.quiet {
        let missing = mine.len() - skipped;
        errln!(
            "{}: {skipped} of {} trials already in {}, running {}",
            sweep.name,
            mine.len(),
            db.display(),
            if todo.len() < missing {
                format!("{} of the other {missing} (--limit)", todo.len())
            } else {
                format!("the other {missing}")
            }
        );
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(a.threads.unwrap_or(0))
        .build()
        .context("starting worker threads")?;
    // Sets whose scenario has no success rule (static filling) count apart from the rate.
    let judged: Vec<bool> = sweep
        .sets
        .iter()
        .map(|s| s.scenario.has_success_rule())
        .collect();
    let (tx, rx) = mpsc::channel::<(Row, bool)>();
    // The single writer: one transaction per finished trial.
    let writer_bar = bar.clone();
    let writer = std::thread::spawn(move || -> Result<(usize, usize, usize), CliError> {
        let (mut n, mut ok, mut unjudged) = (0usize, 0usize, 0usize);
        for (row, judged) in rx {
            store.insert(&row)?;
            n += 1;
            if !judged {
                unjudged += 1;
            } else if row.result.outcome == Outcome::Success {
                ok += 1;
            }
            writer_bar.inc(1);
            if n > unjudged {
                writer_bar.set_message(format!(
                    "success {:.0} %",
                    100.0 * ok as f64 / (n - unjudged) as f64
                ));
            }
        }
        Ok((n, ok, unjudged))
    });
    let failures: Vec<String> = pool.install(|| {
        todo.par_iter()
            .with_max_len(1)
            .filter_map(|&t| {
                if crate::stop_requested() {
                    return None;
                }
                match crate::caught(|| run_trial(&sweep, t, record, &provenance[t.set])) {
                    Ok(row) => tx
                        .send((row, judged[t.set]))
                        .err()
                        .map(|_| "the result writer stopped".to_string()),
                    Err(e) => Some(format!("trial {} (seed {}): {e}", t.index, t.seed)),
                }
            })
            .collect()
    });
    drop(tx);
    let written = writer.join().map_err(|payload| {
        // Its message too: while trials run, the panic hook leaves the reporting to us.
        let message = formica::world::panic_message(payload.as_ref()).unwrap_or_default();
        CliError::Other(anyhow::anyhow!("the result writer panicked: {message}"))
    })?;
    let (n, ok, unjudged) = written?;
    bar.finish_and_clear();
    if let Some(f) = failures.first() {
        return Err(CliError::Other(anyhow::anyhow!(
            "{} trial(s) failed; first: {f}",
            failures.len()
        )));
    }
    let store = Store::open(&db)?;
    let total = store.count()?;
    if crate::stop_requested() {
        return Err(CliError::Interrupted(format!(
            "{}: interrupted after {n} trials; {} holds {total} of {} trials (run the same \
             command again to run the rest)",
            sweep.name,
            db.display(),
            all.len()
        )));
    }
    let scored = n - unjudged;
    let [lo, hi] = stats::wilson95(ok, scored);
    let missing = mine.len() - skipped;
    let outcome = match (scored, unjudged) {
        (0, 0) if missing > 0 => {
            format!("--limit {}: {missing} still to run", a.limit.unwrap_or(0))
        }
        (0, 0) => "none to run".to_string(),
        (0, _) => "none has a success rule: static filling, judged by its metrics".to_string(),
        (_, u) => format!(
            "{ok} successes{}, {:.1} %, 95 % CI {:.1}-{:.1} %{}",
            if u > 0 {
                format!(" of {scored}")
            } else {
                String::new()
            },
            100.0 * ok as f64 / scored as f64,
            100.0 * lo,
            100.0 * hi,
            if u > 0 {
                format!("; {u} with no success rule beside them")
            } else {
                String::new()
            }
        ),
    };
    // Trials of an earlier grid that this one no longer has stay in the store (numbered after
    // the grid): say so rather than "holds 16 of 8".
    let in_grid = all
        .iter()
        .filter(|t| done.contains(&(sweep.sets[t.set].key.clone(), t.seed)))
        .count()
        + n;
    let held = if total > in_grid {
        format!(
            "{in_grid} of the grid's {} trials, and {} of an earlier grid",
            all.len(),
            total - in_grid
        )
    } else {
        format!("{total} of {} trials", all.len())
    };
    outln!(
        "{}: ran {n} trials ({outcome}), skipped {skipped} already stored; {} holds {held}",
        sweep.name,
        db.display(),
    );
    Ok(())
}
