//! Explaining trials and saying where results come from: stored trials replay exactly, reports
//! list failed trials with a gallery, videos record, and every result carries its provenance.

use std::path::{Path, PathBuf};

mod common;
use common::{formica, ok, repo};

fn tmp(name: &str) -> PathBuf {
    common::tmp("replay", name)
}

/// The smoke study's store (24 trials, trajectories on), made once per test that needs it.
fn smoke_store(dir: &Path) -> PathBuf {
    let db = dir.join("smoke.db");
    ok(formica()
        .arg("sweep")
        .arg(repo("experiments/smoke.toml"))
        .arg("--db")
        .arg(&db)
        .arg("--quiet")
        .output()
        .unwrap());
    db
}

fn conn(db: &Path) -> rusqlite::Connection {
    rusqlite::Connection::open(db).unwrap()
}

const PROVENANCE: [&str; 4] = [
    "formica_version",
    "git_commit",
    "scenario_sha256",
    "platform",
];

#[test]
fn record_and_report_never_write_over_the_store_they_read() {
    let dir = tmp("overwrite");
    let db = smoke_store(&dir);
    let size = std::fs::metadata(&db).unwrap().len();
    // `record --out` naming the store itself (through a link ending in .gif).
    let link = dir.join("store.gif");
    let _ = std::fs::remove_file(&link);
    #[cfg(unix)]
    std::os::unix::fs::symlink(&db, &link).unwrap();
    #[cfg(unix)]
    {
        let out = formica()
            .arg("record")
            .arg("--db")
            .arg(&db)
            .args(["--trial", "0", "--max-frames", "3", "--out"])
            .arg(&link)
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(2));
        assert!(String::from_utf8_lossy(&out.stderr).contains("writing it would destroy it"));
    }
    // A store named trials.csv in the report's folder.
    let rx = dir.join("rx");
    std::fs::create_dir_all(&rx).unwrap();
    let inside = rx.join("trials.csv");
    std::fs::copy(&db, &inside).unwrap();
    let out = formica()
        .arg("report")
        .arg(&inside)
        .arg("--out")
        .arg(&rx)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert_eq!(std::fs::metadata(&inside).unwrap().len(), size);
    assert_eq!(std::fs::metadata(&db).unwrap().len(), size);
    // `export` with one file for both CSVs (the trajectories would replace the trials).
    let out = formica()
        .arg("export")
        .arg(&db)
        .arg("--csv")
        .arg(dir.join("x.csv"))
        .arg("--trajectories")
        .arg(dir.join(".").join("x.csv"))
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    // `merge` with an input that is no store leaves no output store behind.
    let text = dir.join("text.db");
    std::fs::write(&text, "hello\n").unwrap();
    let merged = dir.join("merged.db");
    let _ = std::fs::remove_file(&merged);
    let out = formica()
        .arg("merge")
        .arg(&merged)
        .arg(&db)
        .arg(&text)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(!merged.exists());
    // A store whose name begins `file:` is that file, not an SQLite URI naming another.
    let odd = dir.join("file:odd.db");
    std::fs::copy(&db, &odd).unwrap();
    let _ = std::fs::remove_file(&merged);
    let out = formica()
        .current_dir(&dir)
        .arg("merge")
        .arg("merged.db")
        .arg("file:odd.db")
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(0));
    assert!(String::from_utf8_lossy(&out.stdout).contains("24 new"));
    assert!(!dir.join("odd.db").exists());
    // `--trial` without `--db` is refused, not ignored.
    let out = formica()
        .arg("run")
        .arg(repo("scenarios/seed-transport.toml"))
        .args(["--trial", "3"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
}

#[test]
fn every_smoke_trial_replays_to_its_stored_outcome_and_time_exactly() {
    let dir = tmp("smoke");
    let db = smoke_store(&dir);
    let out = ok(formica()
        .args(["run", "--json", "--trial", "all", "--db"])
        .arg(&db)
        .output()
        .unwrap());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("replayed 24 trials, 24 end as stored, 0 differ"),
        "{stderr}"
    );
    // Independently of the command's own check: outcome, time and ticks equal the stored row's,
    // bit for bit.
    let c = conn(&db);
    let mut stored = c
        .prepare("SELECT seed, outcome, sim_time_s, ticks FROM trials ORDER BY trial")
        .unwrap();
    let stored: Vec<(u64, String, f64, u64)> = stored
        .query_map([], |r| {
            Ok((
                r.get::<_, i64>(0)? as u64,
                r.get(1)?,
                r.get(2)?,
                r.get::<_, i64>(3)? as u64,
            ))
        })
        .unwrap()
        .map(Result::unwrap)
        .collect();
    let replayed: Vec<serde_json::Value> = String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(replayed.len(), 24);
    assert_eq!(stored.len(), 24);
    let mut outcomes = std::collections::BTreeSet::new();
    for ((seed, outcome, time, ticks), r) in stored.iter().zip(&replayed) {
        assert_eq!(r["seed"].as_u64(), Some(*seed));
        assert_eq!(r["outcome"].as_str(), Some(outcome.as_str()), "seed {seed}");
        assert_eq!(
            r["sim_time_s"].as_f64().map(f64::to_bits),
            Some(time.to_bits()),
            "seed {seed}"
        );
        assert_eq!(r["ticks"].as_u64(), Some(*ticks), "seed {seed}");
        outcomes.insert(outcome.clone());
    }
    assert!(
        outcomes.len() >= 2,
        "the smoke study ends in more than one way: {outcomes:?}"
    );

    // One trial with --out: its files, the time series included, and the check on stdout.
    let out_dir = dir.join("trial-3");
    let out = ok(formica()
        .args(["run", "--trial", "3", "--out"])
        .arg(&out_dir)
        .arg("--db")
        .arg(&db)
        .output()
        .unwrap());
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains("replay of trial 3 (seed 4) ends as stored"),
        "{text}"
    );
    let csv = std::fs::read_to_string(out_dir.join("timeseries.csv")).unwrap();
    let mut lines = csv.lines();
    let header = lines.next().unwrap();
    assert!(
        header.starts_with("t_s,goal_distance_m,object_speed_m_s,robots_"),
        "{header}"
    );
    assert!(lines.count() > 100);

    // The sweep stored every trial's time series too (trajectories are on in smoke.toml).
    let n: i64 = c
        .query_row("SELECT COUNT(*) FROM timeseries", [], |r| r.get(0))
        .unwrap();
    assert_eq!(n, 24);
    let series: String = c
        .query_row("SELECT series FROM timeseries LIMIT 1", [], |r| r.get(0))
        .unwrap();
    let series: serde_json::Value = serde_json::from_str(&series).unwrap();
    assert!(series["t_s"].as_array().is_some_and(|t| t.len() > 50));
    assert!(series["states"].as_array().is_some_and(|s| !s.is_empty()));

    // Bad trial numbers are input errors.
    for bad in ["99", "x", "5..2"] {
        let o = formica()
            .args(["run", "--trial", bad, "--db"])
            .arg(&db)
            .output()
            .unwrap();
        assert_eq!(o.status.code(), Some(2), "--trial {bad}");
    }
    let o = formica()
        .args(["run", "--trial", "1", "--db"])
        .arg(dir.join("missing.db"))
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
}

