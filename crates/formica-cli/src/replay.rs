//! Replaying a stored trial: `formica run`, `serve` and `record` with `--db STUDY.db --trial N`
//! rebuild trial N of a result store from the scenario and seed it ran with, and check that it
//! ends as stored. Runs are deterministic, so a replay by a build of the same results format
//! reproduces every stored metric bit for bit.
//!
//! The scenario comes from the store's `scenarios` table (each parameter set's scenario as run,
//! kept by `formica sweep`), or, for stores made before it was kept, from the sweep file named
//! in the store's `meta` (which must still hold the same sweep).

use crate::provenance::Provenance;
use crate::store::{Store, StoredTrial};
use crate::sweep::Sweep;
use crate::CliError;
use formica::{Overrides, RunResult, Scenario};
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

/// One stored trial, ready to run again.
pub struct Replay {
    /// Its grid index.
    pub trial: usize,
    /// The scenario it ran (every override applied).
    pub scenario: Scenario,
    /// Its seed.
    pub seed: u64,
    /// What the store holds for it.
    pub stored: StoredTrial,
    /// The store's columns of end-of-run fields (loop functions' `extra`).
    pub columns: BTreeSet<String>,
}

impl Replay {
    /// The overrides that make a run of [`Replay::scenario`] this trial.
    pub fn overrides(&self) -> Overrides {
        Overrides {
            seed: Some(self.seed),
            ..Overrides::default()
        }
    }

    /// How `got` differs from the stored result (every field but the wall-clock time, as
    /// `field: stored, replayed`); empty when the replay reproduced it.
    ///
    /// End-of-run fields the store has no column for (added after it was written) are left
    /// out; [`Replay::not_compared`] names them.
    pub fn differences(&self, got: &RunResult) -> Vec<String> {
        formica::experiment::replay_differences(&self.stored.result, got, &self.columns)
    }

    /// `got`'s end-of-run fields that the store cannot hold, so a replay does not compare them:
    /// ` (not in the store, not compared: cavity_centres)`, or empty.
    pub fn not_compared(&self, got: &RunResult) -> String {
        let unstored =
            formica::experiment::unstored_fields(&self.stored.result, got, &self.columns);
        if unstored.is_empty() {
            String::new()
        } else {
            format!(" (not in the store, not compared: {})", unstored.join(", "))
        }
    }

    /// `wall after 83.4 s (834 ticks)`: the stored outcome, for messages.
    pub fn stored_outcome(&self) -> String {
        outcome_text(&self.stored.result)
    }
}

/// `success after 83.4 s (834 ticks)`.
pub fn outcome_text(r: &RunResult) -> String {
    format!(
        "{} after {:.1} s ({} ticks)",
        r.outcome.name(),
        r.sim_time_s,
        r.ticks
    )
}

/// How a store is named in messages and reports: its file name only, never a folder of the
/// machine it is on.
pub fn store_name(db: &Path) -> String {
    db.file_name().map_or_else(
        || db.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    )
}

/// The command that replays `trial` of the store `db_shown` in the viewer (named after this
/// program: `formica`, or a program built on [`crate::main_with`]).
pub fn serve_command(db_shown: &str, trial: usize) -> String {
    format!("{} serve --db {db_shown} --trial {trial}", crate::program())
}

/// Opens trials of one store for replay (the sweep file, if needed, is read once).
pub struct Replayer {
    store: Store,
    db: PathBuf,
    sweep: Option<Sweep>,
}

impl Replayer {
    /// Opens an existing store.
    pub fn open(db: &Path) -> Result<Replayer, CliError> {
        Ok(Replayer {
            store: Store::open_existing(db)?,
            db: db.to_path_buf(),
            sweep: None,
        })
    }

