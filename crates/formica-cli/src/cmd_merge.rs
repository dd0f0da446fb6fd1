//! `formica merge OUT.db IN1.db IN2.db ...`: merge shard result stores into one.
//!
//! With `--sweep FILE`, the inputs may be stores of other sweep files (slices of FILE's grid,
//! say, that fix one of its varied keys in `[set]`): a stored trial is taken in under FILE's
//! parameter set when it ran the same scenario (its `scenario_sha256`, the canonical scenario
//! after every override) with one of FILE's seeds, which makes it the trial FILE would run.

use crate::provenance::{sha256_hex, Provenance, Writer};
use crate::store::{columns_of, ident, sql_of, Store};
use crate::sweep::Sweep;
use crate::CliError;
use anyhow::Context;
use formica::Overrides;
use rusqlite::types::Value as SqlValue;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// Arguments of `formica merge`.
#[derive(clap::Args)]
pub struct Args {
    /// Store to write (created if missing; trials already in it are kept).
    pub out: PathBuf,
    /// Stores to merge in (e.g. the shards of one sweep).
    #[arg(required = true)]
    pub inputs: Vec<PathBuf>,
    /// Merge stores written by Formica builds whose results can differ (another results
    /// format), as `formica sweep --allow-mixed` would.
    #[arg(long)]
    pub allow_mixed: bool,
    /// Sweep file whose store OUT is: take in every trial of the inputs that ran one of its
    /// parameter sets' scenarios with one of its seeds (the inputs may come from other sweep
    /// files, e.g. slices of this one), under its parameter sets; skip the rest.
    #[arg(long, value_name = "SWEEP.toml")]
    pub sweep: Option<PathBuf>,
}

/// Runs the command.
pub fn main(a: Args) -> Result<(), CliError> {
    for p in &a.inputs {
        if !p.is_file() {
            return Err(CliError::Input(crate::store::not_a_store(p)));
        }
        if p.canonicalize().ok() == a.out.canonicalize().ok() {
            return Err(CliError::Input(format!(
                "{}: cannot merge a store into itself",
                p.display()
            )));
        }
    }
    // Every input must open as a result store before the output is created (a text file given
    // as an input left an empty output store behind).
    for p in &a.inputs {
        Store::open_existing(p)?;
    }
    if let Some(file) = &a.sweep {
        return into_sweep(&a, file);
    }
    let mut store = Store::open(&a.out)?;
    // Check every input before changing anything: all must hold the same sweep.
    let mut digest = store.meta("digest")?;
    let mut first = a.out.display().to_string();
    for p in &a.inputs {
        let theirs = Store::open_existing(p)?.meta("digest")?;
        match (&digest, theirs) {
            (Some(mine), Some(theirs)) if *mine != theirs => {
                return Err(CliError::Input(format!(
                    "{}: holds a different sweep than {first} (their base scenarios or fixed settings differ); nothing merged",
                    p.display()
                )))
            }
            (None, Some(theirs)) => {
                digest = Some(theirs);
                first = p.display().to_string();
            }
            _ => {}
        }
    }
    let writers = writers_of(&store, &a)?;
    let before = store.count()?;
    for p in &a.inputs {
        let src = Store::open_existing(p)?;
        let mut keys = src.keys()?;
        drop(src);
        attached(&mut store, p, |store| {
            if store.meta("digest")?.is_none() {
                store
                    .conn
                    .execute(
                        "INSERT OR IGNORE INTO main.meta (key, value) SELECT key, value FROM src.meta",
                        [],
                    )
                    .context("copying meta")?;
            }
            let mut all = store.keys()?;
            for k in keys.drain(..) {
                if !all.contains(&k) {
                    all.push(k);
                }
            }
            store.set_meta(
                "keys",
                &serde_json::to_string(&all).context("encoding keys")?,
            )?;
            let theirs = columns_of(&store.conn, "src")?;
            store.ensure_columns(&theirs)?;
            let cols: Vec<String> = theirs.iter().map(|c| ident(c)).collect();
            let cols = cols.join(", ");
            // A trial stored already with another result is kept as it was: say so.
            let differing: i64 = store
                .conn
                .query_row(
                    &format!(
                        "SELECT COUNT(*) FROM src.trials s JOIN main.trials m
                         ON s.params = m.params AND s.seed = m.seed WHERE {DIFFERENT}"
                    ),
                    [],
                    |r| r.get(0),
                )
                .with_context(|| format!("comparing {} with the merged trials", p.display()))?;
            warn_differing(p, differing as usize);
            store
                .conn
                .execute_batch(&format!(
                    "BEGIN;
                     INSERT OR IGNORE INTO main.trials ({cols}) SELECT {cols} FROM src.trials;
                     INSERT OR IGNORE INTO main.trajectories (params, seed, samples)
                         SELECT params, seed, samples FROM src.trajectories;
                     INSERT OR IGNORE INTO main.timeseries (params, seed, series)
                         SELECT params, seed, series FROM src.timeseries;
                     INSERT OR IGNORE INTO main.scenarios (sha256, file, toml)
                         SELECT sha256, file, toml FROM src.scenarios;
                     COMMIT;"
                ))
                .with_context(|| format!("merging {}", p.display()))?;
            Ok(())
        })?;
    }
    if !writers.is_empty() {
        store.set_writers(&writers)?;
    }
    let moved = separate_shared_numbers(&mut store)?;
    if moved > 0 {
        errln!(
            "{}: warning: {moved} trial(s) shared a number with another (trials a sweep file's \
             grid no longer had, numbered after it in each store); they are numbered after the \
             highest",
            a.out.display()
        );
    }
    let after = store.count()?;
    outln!(
        "{}: {after} trials ({} new from {} store(s))",
        a.out.display(),
        after - before,
        a.inputs.len()
    );
    Ok(())
}