#[test]
fn a_replay_that_differs_from_the_store_fails() {
    let dir = tmp("differs");
    let db = smoke_store(&dir);
    conn(&db)
        .execute(
            "UPDATE trials SET sim_time_s = sim_time_s + 0.1 WHERE trial = 2",
            [],
        )
        .unwrap();
    let o = formica()
        .args(["run", "--trial", "2", "--db"])
        .arg(&db)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("does NOT end as stored"), "{text}");
    assert!(text.contains("sim_time_s"), "{text}");
}

#[test]
fn a_store_of_a_controller_this_program_lacks_says_where_to_replay_it() {
    // As a store written through Python with a controller registered there reads to the
    // command line: the stored scenario names a controller it does not know.
    let dir = tmp("lacks");
    let db = smoke_store(&dir);
    conn(&db)
        .execute(
            "UPDATE scenarios SET toml = replace(toml, '\"occlusion\"', '\"py-mine\"')",
            [],
        )
        .unwrap();
    let o = formica()
        .args(["run", "--trial", "0", "--db"])
        .arg(&db)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    // The store as given (here a full path), so that the call works from where it was run.
    let call = format!(
        "formica.cli(\"run\", \"--db\", {:?}, \"--trial\", \"0\")",
        db.display().to_string()
    );
    assert!(
        err.contains("as stored in smoke.db:")
            && err.contains("unknown controller `py-mine`")
            && err.contains(&call),
        "{err}"
    );
}

