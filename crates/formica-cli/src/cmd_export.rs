//! `formica export DB --csv FILE`: a result store as CSV, one row per trial, for pandas and R.

use crate::store::{ident, is_fixed_column, Store, METRICS, PROVENANCE};
use crate::CliError;
use anyhow::Context;
use rusqlite::types::Value as SqlValue;
use std::io::Write;
use std::path::{Path, PathBuf};

/// Arguments of `formica export`.
#[derive(clap::Args)]
pub struct Args {
    /// Result store (SQLite) written by `formica sweep` or `formica merge`.
    pub db: PathBuf,
    /// CSV file to write (`-`: standard output). Columns: trial, seed, params (JSON), one
    /// column per varied key, the provenance columns, then every metric, then every end-of-run
    /// field of loop functions.
    #[arg(long)]
    pub csv: PathBuf,
    /// Also write the stored object trajectories as CSV (params, seed, t, x, y, theta).
    #[arg(long)]
    pub trajectories: Option<PathBuf>,
}

/// Quotes a CSV field when needed.
pub fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

fn cell(v: &SqlValue) -> String {
    match v {
        SqlValue::Null => String::new(),
        SqlValue::Integer(i) => i.to_string(),
        SqlValue::Real(f) => format!("{f}"),
        SqlValue::Text(t) => csv_field(t),
        SqlValue::Blob(_) => String::new(),
    }
}

/// Gets output `path` ready to write: creates its folder, and refuses it if it is the store
/// `db` being read (checked once the folder exists, so that no path to it slips through).
/// `-` (standard output) needs nothing.
fn prepare_out(path: &Path, db: &Path) -> Result<(), CliError> {
    if path.as_os_str() == "-" {
        return Ok(());
    }
    if let Some(d) = path.parent() {
        if d.is_file() {
            return Err(CliError::Input(format!(
                "{}: `{}` is a file, not a folder",
                path.display(),
                d.display()
            )));
        }
        if !d.as_os_str().is_empty() {
            std::fs::create_dir_all(d).with_context(|| format!("creating {}", d.display()))?;
        }
    }
    crate::refuse_overwriting(path, db, "result store")
}

/// Opens `path` (`-`: standard output) for writing; [`prepare_out`] has checked it.
fn open_out(path: &Path) -> Result<Box<dyn Write>, CliError> {
    Ok(if path.as_os_str() == "-" {
        Box::new(std::io::BufWriter::new(crate::console::Stdout))
    } else {
        Box::new(std::io::BufWriter::new(
            std::fs::File::create(path).with_context(|| format!("creating {}", path.display()))?,
        ))
    })
}

/// The export's columns: head, varied keys, provenance, metrics, end-of-run fields.
pub fn export_columns(store: &Store) -> Result<Vec<String>, CliError> {
    let have = store.columns()?;
    let extras = store.extra_columns()?;
    let mut cols: Vec<String> = vec!["trial".into(), "seed".into(), "params".into()];
    for c in &have {
        if !is_fixed_column(c) && !extras.contains(c) {
            cols.push(c.clone());
        }
    }
    cols.extend(PROVENANCE.iter().map(|p| p.to_string()));
    cols.extend(METRICS.iter().map(|(m, _)| m.to_string()));
    cols.extend(extras);
    Ok(cols)
}

/// Writes every trial of `store` as CSV to `out` (the columns of [`export_columns`], one row
/// per trial in trial order); returns the number of trials written.
pub fn write_trials(store: &Store, out: &mut dyn Write) -> Result<usize, CliError> {
    let cols = export_columns(store)?;
    let sel: Vec<String> = cols.iter().map(|c| ident(c)).collect();
    let mut st = store
        .conn
        .prepare(&format!(
            "SELECT {} FROM trials ORDER BY trial, seed",
            sel.join(", ")
        ))
        .context("reading trials")?;
    let header: Vec<String> = cols.iter().map(|c| csv_field(c)).collect();
    writeln!(out, "{}", header.join(",")).context("writing CSV")?;
    let mut rows = st.query([]).context("reading trials")?;
    let mut n = 0usize;
    while let Some(r) = rows.next().context("reading trials")? {
        let mut line = Vec::with_capacity(cols.len());
        for i in 0..cols.len() {
            let v: SqlValue = r.get(i).context("reading a cell")?;
            line.push(cell(&v));
        }
        writeln!(out, "{}", line.join(",")).context("writing CSV")?;
        n += 1;
    }
    out.flush().context("writing CSV")?;
    Ok(n)
}

/// Runs the command.
pub fn main(a: Args) -> Result<(), CliError> {
    // Every output checked before anything is written.
    for out in std::iter::once(&a.csv).chain(&a.trajectories) {
        prepare_out(out, &a.db)?;
    }
    if let Some(tp) = &a.trajectories {
        let same = tp == &a.csv
            || matches!(
                (crate::resolve_path(tp), crate::resolve_path(&a.csv)),
                (Some(t), Some(c)) if t == c
            );
        if same {
            return Err(CliError::Input(format!(
                "--trajectories {}: the same file as --csv; give each its own",
                tp.display()
            )));
        }
    }
    let store = Store::open_existing(&a.db)?;
    let n = write_trials(&store, &mut open_out(&a.csv)?)?;
    if let Some(tp) = &a.trajectories {
        let mut out = open_out(tp)?;
        writeln!(out, "params,seed,t,x,y,theta").context("writing CSV")?;
        let stored = store.trajectories(usize::MAX >> 1)?;
        if stored.is_empty() {
            errln!(
                "warning: {} holds no trajectories ({} has the header only): sweep with \
                 --trajectories to store them",
                a.db.display(),
                tp.display()
            );
        }
        for (p, seed, samples) in stored {
            let pq = csv_field(&p);
            for [t, x, y, th] in samples {
                writeln!(out, "{pq},{seed},{t},{x},{y},{th}").context("writing CSV")?;
            }
        }
        out.flush().context("writing CSV")?;
    }
    if a.csv.as_os_str() != "-" {
        errln!("wrote {n} trials to {}", a.csv.display());
    }
    Ok(())
}