/// SQL condition: stored trials `s` and `m` of one trial (parameters and seed) hold different
/// results.
const DIFFERENT: &str = "(s.outcome IS NOT m.outcome OR s.sim_time_s IS NOT m.sim_time_s
    OR s.goal_distance_m IS NOT m.goal_distance_m OR s.object_path_m IS NOT m.object_path_m)";

/// Warns that `n` trials of input `p` were merged already with another result (kept).
fn warn_differing(p: &Path, n: usize) {
    if n > 0 {
        errln!(
            "{}: warning: {n} trial(s) are already merged with another result (same parameters \
             and seed; another build or results format?); the one merged first is kept",
            p.display()
        );
    }
}

/// Gives every trial that shares its number with another (ordered by parameter set and seed,
/// the first keeping it) a number after the highest, so that `--trial N` names one trial.
/// Returns how many moved.
fn separate_shared_numbers(store: &mut Store) -> Result<usize, CliError> {
    let rows: Vec<(i64, String, i64)> = {
        let mut st = store
            .conn
            .prepare(
                "SELECT trial, params, seed FROM trials WHERE trial IN \
                 (SELECT trial FROM trials GROUP BY trial HAVING COUNT(*) > 1) \
                 ORDER BY trial, params, seed",
            )
            .context("reading trial numbers")?;
        let rows = st
            .query_map([], |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?)))
            .context("reading trial numbers")?;
        rows.collect::<Result<_, _>>()
            .context("reading trial numbers")?
    };
    let next: i64 = store
        .conn
        .query_row("SELECT COALESCE(MAX(trial), -1) + 1 FROM trials", [], |r| {
            r.get(0)
        })
        .context("reading trial numbers")?;
    // Every row after the first of its number moves.
    let mut moved: Vec<(&str, u64)> = rows
        .windows(2)
        .filter(|w| w[0].0 == w[1].0)
        .map(|w| (w[1].1.as_str(), w[1].2 as u64))
        .collect();
    moved.sort();
    let index: Vec<(&str, u64, usize)> = moved
        .iter()
        .enumerate()
        .map(|(k, &(params, seed))| (params, seed, next as usize + k))
        .collect();
    store.reindex(&index)?;
    Ok(moved.len())
}