#[test]
fn report_lists_failed_trials_with_replay_commands_and_a_gallery() {
    let dir = tmp("report");
    let db = smoke_store(&dir);
    let out_dir = dir.join("report");
    // A folder that held an earlier report: its picture of a trial this store does not have
    // goes, a file of the user's stays.
    std::fs::create_dir_all(out_dir.join("failures")).unwrap();
    std::fs::write(out_dir.join("failures/trial-9999.png"), b"old").unwrap();
    std::fs::write(out_dir.join("failures/notes.txt"), b"mine").unwrap();
    ok(formica()
        .arg("report")
        .arg(&db)
        .arg("--out")
        .arg(&out_dir)
        .output()
        .unwrap());
    let md = std::fs::read_to_string(out_dir.join("summary.md")).unwrap();
    assert!(md.contains("## Failed trials"), "{md}");
    assert!(md.contains("`formica serve --db smoke.db --trial "), "{md}");
    assert!(!out_dir.join("failures/trial-9999.png").exists());
    assert_eq!(
        std::fs::read(out_dir.join("failures/notes.txt")).unwrap(),
        b"mine"
    );
    // Pictures of at most 3 failed trials per parameter set, each linked from the summary.
    let pictures: Vec<String> = std::fs::read_dir(out_dir.join("failures"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|f| f.ends_with(".png"))
        .collect();
    assert!(!pictures.is_empty());
    assert!(pictures.len() <= 4 * 3);
    for p in &pictures {
        assert!(md.contains(&format!("](failures/{p})")), "{p} not linked");
        let bytes = std::fs::read(out_dir.join("failures").join(p)).unwrap();
        assert!(bytes.starts_with(b"\x89PNG"));
    }
    // Provenance, and no path of this machine.
    assert!(md.contains("## Provenance"), "{md}");
    assert!(md.contains("--out report`."), "{md}");
    assert!(
        md.contains(&format!(
            "results format {}",
            formica::experiment::RESULTS_FORMAT
        )),
        "{md}"
    );
    let tmp_dir = std::env::temp_dir().display().to_string();
    assert!(
        !md.contains(&tmp_dir),
        "the summary names a machine path:\n{md}"
    );
    assert!(md.starts_with("# smoke\n\n24 trials in `smoke.db`"), "{md}");
}

#[test]
fn record_writes_an_mp4_video_of_a_stored_trial() {
    let dir = tmp("video");
    let db = smoke_store(&dir);
    let out = dir.join("trial-3.mp4");
    let o = ok(formica()
        .args(["record", "--trial", "3", "--width", "320", "--out"])
        .arg(&out)
        .arg("--db")
        .arg(&db)
        .output()
        .unwrap());
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("trial 3 (seed 4) ends as stored"), "{text}");
    let bytes = std::fs::read(&out).unwrap();
    assert_eq!(&bytes[4..8], b"ftyp");
    assert!(bytes.windows(4).any(|w| w == b"avc1"));
    assert!(bytes.windows(4).any(|w| w == b"moov"));
}

