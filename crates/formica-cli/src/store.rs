//! The result store: one SQLite file (WAL mode), one row per finished trial, committed as each
//! trial finishes so an interrupted sweep keeps everything it finished.
//!
//! Tables:
//! - `meta(key, value)`: `name`, `digest` (of the sweep's fixed settings), `keys` (JSON list of
//!   the varied keys), `sweep` (the file); the provenance of the run that made the store
//!   (`formica_version`, `git_commit`, `platform`, `scenario_sha256`: of the canonical scenarios
//!   of every parameter set, in grid order), its `results_format`, and `writers` (JSON list of
//!   every build that added trials, see [`crate::provenance::Writer`]).
//! - `trials`: `trial` (index in the full grid), `params` (canonical JSON), `seed`, one column
//!   per varied key (named as the key, e.g. `robots.0.count`), then every `RunResult` metric
//!   (`scenario_name` for the result's `scenario`), the four [`PROVENANCE`] columns, then one
//!   column per end-of-run field that loop functions added (`RunResult::extra`, added as trials
//!   bring new ones; NULL in trials without it; lists and tables as JSON text). Primary key
//!   `(params, seed)`.
//! - `scenarios(sha256, file, toml)`: each parameter set's scenario as run (overrides applied),
//!   by its `scenario_sha256`, so that any trial can be replayed from the store alone.
//! - `trajectories(params, seed, samples)`: the object's path as JSON `[[t, x, y, theta], ...]`,
//!   and `timeseries(params, seed, series)`: goal distance, object speed and robots per state
//!   over time (JSON, see [`formica::timeseries::TimeSeries::to_json`]), when the sweep stores
//!   trajectories.

use crate::provenance::{Provenance, Writer};
use crate::sweep::Sweep;
use crate::CliError;
use anyhow::Context;
use formica::{Outcome, RunResult};
use rusqlite::types::Value as SqlValue;
use rusqlite::{params, Connection, OptionalExtension};
use std::collections::{BTreeMap, HashSet};
use std::path::{Path, PathBuf};

/// The metric columns, in order, with their SQL types.
pub const METRICS: &[(&str, &str)] = &[
    ("scenario_name", "TEXT"),
    ("controller", "TEXT"),
    ("robots", "INTEGER"),
    ("outcome", "TEXT"),
    ("sim_time_s", "REAL"),
    ("ticks", "INTEGER"),
    ("goal_distance_m", "REAL"),
    ("object_path_m", "REAL"),
    ("path_efficiency", "REAL"),
    ("object_robots", "INTEGER"),
    ("fill_time_s", "REAL"),
    ("convexity_before", "REAL"),
    ("convexity_after", "REAL"),
    ("cavity_filled", "REAL"),
    ("cavity_capacity", "INTEGER"),
    ("cavity_robots", "INTEGER"),
    ("false_stops", "INTEGER"),
    ("wall_time_s", "REAL"),
];

/// Provenance columns of `trials` (see [`crate::provenance`]).
pub const PROVENANCE: &[&str] = &[
    "formica_version",
    "git_commit",
    "scenario_sha256",
    "platform",
];

/// Columns every `trials` table starts with.
pub const HEAD: &[&str] = &["trial", "params", "seed"];

/// Whether `c` is one of the columns every `trials` table has (head, metrics, provenance).
pub fn is_fixed_column(c: &str) -> bool {
    HEAD.contains(&c) || METRICS.iter().any(|(m, _)| *m == c) || PROVENANCE.contains(&c)
}

/// Quotes an SQL identifier.
pub fn ident(name: &str) -> String {
    format!("\"{}\"", name.replace('"', "\"\""))
}

/// An open result store.
pub struct Store {
    /// The connection.
    pub conn: Connection,
    /// The file (for messages).
    path: PathBuf,
    /// Columns of `trials` known to exist (end-of-run fields are added as they come).
    known: HashSet<String>,
}

/// One finished trial, ready to store.
pub struct Row {
    /// Index in the full grid.
    pub trial: usize,
    /// Canonical JSON of the parameter set.
    pub params: String,
    /// Varied keys and their values.
    pub values: Vec<(String, toml::Value)>,
    /// The result.
    pub result: RunResult,
    /// Object samples `[t, x, y, theta]`, if stored.
    pub trajectory: Option<Vec<[f64; 4]>>,
    /// The time series (JSON), if stored.
    pub timeseries: Option<String>,
    /// Which build made it, from which scenario.
    pub provenance: Provenance,
}

/// A varied key's value as SQL: numbers as INTEGER or REAL, booleans as 0 / 1, lists and tables
/// as canonical JSON text.
pub fn sql_of(v: &toml::Value) -> SqlValue {
    match v {
        toml::Value::Integer(i) => SqlValue::Integer(*i),
        toml::Value::Float(f) => SqlValue::Real(*f),
        toml::Value::Boolean(b) => SqlValue::Integer(i64::from(*b)),
        toml::Value::String(s) => SqlValue::Text(s.clone()),
        other => SqlValue::Text(crate::sweep::canonical_json(other)),
    }
}