    /// Trial `trial`, or an input error naming the trials the store holds.
    pub fn trial(&mut self, trial: usize) -> Result<Replay, CliError> {
        let Some(stored) = self.store.trial(trial)? else {
            let (lo, hi, n): (Option<i64>, Option<i64>, i64) = self
                .store
                .conn
                .query_row(
                    "SELECT MIN(trial), MAX(trial), COUNT(*) FROM trials",
                    [],
                    |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?)),
                )
                .map_err(|e| CliError::Other(anyhow::Error::new(e).context("reading trials")))?;
            return Err(CliError::Input(match (lo, hi) {
                (Some(lo), Some(hi)) => format!(
                    "--trial {trial}: {} holds no such trial ({n} trials, numbered {lo} to {hi})",
                    store_name(&self.db)
                ),
                _ => format!("--trial: {} holds no trials yet", store_name(&self.db)),
            }));
        };
        let scenario = self.scenario_of(&stored)?;
        Ok(Replay {
            trial,
            seed: stored.result.seed,
            scenario,
            stored,
            columns: self.store.extra_columns()?.into_iter().collect(),
        })
    }

    /// Every stored trial number, in grid order.
    pub fn trial_numbers(&self) -> Result<Vec<usize>, CliError> {
        Ok(self.store.results()?.iter().map(|t| t.trial).collect())
    }

    fn scenario_of(&mut self, t: &StoredTrial) -> Result<Scenario, CliError> {
        let want = &t.provenance.scenario_sha256;
        let name = store_name(&self.db);
        let sc = match self.store.scenario(want)? {
            Some((file, toml)) if !want.is_empty() => {
                // Positions are in the stored text (the file with the trial's overrides), not
                // in the file on disk: say so in the place.
                Scenario::parse(&toml, &file).map_err(|mut e| {
                    if let formica::ScenarioError::Invalid { file: at, .. } = &mut e {
                        *at = format!("{file} as stored in {name}");
                    }
                    CliError::Input(format!(
                        "{name}: trial {}'s stored scenario does not parse with this program: {e} \
                         (a store written by a program with its own controllers or models is \
                         replayed with that program: a Rust one such as examples/custom-controller's \
                         formica-phototaxis, or, for controllers registered from Python, Python \
                         with them registered: formica.cli(\"run\", \"--db\", {:?}, \
                         \"--trial\", \"{}\"); otherwise the store is from another Formica)",
                        t.trial,
                        self.db.display().to_string(),
                        t.trial
                    ))
                })?
            }
            _ => self.scenario_from_sweep_file(t)?,
        };
        if !want.is_empty() {
            let got = crate::provenance::scenario_sha256(&sc, &Overrides::default());
            if &got != want {
                return Err(CliError::Input(format!(
                    "{name}: trial {} ran scenario {want}, but it rebuilds as {got}; it cannot be replayed exactly",
                    t.trial
                )));
            }
        }
        Ok(sc)
    }

    /// A trial's scenario from the sweep file the store was made from.
    fn scenario_from_sweep_file(&mut self, t: &StoredTrial) -> Result<Scenario, CliError> {
        let name = store_name(&self.db);
        if self.sweep.is_none() {
            let file = self.store.meta("sweep")?.ok_or_else(|| {
                CliError::Input(format!(
                    "{name}: the store names no sweep file and keeps no scenarios; it cannot be replayed"
                ))
            })?;
            let given = PathBuf::from(&file);
            let beside = self
                .db
                .parent()
                .map(|d| d.join(&given))
                .filter(|p| p.is_file());
            let path = if given.is_file() {
                given
            } else if let Some(p) = beside {
                p
            } else {
                return Err(CliError::Input(format!(
                    "{name}: keeps no scenarios (made before they were kept), and its sweep file `{file}` is not found here or beside the store"
                )));
            };
            let sweep = Sweep::load(&path)?;
            if self.store.meta("digest")?.as_deref() != Some(sweep.digest.as_str()) {
                return Err(CliError::Input(format!(
                    "{name}: the sweep file `{file}` has changed since the store was made; its trials cannot be rebuilt from it"
                )));
            }
            self.sweep = Some(sweep);
        }
        let sweep = self
            .sweep
            .as_ref()
            .ok_or_else(|| CliError::Other(anyhow::anyhow!("sweep file not loaded")))?;
        sweep
            .sets
            .iter()
            .find(|s| s.key == t.params_json)
            .map(|s| s.scenario.clone())
            .ok_or_else(|| {
                CliError::Input(format!(
                    "{name}: trial {}'s parameter set {} is not in the sweep file any more",
                    t.trial, t.params_json
                ))
            })
    }
}

/// The provenance a replay of `r` by this build has.
pub fn provenance_of(r: &Replay) -> Provenance {
    Provenance::of(&r.scenario, &r.overrides())
}

/// Parses `--trial` of `formica run`: `N`, `A..B` (inclusive) or `all`; `None` for all.
pub fn parse_trials(s: &str) -> Result<Option<std::ops::RangeInclusive<usize>>, CliError> {
    let s = s.trim();
    if s == "all" {
        return Ok(None);
    }
    let bad = || CliError::Input(format!("--trial: expected N, A..B or all, got `{s}`"));
    if let Some((a, b)) = s.split_once("..") {
        let a: usize = a.trim().parse().map_err(|_| bad())?;
        let b: usize = b
            .trim()
            .trim_start_matches('=')
            .parse()
            .map_err(|_| bad())?;
        return if a <= b { Ok(Some(a..=b)) } else { Err(bad()) };
    }
    let n: usize = s.parse().map_err(|_| bad())?;
    Ok(Some(n..=n))
}