/// Runs `f` with the store at `p` attached to `store` as schema `src`, and detaches it whatever
/// `f` returns.
fn attached<T>(
    store: &mut Store,
    p: &Path,
    f: impl FnOnce(&mut Store) -> Result<T, CliError>,
) -> Result<T, CliError> {
    store
        .conn
        .execute(
            "ATTACH DATABASE ?1 AS src",
            [crate::store::plain_name(p).display().to_string()],
        )
        .with_context(|| format!("opening {}", p.display()))?;
    let result = f(store);
    store
        .conn
        .execute("DETACH DATABASE src", [])
        .context("closing an input")?;
    result
}

/// Every build that wrote into OUT or an input; refuses (unless `--allow-mixed`) stores of
/// different results formats, whose results can differ.
fn writers_of(store: &Store, a: &Args) -> Result<Vec<Writer>, CliError> {
    let mut formats: Vec<(String, Option<String>)> = Vec::new();
    if store.count()? > 0 {
        formats.push((a.out.display().to_string(), store.meta("results_format")?));
    }
    let mut writers = store.writers()?;
    for p in &a.inputs {
        let src = Store::open_existing(p)?;
        formats.push((p.display().to_string(), src.meta("results_format")?));
        for w in src.writers()? {
            if !writers.contains(&w) {
                writers.push(w);
            }
        }
    }
    if !a.allow_mixed && formats.iter().any(|(_, f)| *f != formats[0].1) {
        let list: Vec<String> = formats
            .iter()
            .map(|(p, f)| format!("{p}: {}", f.as_deref().unwrap_or("none recorded")))
            .collect();
        return Err(CliError::Input(format!(
            "these stores hold results of different results formats ({}), whose results can differ; nothing merged (--allow-mixed merges them anyway)",
            list.join(", ")
        )));
    }
    Ok(writers)
}