/// An end-of-run field as SQL: numbers as INTEGER or REAL, booleans as 0 / 1, lists and tables as
/// JSON text.
fn sql_of_json(v: &serde_json::Value) -> SqlValue {
    use serde_json::Value as J;
    match v {
        J::Null => SqlValue::Null,
        J::Bool(b) => SqlValue::Integer(i64::from(*b)),
        J::Number(n) => match (n.as_i64(), n.as_f64()) {
            (Some(i), _) => SqlValue::Integer(i),
            (None, Some(f)) => SqlValue::Real(f),
            (None, None) => SqlValue::Text(n.to_string()),
        },
        J::String(s) => SqlValue::Text(s.clone()),
        other => SqlValue::Text(other.to_string()),
    }
}

/// A stored end-of-run field back as JSON (NULL: absent).
fn json_of_sql(v: SqlValue) -> Option<serde_json::Value> {
    match v {
        SqlValue::Null | SqlValue::Blob(_) => None,
        SqlValue::Integer(i) => Some(i.into()),
        SqlValue::Real(f) => serde_json::Number::from_f64(f).map(serde_json::Value::Number),
        SqlValue::Text(t) => Some(t.into()),
    }
}

/// The names of the tables in an SQLite file, in name order.
fn table_names(conn: &Connection) -> rusqlite::Result<Vec<String>> {
    let mut st =
        conn.prepare("SELECT name FROM sqlite_master WHERE type = 'table' ORDER BY name")?;
    let names = st.query_map([], |r| r.get(0))?.collect();
    names
}

impl Store {
    /// `what`, prefixed with the store's file, for an error message.
    fn at(&self, what: &str) -> String {
        format!("{}: {what}", self.path.display())
    }

    /// A transaction, and the store's file for its error messages.
    fn begin(&mut self) -> Result<(rusqlite::Transaction<'_>, Located), CliError> {
        let at = Located(self.path.display().to_string());
        let tx = self
            .conn
            .transaction()
            .with_context(|| at.of("starting a transaction"))?;
        Ok((tx, at))
    }

    /// Opens (creating if needed) a store. An SQLite file with tables but no `trials` table
    /// (another program's) is refused untouched.
    pub fn open(path: &Path) -> Result<Store, CliError> {
        if let Some(dir) = path.parent() {
            if !dir.as_os_str().is_empty() {
                std::fs::create_dir_all(dir)
                    .with_context(|| format!("creating {}", dir.display()))?;
            }
        }
        let conn = Connection::open(plain_name(path))
            .with_context(|| format!("opening {}", path.display()))?;
        conn.busy_timeout(std::time::Duration::from_secs(30))
            .with_context(|| format!("{}: setting the busy timeout", path.display()))?;
        // The first statement that reads the file: one that is not SQLite fails here, and
        // another program's SQLite file is refused before anything of ours is written to it.
        let tables = match table_names(&conn) {
            Ok(t) => t,
            Err(e) if e.sqlite_error_code() == Some(rusqlite::ErrorCode::NotADatabase) => {
                return Err(CliError::Input(format!(
                    "{}: not a result store (not an SQLite file)",
                    path.display()
                )));
            }
            Err(e) => {
                return Err(anyhow::Error::new(e)
                    .context(format!("{}: reading its tables", path.display()))
                    .into())
            }
        };
        if !tables.is_empty() && !tables.iter().any(|t| t == "trials") {
            return Err(CliError::Input(format!(
                "{}: an SQLite file but not a Formica result store (it has {} and no `trials` \
                 table); give a new file or a store that formica sweep wrote",
                path.display(),
                match tables.len() {
                    1 => format!("the table `{}`", tables[0]),
                    n => format!("{n} tables, `{}` first", tables[0]),
                }
            )));
        }
        // WAL: a committed trial survives the process being killed at any moment. (A file
        // that is not SQLite failed above, at the first statement that read it.)
        conn.pragma_update(None, "journal_mode", "WAL")
            .with_context(|| format!("{}: enabling WAL", path.display()))?;
        conn.pragma_update(None, "synchronous", "NORMAL")
            .with_context(|| format!("{}: setting synchronous", path.display()))?;
        let metrics: Vec<String> = METRICS
            .iter()
            .map(|(n, t)| format!("{} {t}", ident(n)))
            .collect();
        conn.execute_batch(&format!(
            "CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);
             CREATE TABLE IF NOT EXISTS trials (trial INTEGER NOT NULL, params TEXT NOT NULL,
                 seed INTEGER NOT NULL, {}, PRIMARY KEY (params, seed));
             CREATE TABLE IF NOT EXISTS trajectories (params TEXT NOT NULL, seed INTEGER NOT NULL,
                 samples TEXT NOT NULL, PRIMARY KEY (params, seed));
             CREATE TABLE IF NOT EXISTS timeseries (params TEXT NOT NULL, seed INTEGER NOT NULL,
                 series TEXT NOT NULL, PRIMARY KEY (params, seed));
             CREATE TABLE IF NOT EXISTS scenarios (sha256 TEXT PRIMARY KEY, file TEXT NOT NULL,
                 toml TEXT NOT NULL);",
            metrics.join(", ")
        ))
        .with_context(|| format!("creating the tables of {}", path.display()))?;
        let mut store = Store {
            conn,
            path: path.to_path_buf(),
            known: HashSet::new(),
        };
        // A trials table without a column every store has (dropped by hand, or a damaged
        // file) would read as wrong figures or fail at a row with a puzzling message.
        let have = store.columns()?;
        let missing: Vec<&str> = HEAD
            .iter()
            .copied()
            .chain(METRICS.iter().map(|(m, _)| *m))
            .filter(|c| !have.iter().any(|h| h == c))
            .collect();
        if !missing.is_empty() {
            return Err(CliError::Input(format!(
                "{}: a damaged result store (or one from an older Formica): its trials table lacks {} \
                 (every store formica sweep writes has them)",
                path.display(),
                missing
                    .iter()
                    .map(|c| format!("`{c}`"))
                    .collect::<Vec<_>>()
                    .join(", ")
            )));
        }
        // Stores made before provenance was recorded get its columns (empty in old rows).
        let want: Vec<String> = PROVENANCE.iter().map(|s| s.to_string()).collect();
        store.ensure_columns(&want)?;
        store.known = store.columns()?.into_iter().collect();
        Ok(store)
    }