#[test]
fn json_lines_result_json_and_store_rows_carry_provenance() {
    let dir = tmp("provenance");
    let o = ok(formica()
        .args(["run", "--json", "--duration", "2", "--out"])
        .arg(dir.join("one"))
        .arg(repo("scenarios/seed-transport.toml"))
        .output()
        .unwrap());
    let line: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let file: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("one/result.json")).unwrap())
            .unwrap();
    for v in [&line, &file] {
        for k in PROVENANCE {
            assert!(
                v[k].as_str().is_some_and(|s| !s.is_empty()),
                "{k} missing: {v}"
            );
        }
        assert_eq!(v["formica_version"], env!("CARGO_PKG_VERSION"));
        assert_eq!(v["scenario_sha256"].as_str().map(str::len), Some(64));
    }
    // --seeds: every line too.
    let o = ok(formica()
        .args(["run", "--json", "--duration", "1", "--seeds", "1..2"])
        .arg(repo("scenarios/seed-transport.toml"))
        .output()
        .unwrap());
    let lines: Vec<serde_json::Value> = String::from_utf8_lossy(&o.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert!(lines[..2].iter().all(|v| v["git_commit"].is_string()));
    // Another duration is another scenario.
    assert_ne!(lines[0]["scenario_sha256"], line["scenario_sha256"]);

    // A store row and the store's meta.
    let db = smoke_store(&dir);
    let c = conn(&db);
    let row: Vec<String> = c
        .query_row(
            "SELECT formica_version, git_commit, scenario_sha256, platform FROM trials LIMIT 1",
            [],
            |r| (0..4).map(|i| r.get(i)).collect(),
        )
        .unwrap();
    assert!(row.iter().all(|v| !v.is_empty()), "{row:?}");
    assert_eq!(row[0], env!("CARGO_PKG_VERSION"));
    for k in PROVENANCE.iter().chain(&["results_format", "writers"]) {
        let v: String = c
            .query_row("SELECT value FROM meta WHERE key = ?1", [k], |r| r.get(0))
            .unwrap_or_else(|e| panic!("meta {k}: {e}"));
        assert!(!v.is_empty(), "meta {k}");
    }
    // Each parameter set's scenario is kept, under the digest its rows carry.
    let kept: i64 = c
        .query_row(
            "SELECT COUNT(*) FROM trials t JOIN scenarios s ON s.sha256 = t.scenario_sha256",
            [],
            |r| r.get(0),
        )
        .unwrap();
    assert_eq!(kept, 24);

    // --version names the version and the commit.
    let o = ok(formica().arg("--version").output().unwrap());
    let v = String::from_utf8_lossy(&o.stdout);
    assert!(
        v.starts_with(&format!("formica {} (commit ", env!("CARGO_PKG_VERSION"))),
        "{v}"
    );
    assert_eq!(
        row[1],
        v.split("(commit ")
            .nth(1)
            .unwrap()
            .split(',')
            .next()
            .unwrap()
    );
}

#[test]
fn resuming_a_store_of_another_results_format_is_refused_unless_allow_mixed() {
    let dir = tmp("mixed");
    let sweep_file = repo("experiments/smoke.toml");
    let db = dir.join("smoke.db");
    let sweep = |extra: &[&str]| {
        formica()
            .arg("sweep")
            .arg(&sweep_file)
            .arg("--db")
            .arg(&db)
            .arg("--quiet")
            .args(extra)
            .output()
            .unwrap()
    };
    ok(sweep(&["--limit", "2"]));
    // Pretend an older Formica, whose results can differ, wrote those trials.
    let c = conn(&db);
    c.execute(
        "UPDATE meta SET value = '0' WHERE key = 'results_format'",
        [],
    )
    .unwrap();
    c.execute(
        "UPDATE meta SET value = '[{\"formica_version\":\"0.0.9\",\"git_commit\":\"abc\",\"platform\":\"x\",\"results_format\":0}]' WHERE key = 'writers'",
        [],
    )
    .unwrap();
    drop(c);
    let o = sweep(&["--limit", "2"]);
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("0.0.9 (commit abc, x, results format 0)"),
        "{err}"
    );
    assert!(
        err.contains(&format!(
            "results format {}",
            formica::experiment::RESULTS_FORMAT
        )),
        "{err}"
    );
    assert!(err.contains("--allow-mixed"), "{err}");
    let n: i64 = conn(&db)
        .query_row("SELECT COUNT(*) FROM trials", [], |r| r.get(0))
        .unwrap();
    assert_eq!(n, 2, "nothing was added");

    let o = ok(sweep(&["--limit", "2", "--allow-mixed"]));
    assert!(String::from_utf8_lossy(&o.stdout).contains("ran 2 trials"));
    let writers: String = conn(&db)
        .query_row("SELECT value FROM meta WHERE key = 'writers'", [], |r| {
            r.get(0)
        })
        .unwrap();
    let writers: Vec<serde_json::Value> = serde_json::from_str(&writers).unwrap();
    assert_eq!(writers.len(), 2, "{writers:?}");
    // The report says the store is mixed.
    let out_dir = dir.join("report");
    ok(formica()
        .arg("report")
        .arg(&db)
        .args(["--gallery", "0", "--out"])
        .arg(&out_dir)
        .output()
        .unwrap());
    let md = std::fs::read_to_string(out_dir.join("summary.md")).unwrap();
    assert!(md.contains("MIXED results formats"), "{md}");
    // The report says how to remake it, options included.
    assert!(md.contains("--gallery 0`."), "{md}");
}

