//! The parts of `formica report`'s `summary.md` that explain a study: its provenance (which
//! builds wrote the store, from which sweep), and its failed trials, per parameter set, each with
//! the command that replays it and, for the first few, a picture of how it ended (the gallery,
//! drawn by replaying the trial).

use crate::provenance::short;
use crate::replay::{self, Replayer};
use crate::store::{Store, StoredTrial};
use crate::CliError;
use anyhow::Context;
use formica::experiment::{Run, RunOptions};
use formica::geometry::Vec2;
use formica::Outcome;
use rayon::prelude::*;
use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::Path;

/// Width of a gallery picture (px).
pub const PICTURE_WIDTH: u32 = 320;

/// A path for a report: as given if relative; if absolute, relative to the working directory
/// when it lies inside it, else the file name only (never a folder of the machine the report
/// was made on).
pub fn shown_path(p: &str) -> String {
    shown_path_from(p, std::env::current_dir().ok().as_deref())
}

/// [`shown_path`] with the working directory `cwd`.
fn shown_path_from(p: &str, cwd: Option<&Path>) -> String {
    let path = Path::new(p);
    if !path.is_absolute() {
        return p.replace('\\', "/");
    }
    if let Some(rest) = cwd.and_then(|c| path.strip_prefix(c).ok()) {
        if !rest.as_os_str().is_empty() {
            return rest.to_string_lossy().replace('\\', "/");
        }
    }
    path.file_name()
        .map_or_else(|| p.to_string(), |n| n.to_string_lossy().into_owned())
}

/// The digest of the scenarios of `rows` (a store's trials in trial order): SHA-256 over each
/// parameter set's `scenario_sha256`, one line each, in the order of the sets' first trials.
/// For a store that holds every set of its sweep this is the digest `formica sweep` records;
/// unlike that record, it follows a sweep file that gained parameter sets after the store was
/// begun. `None` if no trial records its scenario (a store from before provenance).
fn scenarios_digest(rows: &[StoredTrial]) -> Option<String> {
    let mut seen = std::collections::HashSet::new();
    let shas: Vec<&str> = rows
        .iter()
        .filter(|r| seen.insert(r.params_json.as_str()))
        .map(|r| r.provenance.scenario_sha256.as_str())
        .collect();
    shas.iter()
        .any(|s| !s.is_empty())
        .then(|| crate::provenance::sha256_hex(shas.join("\n").as_bytes()))
}

/// The `## Provenance` section of the report written to `out` with `options` (the report's
/// options that are not their defaults, as typed), for the store's trials `rows`.
pub fn provenance_section(
    store: &Store,
    rows: &[StoredTrial],
    db: &Path,
    out: &Path,
    options: &str,
) -> Result<String, CliError> {
    let mut md = String::from("## Provenance\n\n");
    let name = replay::store_name(db);
    let sweep = store.meta("sweep")?.map(|s| shown_path(&s));
    if let Some(s) = &sweep {
        let _ = writeln!(
            md,
            "Made by `{program} sweep {s} --db {name}`, then `{program} report {name} --out {}{options}`.\n",
            shown_path(&out.display().to_string()),
            program = crate::program()
        );
    }
    let writers = store.writers()?;
    if writers.is_empty() {
        md.push_str("The store records no provenance: it was made by a Formica older than provenance records.\n\n");
    } else {
        let formats: Vec<u32> = writers.iter().map(|w| w.results_format).collect();
        let mixed = formats.iter().any(|f| *f != formats[0]);
        let _ = writeln!(
            md,
            "Written by {} ({}):\n",
            if writers.len() == 1 {
                "one build".to_string()
            } else {
                format!("{} builds", writers.len())
            },
            if mixed {
                "MIXED results formats: trials of different formats may not be comparable"
            } else {
                "one results format"
            }
        );
        for w in &writers {
            let _ = writeln!(md, "- Formica {}", w.describe());
        }
        md.push('\n');
    }
    let digest = match scenarios_digest(rows) {
        Some(d) => Some(d),
        None => store.meta("scenario_sha256")?,
    };
    if let Some(d) = digest {
        let _ = writeln!(
            md,
            "Scenarios: SHA-256 `{}` over the canonical scenario of every parameter set (each trial's own is in the `scenario_sha256` column).\n",
            short_digest(&d)
        );
    }
    // Rows per build, as each row records it.
    let mut st = store
        .conn
        .prepare(
            "SELECT COALESCE(formica_version, ''), COALESCE(git_commit, ''), COALESCE(platform, ''), COUNT(*)
             FROM trials GROUP BY 1, 2, 3 ORDER BY 4 DESC",
        )
        .context("reading provenance")?;
    let rows = st
        .query_map([], |r| {
            Ok((
                r.get::<_, String>(0)?,
                r.get::<_, String>(1)?,
                r.get::<_, String>(2)?,
                r.get::<_, i64>(3)?,
            ))
        })
        .context("reading provenance")?;
    let mut lines = Vec::new();
    for r in rows {
        let (v, c, p, n) = r.context("reading provenance")?;
        lines.push(if v.is_empty() {
            format!("{n} trials record no build")
        } else {
            format!("{n} trials by {v} (commit {}, {p})", short(&c))
        });
    }
    if !lines.is_empty() {
        let _ = writeln!(md, "Rows: {}.\n", lines.join("; "));
    }
    Ok(md)
}