    /// Opens an existing store (for reading); a missing file, an empty one, or an SQLite file
    /// without the store's tables is an input error (and is left as it was).
    pub fn open_existing(path: &Path) -> Result<Store, CliError> {
        if !path.is_file() {
            return Err(CliError::Input(not_a_store(path)));
        }
        if std::fs::metadata(path).is_ok_and(|m| m.len() == 0) {
            return Err(CliError::Input(format!(
                "{}: an empty file, not a result store (formica sweep writes one)",
                path.display()
            )));
        }
        let s = Store::open(path)?;
        Ok(s)
    }

    /// A meta value.
    pub fn meta(&self, key: &str) -> Result<Option<String>, CliError> {
        Ok(self
            .conn
            .query_row("SELECT value FROM meta WHERE key = ?1", [key], |r| r.get(0))
            .optional()
            .with_context(|| self.at("reading meta"))?)
    }

    /// Sets a meta value.
    pub fn set_meta(&self, key: &str, value: &str) -> Result<(), CliError> {
        self.conn
            .execute(
                "INSERT OR REPLACE INTO meta (key, value) VALUES (?1, ?2)",
                [key, value],
            )
            .with_context(|| self.at("writing meta"))?;
        Ok(())
    }

    /// Records which sweep fills this store, or refuses a store made by a different one, or
    /// (unless `allow_mixed`) one holding trials of a build whose results can differ from this
    /// one's: another results format, or none recorded (a store from before formats were).
    /// `scenarios_sha256` is the digest of the sweep's scenarios for `meta`.
    pub fn bind(
        &self,
        sweep: &Sweep,
        path: &Path,
        scenarios_sha256: &str,
        allow_mixed: bool,
    ) -> Result<(), CliError> {
        let me = Writer::this();
        let mut writers = self.writers()?;
        let theirs: Option<u32> = match self.meta("results_format")? {
            None => None,
            Some(f) => Some(f.trim().parse().map_err(|_| {
                CliError::Input(format!(
                    "{}: a damaged result store: its meta value `results_format` is {f:?}, not \
                     a whole number",
                    path.display()
                ))
            })?),
        };
        if self.count()? > 0 && theirs != Some(me.results_format) && !allow_mixed {
            let mut who = if writers.is_empty() {
                "a Formica that recorded no results format (older than provenance)".to_string()
            } else {
                writers
                    .iter()
                    .map(Writer::describe)
                    .collect::<Vec<_>>()
                    .join("; ")
            };
            if let Some(f) = theirs {
                who += &format!(" (its meta records results format {f})");
            }
            return Err(CliError::Input(format!(
                "{}: its trials were written by {who}; this is Formica {}. Results can differ between results formats, so resuming would mix them in one store. Use another --db, or --allow-mixed to add to it anyway (every row records the build that wrote it)",
                path.display(),
                me.describe()
            )));
        }
        if !writers.contains(&me) {
            writers.push(me.clone());
            self.set_writers(&writers)?;
        }
        if theirs.is_none() {
            self.set_meta("results_format", &me.results_format.to_string())?;
            self.set_meta("formica_version", &me.formica_version)?;
            self.set_meta("git_commit", &me.git_commit)?;
            self.set_meta("platform", &me.platform)?;
            self.set_meta("scenario_sha256", scenarios_sha256)?;
        }
        self.adopt(sweep, path, "--db")
    }