/// `formica merge --sweep FILE`: takes in the inputs' trials that are trials of FILE's grid.
fn into_sweep(a: &Args, file: &Path) -> Result<(), CliError> {
    let sweep = Sweep::load(file)?;
    let shas: Vec<String> = sweep
        .sets
        .iter()
        .map(|s| Provenance::of(&s.scenario, &Overrides::default()).scenario_sha256)
        .collect();
    let mut sets_of: HashMap<&str, Vec<usize>> = HashMap::new();
    for (i, sha) in shas.iter().enumerate() {
        sets_of.entry(sha.as_str()).or_default().push(i);
    }
    let seed_pos: HashMap<u64, usize> = sweep
        .seeds
        .iter()
        .enumerate()
        .map(|(i, &s)| (s, i))
        .collect();
    let mut store = Store::open(&a.out)?;
    let writers = writers_of(&store, a)?;
    store.adopt(&sweep, &a.out, "store")?;
    if store.meta("scenario_sha256")?.is_none() {
        store.set_meta("scenario_sha256", &sha256_hex(shas.join("\n").as_bytes()))?;
    }
    for (set, sha) in sweep.sets.iter().zip(&shas) {
        store.add_scenario(sha, &set.scenario.file, set.scenario.text())?;
    }
    let before = store.count()?;
    let mut skipped = 0usize;
    for p in &a.inputs {
        let src = Store::open_existing(p)?;
        let src_keys = src.keys()?;
        let meta: Vec<(String, Option<String>)> = [
            "results_format",
            "formica_version",
            "git_commit",
            "platform",
        ]
        .iter()
        .map(|k| Ok((k.to_string(), src.meta(k)?)))
        .collect::<Result<_, CliError>>()?;
        let mut rows: Vec<(String, u64, Option<String>)> = Vec::new();
        {
            let mut st = src
                .conn
                .prepare("SELECT params, seed, scenario_sha256 FROM trials")
                .context("reading trials")?;
            let it = st
                .query_map([], |r| {
                    Ok((r.get(0)?, r.get::<_, i64>(1)? as u64, r.get(2)?))
                })
                .context("reading trials")?;
            for r in it {
                rows.push(r.context("reading trials")?);
            }
        }
        drop(src);
        // The first writer's provenance becomes the store's, as a sweep's would.
        for (k, v) in meta {
            if let (None, Some(v)) = (store.meta(&k)?, v) {
                store.set_meta(&k, &v)?;
            }
        }
        skipped += attached(&mut store, p, |store| {
            // Columns copied as they are: results, provenance and end-of-run fields (not the
            // input's own parameters, which FILE's parameter set replaces).
            let copied: Vec<String> = columns_of(&store.conn, "src")?
                .into_iter()
                .filter(|c| !["trial", "params", "seed"].contains(&c.as_str()))
                .filter(|c| !src_keys.contains(c) && !sweep.keys.contains(c))
                .collect();
            store.ensure_columns(&copied)?;
            let mut cols: Vec<String> = ["trial", "params", "seed"]
                .iter()
                .map(|c| ident(c))
                .collect();
            cols.extend(sweep.keys.iter().map(|k| ident(k)));
            let marks: Vec<String> = (1..=cols.len()).map(|i| format!("?{i}")).collect();
            let n = cols.len();
            let copied_sql: Vec<String> = copied.iter().map(|c| ident(c)).collect();
            let trials_sql = format!(
                "INSERT OR IGNORE INTO main.trials ({}, {}) SELECT {}, {} FROM src.trials WHERE params = ?{} AND seed = ?3",
                cols.join(", "),
                copied_sql.join(", "),
                marks.join(", "),
                copied_sql.join(", "),
                n + 1
            );
            let tx = store.conn.transaction().context("starting a transaction")?;
            let mut skipped = 0usize;
            let mut differing = 0usize;
            {
                let mut ins = tx.prepare(&trials_sql).context("merging trials")?;
                // For a trial held already: does the input's result differ from it?
                let mut differs = tx
                    .prepare(&format!(
                        "SELECT COUNT(*) FROM src.trials s JOIN main.trials m
                             ON m.params = ?1 AND m.seed = ?3
                         WHERE s.params = ?2 AND s.seed = ?3 AND {DIFFERENT}"
                    ))
                    .context("comparing with the merged trials")?;
                let mut side = Vec::new();
                for table in ["trajectories", "timeseries"] {
                    let col = if table == "trajectories" {
                        "samples"
                    } else {
                        "series"
                    };
                    side.push(
                        tx.prepare(&format!(
                            "INSERT OR IGNORE INTO main.{table} (params, seed, {col}) SELECT ?1, seed, {col} FROM src.{table} WHERE params = ?2 AND seed = ?3"
                        ))
                        .with_context(|| format!("merging {table}"))?,
                    );
                }
                for (params, seed, sha) in &rows {
                    let sets = sha.as_deref().and_then(|s| sets_of.get(s));
                    let (Some(sets), Some(&pos)) = (sets, seed_pos.get(seed)) else {
                        skipped += 1;
                        continue;
                    };
                    for &i in sets {
                        let set = &sweep.sets[i];
                        let mut vals: Vec<SqlValue> = vec![
                            SqlValue::Integer((i * sweep.seeds.len() + pos) as i64),
                            SqlValue::Text(set.key.clone()),
                            SqlValue::Integer(*seed as i64),
                        ];
                        vals.extend(
                            sweep
                                .keys
                                .iter()
                                .map(|k| set.params.get(k).map_or(SqlValue::Null, sql_of)),
                        );
                        vals.push(SqlValue::Text(params.clone()));
                        let added = ins
                            .execute(rusqlite::params_from_iter(vals.iter()))
                            .context("merging trials")?;
                        if added == 0 {
                            let n: i64 = differs
                                .query_row(rusqlite::params![set.key, params, *seed as i64], |r| {
                                    r.get(0)
                                })
                                .context("comparing with the merged trials")?;
                            differing += n as usize;
                        }
                        for st in &mut side {
                            st.execute(rusqlite::params![set.key, params, *seed as i64])
                                .context("merging trajectories")?;
                        }
                    }
                }
            }
            tx.commit().context("merging trials")?;
            warn_differing(p, differing);
            Ok(skipped)
        })?;
    }
    if !writers.is_empty() {
        store.set_writers(&writers)?;
    }
    let after = store.count()?;
    outln!(
        "{}: {after} of the {} trials of {} ({} new from {} store(s); {skipped} stored trial(s) are not trials of it and were left out)",
        a.out.display(),
        sweep.sets.len() * sweep.seeds.len(),
        file.display(),
        after - before,
        a.inputs.len()
    );
    Ok(())
}
