//! `formica merge OUT.db IN1.db IN2.db ...`: merge shard result stores into one.

use crate::store::{columns_of, ident, Store};
use crate::CliError;
use anyhow::Context;
use std::path::PathBuf;

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
}

/// Runs the command.
pub fn main(a: Args) -> Result<(), CliError> {
    for p in &a.inputs {
        if !p.is_file() {
            return Err(CliError::Input(format!(
                "{}: no such result store",
                p.display()
            )));
        }
        if p.canonicalize().ok() == a.out.canonicalize().ok() {
            return Err(CliError::Input(format!(
                "{}: cannot merge a store into itself",
                p.display()
            )));
        }
    }
    let store = Store::open(&a.out)?;
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
    // Results formats: stores whose results can differ are not mixed unless asked.
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
    let before = store.count()?;
    for p in &a.inputs {
        let src = Store::open_existing(p)?;
        let mut keys = src.keys()?;
        drop(src);
        store
            .conn
            .execute("ATTACH DATABASE ?1 AS src", [p.display().to_string()])
            .with_context(|| format!("opening {}", p.display()))?;
        let result = (|| -> Result<(), CliError> {
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
        })();
        store
            .conn
            .execute("DETACH DATABASE src", [])
            .context("closing an input")?;
        result?;
    }
    if !writers.is_empty() {
        store.set_meta(
            "writers",
            &serde_json::to_string(&writers).context("encoding writers")?,
        )?;
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