    /// What [`Store::bind`] would say of this store, and the trials it holds, without writing
    /// anything (for `sweep --dry-run`): the binding runs in a transaction that is rolled back.
    pub fn would_bind(
        &self,
        sweep: &Sweep,
        path: &Path,
        scenarios_sha256: &str,
        allow_mixed: bool,
    ) -> Result<HashSet<(String, u64)>, CliError> {
        self.conn
            .execute_batch("BEGIN")
            .with_context(|| format!("{}: starting a transaction", path.display()))?;
        let result = self
            .bind(sweep, path, scenarios_sha256, allow_mixed)
            .and_then(|()| self.done());
        self.conn
            .execute_batch("ROLLBACK")
            .with_context(|| format!("{}: rolling back", path.display()))?;
        result
    }

    /// Records that this store holds trials of `sweep` (its digest, name, file and varied keys,
    /// with a column each), or refuses a store of a different sweep, telling the user to use
    /// another `what` (`--db` for a sweep).
    pub fn adopt(&self, sweep: &Sweep, path: &Path, what: &str) -> Result<(), CliError> {
        match self.meta("digest")? {
            Some(d) if d == sweep.digest => {}
            Some(_) if self.count()? > 0 => {
                return Err(CliError::Input(format!(
                    "{}: this store holds trials of a different sweep (its base scenario, [set] or duration_s differ from {}); use another {what}, or delete the store to start over",
                    path.display(),
                    sweep.file.display()
                )))
            }
            old => {
                if old.is_some() {
                    // A store of another sweep that holds no trial yet (one interrupted before
                    // its first trial ended, its file then mended) is taken over; the old
                    // sweep's varied keys go with it (their columns are empty).
                    for k in self.keys()?.iter().filter(|k| !sweep.keys.contains(k)) {
                        self.conn
                            .execute(&format!("ALTER TABLE trials DROP COLUMN {}", ident(k)), [])
                            .with_context(|| format!("dropping column {k}"))?;
                    }
                    self.set_meta("keys", "[]")?;
                }
                self.set_meta("digest", &sweep.digest)?;
                self.set_meta("name", &sweep.name)?;
                self.set_meta("sweep", &sweep.file.display().to_string())?;
            }
        }
        // The grid's size, so that a report can tell a partial store (`--limit`, a stopped
        // sweep, one shard) from a whole one.
        self.set_meta(
            "grid_trials",
            &(sweep.sets.len() * sweep.seeds.len()).to_string(),
        )?;
        let mut keys = self.keys()?;
        for k in &sweep.keys {
            if !keys.contains(k) {
                keys.push(k.clone());
            }
        }
        self.set_meta(
            "keys",
            &serde_json::to_string(&keys).with_context(|| self.at("encoding keys"))?,
        )?;
        self.ensure_columns(&sweep.keys)
    }

    /// Records the builds that wrote into the store (`meta` key `writers`).
    pub fn set_writers(&self, writers: &[Writer]) -> Result<(), CliError> {
        self.set_meta(
            "writers",
            &serde_json::to_string(writers).with_context(|| self.at("encoding writers"))?,
        )
    }

    /// The column names of `trials`.
    pub fn columns(&self) -> Result<Vec<String>, CliError> {
        columns_of(&self.conn, "main")
    }

    /// Adds a column for each varied key that has none yet.
    pub fn ensure_columns(&self, keys: &[String]) -> Result<(), CliError> {
        let have = self.columns()?;
        for k in keys {
            if !have.contains(k) {
                self.conn
                    .execute(&format!("ALTER TABLE trials ADD COLUMN {}", ident(k)), [])
                    .with_context(|| format!("adding column {k}"))?;
            }
        }
        Ok(())
    }

    /// The (params, seed) keys already stored.
    pub fn done(&self) -> Result<HashSet<(String, u64)>, CliError> {
        let mut st = self
            .conn
            .prepare("SELECT params, seed FROM trials")
            .with_context(|| self.at("reading trials"))?;
        let rows = st
            .query_map([], |r| {
                Ok((r.get::<_, String>(0)?, r.get::<_, i64>(1)? as u64))
            })
            .with_context(|| self.at("reading trials"))?;
        let mut out = HashSet::new();
        for r in rows {
            out.insert(r.with_context(|| self.at("reading trials"))?);
        }
        Ok(out)
    }

    /// Sets the grid index of stored trials (`(params, seed) -> trial`), so that a sweep file
    /// whose grid grew keeps its rows in grid order.
    pub fn reindex(&mut self, index: &[(&str, u64, usize)]) -> Result<(), CliError> {
        let (tx, at) = self.begin()?;
        {
            let mut st = tx
                .prepare(
                    "UPDATE trials SET trial = ?1 WHERE params = ?2 AND seed = ?3 AND trial <> ?1",
                )
                .with_context(|| at.of("renumbering trials"))?;
            for (p, seed, i) in index {
                st.execute(params![*i as i64, p, *seed as i64])
                    .with_context(|| at.of("renumbering trials"))?;
            }
        }
        tx.commit().with_context(|| at.of("renumbering trials"))?;
        Ok(())
    }