#[test]
fn stores_from_before_scenarios_were_kept_replay_from_their_sweep_file() {
    let dir = tmp("old-store");
    let db = smoke_store(&dir);
    // What a store of an older Formica holds: no kept scenarios, no provenance in its rows.
    let c = conn(&db);
    c.execute("DELETE FROM scenarios", []).unwrap();
    c.execute("UPDATE trials SET scenario_sha256 = NULL", [])
        .unwrap();
    drop(c);
    let o = ok(formica()
        .args(["run", "--trial", "0..5", "--db"])
        .arg(&db)
        .output()
        .unwrap());
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        text.contains("replayed 6 trials, 6 end as stored"),
        "{text}"
    );
    // A sweep file that no longer holds the same sweep cannot rebuild its trials.
    let copy = dir.join("smoke.toml");
    let sweep = std::fs::read_to_string(repo("experiments/smoke.toml"))
        .unwrap()
        .replace("duration_s = 120", "duration_s = 121")
        .replace(
            "../scenarios/",
            &format!("{}/", repo("scenarios").display()),
        );
    std::fs::write(&copy, sweep).unwrap();
    conn(&db)
        .execute(
            "UPDATE meta SET value = ?1 WHERE key = 'sweep'",
            [copy.display().to_string()],
        )
        .unwrap();
    let o = formica()
        .args(["run", "--trial", "1", "--db"])
        .arg(&db)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("has changed since the store was made"));
}

#[test]
fn a_store_without_a_later_field_still_replays_and_says_what_it_left_out() {
    let dir = tmp("later-field");
    let sweep = dir.join("fill.toml");
    std::fs::write(
        &sweep,
        format!(
            "name = \"fill\"\nscenario = {:?}\nseeds = \"1..2\"\nduration_s = 20\n",
            repo("scenarios/seed-fill-u.toml").display().to_string()
        ),
    )
    .unwrap();
    let db = dir.join("fill.db");
    let _ = std::fs::remove_file(&db);
    ok(formica()
        .arg("sweep")
        .arg(&sweep)
        .arg("--db")
        .arg(&db)
        .arg("--quiet")
        .output()
        .unwrap());
    let replay = |trial: &str| {
        formica()
            .args(["run", "--trial", trial, "--db"])
            .arg(&db)
            .output()
            .unwrap()
    };
    // A store written before `cavity_centres` existed has no column for it: the replay
    // compares everything else, and says what it did not compare.
    conn(&db)
        .execute("ALTER TABLE trials DROP COLUMN cavity_centres", [])
        .unwrap();
    let o = replay("0");
    assert_eq!(o.status.code(), Some(0));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("ends as stored"), "{text}");
    assert!(
        text.contains("not in the store, not compared: cavity_centres"),
        "{text}"
    );
    // A field the store has a column for but no value is a difference.
    conn(&db)
        .execute("ALTER TABLE trials ADD COLUMN cavity_centres REAL", [])
        .unwrap();
    let o = replay("1");
    assert_eq!(o.status.code(), Some(1));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("cavity_centres: none"), "{text}");
}