fn short_digest(d: &str) -> &str {
    d.get(..16).unwrap_or(d)
}

/// One failed trial in the report.
struct Failed<'a> {
    row: &'a StoredTrial,
    picture: Option<Result<String, String>>,
}

/// Removes from `folder` the pictures a report draws (`trial-N.png`) whose trial is not in
/// `keep`; any other file is left alone, and a missing folder is nothing to do.
fn prune_pictures(folder: &Path, keep: &[usize]) -> Result<(), CliError> {
    let entries = match std::fs::read_dir(folder) {
        Ok(entries) => entries,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(()),
        Err(e) => return Err(anyhow::anyhow!("reading {}: {e}", folder.display()).into()),
    };
    for entry in entries {
        let entry = entry.with_context(|| format!("reading {}", folder.display()))?;
        let file = entry.file_name();
        let Some(trial) = file
            .to_str()
            .and_then(|f| f.strip_prefix("trial-")?.strip_suffix(".png"))
            .and_then(|n| n.parse::<usize>().ok())
        else {
            continue;
        };
        if !keep.contains(&trial) {
            let path = entry.path();
            std::fs::remove_file(&path).with_context(|| format!("removing {}", path.display()))?;
        }
    }
    Ok(())
}

/// Which trials a [`trials_section`] lists.
#[derive(Clone, Copy, PartialEq, Eq)]
pub enum Listed {
    /// `## Failed trials`: the trials that did not succeed (pictures in `failures/`).
    Failed,
    /// `## Trials without a success rule`: how each trial of a set with no success rule
    /// (static filling) ended (pictures in `endings/`).
    Unjudged,
}

/// The `## Failed trials` section ([`Listed::Failed`]: of `rows`, those that did not succeed),
/// or the `## Trials without a success rule` section ([`Listed::Unjudged`]: every one of
/// `rows`): per parameter set (labelled by `set_label`), up to `list` trials with their replay
/// command, and pictures of the first `gallery` of them.
#[expect(
    clippy::too_many_arguments,
    reason = "two calls, each argument named at the call"
)]
pub fn trials_section(
    listed: Listed,
    db: &Path,
    rows: &[StoredTrial],
    sets: &[String],
    set_label: &dyn Fn(&StoredTrial) -> String,
    dir: &Path,
    list: usize,
    gallery: usize,
) -> Result<String, CliError> {
    let failed: Vec<&StoredTrial> = rows
        .iter()
        .filter(|r| r.result.outcome != Outcome::Success)
        .collect();
    let (heading, folder, verb, word) = match listed {
        Listed::Failed => ("Failed trials", "failures", "did not succeed", "failed"),
        Listed::Unjudged => (
            "Trials without a success rule",
            "endings",
            "have no success rule (their filling columns above judge them)",
            "trials",
        ),
    };
    let mut md = format!("## {heading}\n\n");
    let name = replay::store_name(db);
    let program = crate::program();
    let mut failed_in: HashMap<&str, Vec<&StoredTrial>> = HashMap::new();
    for r in &failed {
        failed_in.entry(r.params_json.as_str()).or_default().push(r);
    }
    let none: Vec<&StoredTrial> = Vec::new();
    let failed_of = |s: &String| failed_in.get(s.as_str()).unwrap_or(&none);
    // Which trials get a picture.
    let mut wanted: Vec<&StoredTrial> = Vec::new();
    for s in sets {
        wanted.extend(failed_of(s).iter().take(gallery).copied());
    }
    // Pictures an earlier report left in the folder (of another store, or with other gallery
    // settings) would sit beside the new ones unnamed by the summary.
    let keep: Vec<usize> = wanted.iter().map(|r| r.trial).collect();
    prune_pictures(&dir.join(folder), &keep)?;
    if rows.is_empty() {
        md.push_str("None: no trial here has a success rule.\n\n");
        return Ok(md);
    }
    if failed.is_empty() {
        md.push_str("Every trial succeeded.\n\n");
        return Ok(md);
    }
    let pictures = if wanted.is_empty() {
        Vec::new()
    } else {
        draw_pictures(db, &wanted, dir, folder)?
    };
    let _ = writeln!(
        md,
        "{} of {} trials {verb}. Each replays in the viewer with the command shown (run where `{name}` is; `{program} run --db {name} --trial N` replays it headless and checks that it ends as stored).{}\n",
        failed.len(),
        rows.len(),
        if gallery > 0 {
            format!(" Pictures show how the first {gallery} of each parameter set ended (object path in red), drawn by replaying them.")
        } else {
            String::new()
        }
    );
    for s in sets {
        let mine: Vec<Failed> = failed_of(s)
            .iter()
            .map(|r| Failed {
                row: r,
                picture: pictures
                    .iter()
                    .find(|(t, _)| *t == r.trial)
                    .map(|(_, p)| p.clone()),
            })
            .collect();
        if mine.is_empty() {
            continue;
        }
        let count = |o: Outcome| mine.iter().filter(|f| f.row.result.outcome == o).count();
        let kinds: Vec<String> = [Outcome::Wall, Outcome::Timeout]
            .iter()
            .filter(|o| count(**o) > 0)
            .map(|o| format!("{} {}", count(*o), o.name()))
            .collect();
        let _ = writeln!(
            md,
            "### {} ({} {word}: {})\n",
            set_label(mine[0].row),
            mine.len(),
            kinds.join(", ")
        );
        if list > 0 {
            md.push_str("| trial | seed | outcome | replay |\n|---|---|---|---|\n");
        }
        for f in mine.iter().take(list) {
            let r = &f.row.result;
            let _ = writeln!(
                md,
                "| {} | {} | {} | `{}` |",
                f.row.trial,
                r.seed,
                replay::outcome_text(r),
                replay::serve_command(&name, f.row.trial)
            );
        }
        if mine.len() > list {
            let _ = writeln!(
                md,
                "\n{} more not listed (`{program} export {name} --csv -` lists every trial).",
                mine.len() - list
            );
        }
        md.push('\n');
        let mut pics = Vec::new();
        for f in &mine {
            match &f.picture {
                Some(Ok(file)) => pics.push(format!(
                    "[![trial {}: {}]({file})]({file})",
                    f.row.trial,
                    replay::outcome_text(&f.row.result)
                )),
                Some(Err(why)) => {
                    let _ = writeln!(md, "Trial {}: no picture ({why}).\n", f.row.trial);
                }
                None => {}
            }
        }
        if !pics.is_empty() {
            let _ = writeln!(md, "{}\n", pics.join(" "));
        }
    }
    Ok(md)
}