    /// Number of stored trials.
    pub fn count(&self) -> Result<usize, CliError> {
        let n: i64 = self
            .conn
            .query_row("SELECT COUNT(*) FROM trials", [], |r| r.get(0))
            .with_context(|| self.at("counting trials"))?;
        Ok(n as usize)
    }

    /// The columns of end-of-run fields: those neither fixed (head, metrics, provenance) nor a
    /// varied key, in table order.
    pub fn extra_columns(&self) -> Result<Vec<String>, CliError> {
        let keys = self.keys()?;
        Ok(self
            .columns()?
            .into_iter()
            .filter(|c| !is_fixed_column(c) && !keys.contains(c))
            .collect())
    }

    /// Adds a column for each end-of-run field of `row` that has none yet.
    fn ensure_extra_columns(&mut self, row: &Row) -> Result<(), CliError> {
        for k in row.result.extra.keys() {
            if row.values.iter().any(|(v, _)| v == k) {
                return Err(CliError::Input(format!(
                    "end-of-run field `{k}` has the name of a varied key; rename one of them"
                )));
            }
            if is_fixed_column(k) {
                return Err(CliError::Input(format!(
                    "end-of-run field `{k}` has the name of a column of every result store; rename it"
                )));
            }
            if self.known.contains(k) {
                continue;
            }
            let have = self.columns()?;
            if !have.contains(k) {
                self.conn
                    .execute(&format!("ALTER TABLE trials ADD COLUMN {}", ident(k)), [])
                    .with_context(|| format!("adding column {k}"))?;
            }
            self.known.extend(have);
            self.known.insert(k.clone());
        }
        Ok(())
    }

    /// Stores one trial (and its trajectory) in one transaction.
    pub fn insert(&mut self, row: &Row) -> Result<(), CliError> {
        self.ensure_extra_columns(row)?;
        let r = &row.result;
        let mut cols: Vec<String> = HEAD.iter().map(|s| ident(s)).collect();
        let mut vals: Vec<SqlValue> = vec![
            SqlValue::Integer(row.trial as i64),
            SqlValue::Text(row.params.clone()),
            SqlValue::Integer(r.seed as i64),
        ];
        for (k, v) in &row.values {
            cols.push(ident(k));
            vals.push(sql_of(v));
        }
        let opt_f = |x: Option<f64>| x.map_or(SqlValue::Null, SqlValue::Real);
        let opt_n = |x: Option<usize>| x.map_or(SqlValue::Null, |n| SqlValue::Integer(n as i64));
        let metrics = [
            SqlValue::Text(r.scenario.clone()),
            SqlValue::Text(r.controller.clone()),
            SqlValue::Integer(r.robots as i64),
            SqlValue::Text(r.outcome.name().to_string()),
            SqlValue::Real(r.sim_time_s),
            SqlValue::Integer(r.ticks as i64),
            opt_f(r.goal_distance_m),
            opt_f(r.object_path_m),
            opt_f(r.path_efficiency),
            r.object_robots
                .map_or(SqlValue::Null, |n| SqlValue::Integer(n as i64)),
            opt_f(r.fill_time_s),
            opt_f(r.convexity_before),
            opt_f(r.convexity_after),
            opt_f(r.cavity_filled),
            opt_n(r.cavity_capacity),
            opt_n(r.cavity_robots),
            opt_n(r.false_stops),
            SqlValue::Real(r.wall_time_s),
        ];
        for ((name, _), v) in METRICS.iter().zip(metrics) {
            cols.push(ident(name));
            vals.push(v);
        }
        let p = &row.provenance;
        for (name, v) in PROVENANCE.iter().zip([
            &p.formica_version,
            &p.git_commit,
            &p.scenario_sha256,
            &p.platform,
        ]) {
            cols.push(ident(name));
            vals.push(SqlValue::Text(v.clone()));
        }
        for (k, v) in &r.extra {
            cols.push(ident(k));
            vals.push(sql_of_json(v));
        }
        let marks: Vec<String> = (1..=vals.len()).map(|i| format!("?{i}")).collect();
        let (tx, at) = self.begin()?;
        tx.execute(
            &format!(
                "INSERT OR REPLACE INTO trials ({}) VALUES ({})",
                cols.join(", "),
                marks.join(", ")
            ),
            rusqlite::params_from_iter(vals),
        )
        .with_context(|| at.of("storing a trial"))?;
        if let Some(tr) = &row.trajectory {
            let json = serde_json::to_string(tr).with_context(|| at.of("encoding a trajectory"))?;
            tx.execute(
                "INSERT OR REPLACE INTO trajectories (params, seed, samples) VALUES (?1, ?2, ?3)",
                params![row.params, r.seed as i64, json],
            )
            .with_context(|| at.of("storing a trajectory"))?;
        }
        if let Some(series) = &row.timeseries {
            tx.execute(
                "INSERT OR REPLACE INTO timeseries (params, seed, series) VALUES (?1, ?2, ?3)",
                params![row.params, r.seed as i64, series],
            )
            .with_context(|| at.of("storing a time series"))?;
        }
        tx.commit().with_context(|| at.of("committing a trial"))?;
        Ok(())
    }

    /// Every stored trial, in grid order.
    pub fn results(&self) -> Result<Vec<StoredTrial>, CliError> {
        self.select("", [])
    }

    /// The stored trial with grid index `trial`, if any.
    pub fn trial(&self, trial: usize) -> Result<Option<StoredTrial>, CliError> {
        Ok(self
            .select("WHERE trial = ?1", [trial as i64])?
            .into_iter()
            .next())
    }

    fn select(
        &self,
        filter: &str,
        args: impl rusqlite::Params,
    ) -> Result<Vec<StoredTrial>, CliError> {
        let extras = self.extra_columns()?;
        let fixed = HEAD.len() + METRICS.len() + PROVENANCE.len();
        let sel: Vec<String> = HEAD
            .iter()
            .chain(METRICS.iter().map(|(n, _)| n))
            .chain(PROVENANCE)
            .copied()
            .chain(extras.iter().map(String::as_str))
            .map(ident)
            .collect();
        let mut st = self
            .conn
            .prepare(&format!(
                "SELECT {} FROM trials {filter} ORDER BY trial, seed",
                sel.join(", ")
            ))
            .with_context(|| self.at("reading trials"))?;
        // Column positions by name: the selection is HEAD, METRICS, PROVENANCE, then extras.
        let names: Vec<&str> = HEAD
            .iter()
            .chain(METRICS.iter().map(|(n, _)| n))
            .chain(PROVENANCE)
            .copied()
            .collect();
        let at = |name: &str| names.iter().position(|n| *n == name).unwrap_or(usize::MAX);
        let rows = st
            .query_map(args, |r| {
                let outcome: String = r.get(at("outcome"))?;
                let outcome = match outcome.as_str() {
                    "success" => Outcome::Success,
                    "wall" => Outcome::Wall,
                    "timeout" => Outcome::Timeout,
                    other => {
                        return Err(rusqlite::Error::FromSqlConversionFailure(
                            at("outcome"),
                            rusqlite::types::Type::Text,
                            format!("unknown outcome `{other}`").into(),
                        ))
                    }
                };
                let params: String = r.get(at("params"))?;
                let text = |i: usize| -> rusqlite::Result<String> {
                    Ok(r.get::<_, Option<String>>(i)?.unwrap_or_default())
                };
                let mut extra = BTreeMap::new();
                for (i, k) in extras.iter().enumerate() {
                    if let Some(v) = json_of_sql(r.get(fixed + i)?) {
                        extra.insert(k.clone(), v);
                    }
                }
                Ok(StoredTrial {
                    trial: r.get::<_, i64>(at("trial"))? as usize,
                    provenance: Provenance {
                        formica_version: text(at("formica_version"))?,
                        git_commit: text(at("git_commit"))?,
                        scenario_sha256: text(at("scenario_sha256"))?,
                        platform: text(at("platform"))?,
                    },
                    params: serde_json::from_str(&params).unwrap_or_default(),
                    params_json: params,
                    result: RunResult {
                        scenario: r.get(at("scenario_name"))?,
                        seed: r.get::<_, i64>(at("seed"))? as u64,
                        outcome,
                        sim_time_s: r.get(at("sim_time_s"))?,
                        ticks: r.get::<_, i64>(at("ticks"))? as u64,
                        robots: r.get::<_, i64>(at("robots"))? as usize,
                        controller: r.get(at("controller"))?,
                        goal_distance_m: r.get(at("goal_distance_m"))?,
                        object_path_m: r.get(at("object_path_m"))?,
                        path_efficiency: r.get(at("path_efficiency"))?,
                        object_robots: r
                            .get::<_, Option<i64>>(at("object_robots"))?
                            .map(|n| n as usize),
                        fill_time_s: r.get(at("fill_time_s"))?,
                        convexity_before: r.get(at("convexity_before"))?,
                        convexity_after: r.get(at("convexity_after"))?,
                        cavity_filled: r.get(at("cavity_filled"))?,
                        cavity_capacity: r
                            .get::<_, Option<i64>>(at("cavity_capacity"))?
                            .map(|n| n as usize),
                        cavity_robots: r
                            .get::<_, Option<i64>>(at("cavity_robots"))?
                            .map(|n| n as usize),
                        false_stops: r
                            .get::<_, Option<i64>>(at("false_stops"))?
                            .map(|n| n as usize),
                        wall_time_s: r.get(at("wall_time_s"))?,
                        extra,
                    },
                })
            })
            .with_context(|| self.at("reading trials"))?;
        let mut out = Vec::new();
        for r in rows {
            out.push(r.with_context(|| self.at("reading a trial"))?);
        }
        Ok(out)
    }