/// A gallery picture: the trial, and the picture's file (relative to the report) or why there
/// is none.
type Picture = (usize, Result<String, String>);

/// Replays `trials` (in parallel) and draws each one's end into `dir/folder`: `(trial,
/// Ok(file relative to `dir`) or Err(why not))`. A replay that does not end as stored is drawn
/// all the same, and said so.
fn draw_pictures(
    db: &Path,
    trials: &[&StoredTrial],
    dir: &Path,
    folder: &str,
) -> Result<Vec<Picture>, CliError> {
    let out = &dir.join(folder);
    let mut replayer = Replayer::open(db)?;
    let mut replays = Vec::new();
    let mut results = Vec::new();
    for t in trials {
        match replayer.trial(t.trial) {
            Ok(r) => replays.push(r),
            Err(e) => {
                let why = match e {
                    CliError::Input(m) | CliError::Interrupted(m) => m,
                    CliError::Other(e) => format!("{e:#}"),
                };
                results.push((t.trial, Err(why)));
            }
        }
    }
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let drawn: Vec<Picture> = replays
        .par_iter()
        .with_max_len(1)
        .map(|r| {
            let run = || -> Result<String, String> {
                let opts = RunOptions {
                    overrides: r.overrides(),
                    record: true,
                    robot_every: u64::MAX,
                    // One world per task.
                    threads: 1,
                };
                let mut run = Run::new(&r.scenario, &opts).map_err(|e| e.to_string())?;
                run.run_to_end();
                let diffs = r.differences(&run.result());
                let path: Vec<Vec2> = run
                    .trajectories()
                    .map(|tr| tr.object.iter().map(|s| Vec2::new(s.x, s.y)).collect())
                    .unwrap_or_default();
                let overlay = formica_render::Overlay {
                    path: &path,
                    goal_radius: run.goal_radius(),
                };
                let file = format!("trial-{}.png", r.trial);
                formica_render::save_png(&run.world, PICTURE_WIDTH, &overlay, &out.join(&file))?;
                if diffs.is_empty() {
                    Ok(format!("{folder}/{file}"))
                } else {
                    Err(format!(
                        "its replay did not end as stored: {}",
                        diffs.join("; ")
                    ))
                }
            };
            (r.trial, run())
        })
        .collect();
    results.extend(drawn);
    Ok(results)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn report_paths_never_name_a_folder_outside_the_working_directory() {
        let cwd = std::env::temp_dir().join("formica-study");
        let inside = cwd.join("results").join("u");
        let outside = std::env::temp_dir().join("elsewhere").join("u");
        let show = |p: &Path| shown_path_from(&p.display().to_string(), Some(&cwd));
        assert_eq!(show(&inside), "results/u");
        assert_eq!(show(&outside), "u");
        assert_eq!(shown_path_from("results/u", Some(&cwd)), "results/u");
        assert_eq!(shown_path_from("results\\u", None), "results/u");
    }
}