    /// Stored trajectories, at most `limit`, taken round the parameter sets: (params JSON,
    /// seed, samples).
    pub fn trajectories(&self, limit: usize) -> Result<Vec<StoredTrajectory>, CliError> {
        let mut st = self
            .conn
            .prepare(
                // Round the parameter sets: each one's first seed, then each one's second, ...,
                // so that a limit below the count samples every set alike.
                "SELECT params, seed, samples FROM (SELECT params, seed, samples, ROW_NUMBER() \
                 OVER (PARTITION BY params ORDER BY seed) AS k FROM trajectories) \
                 ORDER BY k, params LIMIT ?1",
            )
            .with_context(|| self.at("reading trajectories"))?;
        let rows = st
            .query_map([limit as i64], |r| {
                Ok((
                    r.get::<_, String>(0)?,
                    r.get::<_, i64>(1)? as u64,
                    r.get::<_, String>(2)?,
                ))
            })
            .with_context(|| self.at("reading trajectories"))?;
        let mut out = Vec::new();
        for r in rows {
            let (p, s, json) = r.with_context(|| self.at("reading a trajectory"))?;
            let samples: Vec<[f64; 4]> =
                serde_json::from_str(&json).with_context(|| self.at("decoding a trajectory"))?;
            out.push((p, s, samples));
        }
        Ok(out)
    }

    /// How many trajectories the store holds.
    pub fn trajectory_count(&self) -> Result<usize, CliError> {
        let n: i64 = self
            .conn
            .query_row("SELECT COUNT(*) FROM trajectories", [], |r| r.get(0))
            .with_context(|| self.at("counting trajectories"))?;
        Ok(n as usize)
    }

    /// Keeps a parameter set's scenario (as run) under its digest.
    pub fn add_scenario(&self, sha256: &str, file: &str, toml: &str) -> Result<(), CliError> {
        self.conn
            .execute(
                "INSERT OR IGNORE INTO scenarios (sha256, file, toml) VALUES (?1, ?2, ?3)",
                [sha256, file, toml],
            )
            .with_context(|| self.at("storing a scenario"))?;
        Ok(())
    }

    /// A kept scenario: its file name and TOML text.
    pub fn scenario(&self, sha256: &str) -> Result<Option<(String, String)>, CliError> {
        Ok(self
            .conn
            .query_row(
                "SELECT file, toml FROM scenarios WHERE sha256 = ?1",
                [sha256],
                |r| Ok((r.get(0)?, r.get(1)?)),
            )
            .optional()
            .with_context(|| self.at("reading a scenario"))?)
    }

    /// The builds that wrote into the store (`meta` key `writers`).
    pub fn writers(&self) -> Result<Vec<Writer>, CliError> {
        self.meta_list("writers")
    }

    /// The varied keys recorded in the store.
    pub fn keys(&self) -> Result<Vec<String>, CliError> {
        self.meta_list("keys")
    }

    /// A meta value that holds a JSON list (none recorded: empty). A value that does not
    /// decode (edited by hand, or a damaged file) is refused, naming the store and the key,
    /// rather than read as empty and written over.
    fn meta_list<T: serde::de::DeserializeOwned>(&self, key: &str) -> Result<Vec<T>, CliError> {
        match self.meta(key)? {
            None => Ok(Vec::new()),
            Some(v) => serde_json::from_str(&v).map_err(|e| {
                CliError::Input(format!(
                    "{}: a damaged result store: its meta value `{key}` is not the JSON list \
                     formica sweep writes ({e})",
                    self.path.display()
                ))
            }),
        }
    }
}

/// A stored object path: params JSON, seed, samples `[t, x, y, theta]`.
pub type StoredTrajectory = (String, u64, Vec<[f64; 4]>);

/// One trial read back from a store.
#[derive(Clone)]
pub struct StoredTrial {
    /// Index in the sweep's grid (what `--trial` takes).
    pub trial: usize,
    /// Which build wrote it (empty in stores from before provenance).
    pub provenance: Provenance,
    /// Parameter set.
    pub params: serde_json::Map<String, serde_json::Value>,
    /// Its canonical JSON.
    pub params_json: String,
    /// The metrics (`wall_time_s` as measured).
    pub result: RunResult,
}

/// Why `path`, which is not a file, is no result store: missing, or a folder.
pub fn not_a_store(path: &Path) -> String {
    if path.is_dir() {
        format!("{}: a folder, not a result store (a file)", path.display())
    } else {
        format!("{}: no such result store", path.display())
    }
}

/// `path` as SQLite takes it for that file: a relative name beginning `file:` gets `./` in
/// front, which SQLite would otherwise read as a URI naming another file.
pub fn plain_name(path: &Path) -> PathBuf {
    if path.to_string_lossy().starts_with("file:") {
        Path::new(".").join(path)
    } else {
        path.to_path_buf()
    }
}

/// A store's file, to put before what failed in an error message.
struct Located(String);

impl Located {
    fn of(&self, what: &str) -> String {
        format!("{}: {what}", self.0)
    }
}

/// Column names of `trials` in schema `db`.
pub fn columns_of(conn: &Connection, db: &str) -> Result<Vec<String>, CliError> {
    let mut st = conn
        .prepare(&format!("PRAGMA {}.table_info(trials)", ident(db)))
        .context("reading the table layout")?;
    let rows = st
        .query_map([], |r| r.get::<_, String>(1))
        .context("reading the table layout")?;
    let mut out = Vec::new();
    for r in rows {
        out.push(r.context("reading the table layout")?);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(seed: u64, extra: serde_json::Value) -> Row {
        let extra = extra.as_object().cloned().unwrap_or_default();
        Row {
            trial: seed as usize,
            params: "{}".into(),
            values: vec![("robots.0.count".into(), toml::Value::Integer(3))],
            result: RunResult {
                scenario: "s".into(),
                seed,
                extra: extra.into_iter().collect(),
                ..RunResult::default()
            },
            trajectory: None,
            timeseries: None,
            provenance: Provenance {
                formica_version: "v".into(),
                git_commit: "c".into(),
                scenario_sha256: "s".into(),
                platform: "p".into(),
            },
        }
    }

    #[test]
    fn end_of_run_fields_read_back_as_core_says_a_store_keeps_them() {
        for v in [
            serde_json::json!(null),
            serde_json::json!(true),
            serde_json::json!(false),
            serde_json::json!(7),
            serde_json::json!(-7),
            serde_json::json!(u64::MAX),
            serde_json::json!(1.0),
            serde_json::json!(0.1),
            serde_json::json!("text"),
            serde_json::json!([1, 2]),
            serde_json::json!({ "a": 1 }),
        ] {
            assert_eq!(
                json_of_sql(sql_of_json(&v)),
                formica::experiment::extra_as_stored(&v),
                "{v}"
            );
        }
    }

    #[test]
    fn a_limit_on_trajectories_takes_every_parameter_set_alike() {
        let dir = std::env::temp_dir().join(format!("formica-traj-test-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let store = Store::open(&dir.join("t.db")).unwrap();
        for set in ["a", "b", "c"] {
            for seed in 1..=4 {
                store
                    .conn
                    .execute(
                        "INSERT INTO trajectories (params, seed, samples) VALUES (?1, ?2, '[]')",
                        rusqlite::params![set, seed],
                    )
                    .unwrap();
            }
        }
        let got: Vec<(String, u64)> = store
            .trajectories(4)
            .unwrap()
            .into_iter()
            .map(|(p, s, _)| (p, s))
            .collect();
        // Each set's first seed, then the second of the first set (by params order).
        let want = [("a", 1), ("b", 1), ("c", 1), ("a", 2)].map(|(p, s)| (p.to_string(), s));
        assert_eq!(got, want);
        assert_eq!(store.trajectory_count().unwrap(), 12);
    }

    #[test]
    fn end_of_run_fields_become_columns_and_read_back() {
        let dir = std::env::temp_dir().join(format!("formica-store-test-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let path = dir.join("t.db");
        let mut store = Store::open(&path).unwrap();
        store.set_meta("keys", r#"["robots.0.count"]"#).unwrap();
        store.ensure_columns(&["robots.0.count".into()]).unwrap();
        store
            .insert(&row(
                1,
                serde_json::json!({ "b": 1.5, "a": [1, 2], "flag": true }),
            ))
            .unwrap();
        store.insert(&row(2, serde_json::json!({}))).unwrap();
        store
            .insert(&row(3, serde_json::json!({ "c": 7 })))
            .unwrap();
        assert_eq!(store.extra_columns().unwrap(), ["a", "b", "flag", "c"]);
        let back = store.results().unwrap();
        let extra = |i: usize| serde_json::to_value(&back[i].result.extra).unwrap();
        assert_eq!(
            extra(0),
            serde_json::json!({ "a": "[1,2]", "b": 1.5, "flag": 1 })
        );
        assert_eq!(extra(1), serde_json::json!({}));
        assert_eq!(extra(2), serde_json::json!({ "c": 7 }));
        // The provenance columns come before the end-of-run fields and read back as written.
        let cols = store.columns().unwrap();
        let at = |c: &str| cols.iter().position(|x| x == c).unwrap();
        assert!(at("platform") < at("a"), "{cols:?}");
        assert_eq!(back[2].provenance, row(3, serde_json::json!({})).provenance);
        // A field named like a fixed column is refused too.
        let fixed = store
            .insert(&row(5, serde_json::json!({ "git_commit": "x" })))
            .err()
            .map(|e| match e {
                CliError::Input(m) | CliError::Interrupted(m) => m,
                CliError::Other(e) => e.to_string(),
            });
        assert!(fixed.is_some_and(|m| m.contains("column of every result store")));
        // A field named like a varied key is refused, not stored under the key's column.
        let e = store
            .insert(&row(4, serde_json::json!({ "robots.0.count": 1 })))
            .err()
            .map(|e| match e {
                CliError::Input(m) | CliError::Interrupted(m) => m,
                CliError::Other(e) => e.to_string(),
            });
        assert!(e.is_some_and(|m| m.contains("has the name of a varied key")));
        drop(store);
        let _ = std::fs::remove_dir_all(&dir);
    }
}
