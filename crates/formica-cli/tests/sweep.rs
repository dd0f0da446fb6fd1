//! `formica sweep`, `export`, `merge`, `report` and `slurm` as users call them: an interrupted
//! sweep resumes to the same rows as an uninterrupted one, results do not depend on the thread
//! count or on sharding, and bad sweep files exit with code 2.

use std::path::{Path, PathBuf};
use std::process::Output;
use std::time::{Duration, Instant};

mod common;
use common::{formica, input_error, ok, repo};

fn tmp(name: &str) -> PathBuf {
    common::tmp("sweep", name)
}

/// A small, fast sweep (36 trials of up to 200 simulated seconds) on the seed's transport scenario,
/// scaled down so that objects move and trials end in every way.
fn write_sweep(dir: &Path, seeds: &str) -> PathBuf {
    let base = repo("scenarios/seed-transport.toml");
    let text = format!(
        r#"name = "test-sweep"
scenario = "{}"
seeds = "{seeds}"
duration_s = 200

[set]
"objects.0.mass" = 5.0
"objects.0.floor_mu" = 0.05

[vary]
"robots.0.count" = [6, 12]
"robots.0.controller" = ["occlusion", "random-walk"]
"objects.0.shape" = [{{ box = [0.4, 0.4] }}]
"#,
        base.display().to_string().replace('\\', "/")
    );
    let p = dir.join("sweep.toml");
    std::fs::write(&p, text).unwrap();
    p
}

/// `formica report DB --out DIR --gallery 0`; returns its `summary.md`.
fn report_without_gallery(db: &Path, out_dir: &Path) -> String {
    ok(formica()
        .arg("report")
        .arg(db)
        .arg("--out")
        .arg(out_dir)
        .args(["--gallery", "0"])
        .output()
        .unwrap());
    std::fs::read_to_string(out_dir.join("summary.md")).unwrap()
}

fn sweep(file: &Path, db: &Path, extra: &[&str]) -> Output {
    formica()
        .arg("sweep")
        .arg(file)
        .arg("--db")
        .arg(db)
        .arg("--quiet")
        .args(extra)
        .output()
        .unwrap()
}

/// The CSV export without the wall-clock column (the only one that is not deterministic).
fn rows(db: &Path) -> Vec<String> {
    let out = ok(formica()
        .arg("export")
        .arg(db)
        .args(["--csv", "-"])
        .output()
        .unwrap());
    let text = String::from_utf8(out.stdout).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let wall = header.iter().position(|h| *h == "wall_time_s").unwrap();
    assert_eq!(wall, header.len() - 1, "wall_time_s is the last column");
    std::iter::once(header[..wall].join(","))
        .chain(lines.map(|l| l[..l.rfind(',').unwrap()].to_string()))
        .collect()
}

fn count(db: &Path) -> usize {
    let Ok(conn) =
        rusqlite::Connection::open_with_flags(db, rusqlite::OpenFlags::SQLITE_OPEN_READ_ONLY)
    else {
        return 0;
    };
    let _ = conn.busy_timeout(Duration::from_secs(5));
    conn.query_row("SELECT COUNT(*) FROM trials", [], |r| r.get::<_, i64>(0))
        .map_or(0, |n| n as usize)
}

#[test]
fn killed_sweep_resumes_to_the_rows_of_an_uninterrupted_one() {
    let dir = tmp("resume");
    let file = write_sweep(&dir, "1..9");
    let full = dir.join("full.db");
    ok(sweep(&file, &full, &["--threads", "2"]));
    let reference = rows(&full);
    assert_eq!(reference.len(), 1 + 36, "{reference:#?}");

    // Interrupted: kill -9 once a few trials are stored.
    let killed = dir.join("killed.db");
    let mut child = formica()
        .arg("sweep")
        .arg(&file)
        .arg("--db")
        .arg(&killed)
        .args(["--quiet", "--threads", "1"])
        .spawn()
        .unwrap();
    let start = Instant::now();
    let mut finished_early = false;
    loop {
        if count(&killed) >= 3 {
            break;
        }
        if child.try_wait().unwrap().is_some() {
            finished_early = true;
            break;
        }
        assert!(
            start.elapsed() < Duration::from_secs(120),
            "no rows appeared"
        );
        std::thread::sleep(Duration::from_millis(5));
    }
    child.kill().unwrap(); // SIGKILL on Unix
    child.wait().unwrap();
    let stored = count(&killed);
    assert!(
        !finished_early && (3..36).contains(&stored),
        "the sweep was not killed halfway: {stored} of 36 trials stored"
    );
    // A dry run lists just the missing trials, and leaves the store as it was.
    let before = rows(&killed);
    let out = ok(sweep(&file, &killed, &["--dry-run"]));
    let text = String::from_utf8_lossy(&out.stdout);
    assert_eq!(
        text.lines().filter(|l| l.starts_with("trial ")).count(),
        36 - stored,
        "{text}"
    );
    assert!(
        text.contains(&format!(
            "{stored} already in {}, {} to run",
            killed.display(),
            36 - stored
        )),
        "{text}"
    );
    assert_eq!(rows(&killed), before);
    // ... and refuses a store of another sweep, as the real run would.
    let other = dir.join("other.toml");
    std::fs::write(
        &other,
        std::fs::read_to_string(&file)
            .unwrap()
            .replace("duration_s = 200", "duration_s = 100"),
    )
    .unwrap();
    let out = sweep(&other, &killed, &["--dry-run"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        out.status.code() == Some(2) && err.contains("holds trials of a different sweep"),
        "{err}"
    );
    assert_eq!(rows(&killed), before);
    // Rerun: only the missing trials run, and the rows equal the uninterrupted run's.
    let out = ok(sweep(&file, &killed, &[]));
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains(&format!("ran {} trials", 36 - stored)),
        "{text}"
    );
    assert_eq!(rows(&killed), reference);
    // Running again does nothing.
    let out = ok(sweep(&file, &killed, &[]));
    assert!(String::from_utf8_lossy(&out.stdout).contains("ran 0 trials"));
}

#[test]
fn thread_count_and_shards_do_not_change_results() {
    let dir = tmp("shards");
    let file = write_sweep(&dir, "1..4");
    let one = dir.join("one.db");
    ok(sweep(&file, &one, &["--threads", "1"]));
    let two = dir.join("two.db");
    ok(sweep(&file, &two, &["--threads", "2"]));
    let reference = rows(&one);
    assert_eq!(reference.len(), 1 + 16);
    assert_eq!(rows(&two), reference);

    let mut shards = Vec::new();
    for k in 0..3 {
        let db = dir.join(format!("shard-{k}.db"));
        ok(sweep(
            &file,
            &db,
            &["--shard", &format!("{k}/3"), "--trajectories"],
        ));
        shards.push(db);
    }
    assert_eq!(count(&shards[0]), 6); // trials 0, 3, ..., 15
    let merged = dir.join("merged.db");
    ok(formica()
        .arg("merge")
        .arg(&merged)
        .args(&shards)
        .output()
        .unwrap());
    assert_eq!(rows(&merged), reference);

    // Report: every figure as PNG and SVG, and the summary table.
    let out_dir = dir.join("report");
    ok(formica()
        .arg("report")
        .arg(&merged)
        .arg("--out")
        .arg(&out_dir)
        .output()
        .unwrap());
    for f in [
        "success-robots-0-count",
        "success-robots-0-controller",
        "path-efficiency-robots-0-count",
        "survival",
        "survival-robots-occlusion",
        "survival-robots-random-walk",
        "trajectories",
    ] {
        for ext in ["png", "svg"] {
            let p = out_dir.join(format!("{f}.{ext}"));
            assert!(
                std::fs::metadata(&p).unwrap().len() > 1000,
                "{}",
                p.display()
            );
        }
    }
    let md = std::fs::read_to_string(out_dir.join("summary.md")).unwrap();
    assert!(md.contains("| occlusion | 6 | 4 |"), "{md}");
    // Every trial, as `formica export` writes it, beside the summary that links it.
    assert!(md.contains("[trials.csv](trials.csv)"), "{md}");
    let csv = std::fs::read_to_string(out_dir.join("trials.csv")).unwrap();
    let export = ok(formica()
        .arg("export")
        .arg(&merged)
        .args(["--csv", "-"])
        .output()
        .unwrap());
    assert_eq!(csv, String::from_utf8(export.stdout).unwrap());
    assert_eq!(csv.lines().count(), 1 + count(&merged));
}

/// A sweep file like [`write_sweep`]'s, with `fixed` added to `[set]` and the listed `vary` lines.
fn write_slice(dir: &Path, name: &str, seeds: &str, fixed: &str, vary: &str) -> PathBuf {
    let base = repo("scenarios/seed-transport.toml");
    let text = format!(
        r#"name = "{name}"
scenario = "{}"
seeds = "{seeds}"
duration_s = 60

[set]
"objects.0.mass" = 5.0
"objects.0.floor_mu" = 0.05
{fixed}

[vary]
"robots.0.controller" = ["occlusion", "random-walk"]
{vary}
"#,
        base.display().to_string().replace('\\', "/")
    );
    let p = dir.join(format!("{name}.toml"));
    std::fs::write(&p, text).unwrap();
    p
}

#[test]
fn slices_of_a_design_merge_into_the_designs_store() {
    let dir = tmp("slices");
    // The design varies the swarm size; each slice fixes it in [set], on fewer seeds or more.
    let design = write_slice(&dir, "design", "1..3", "", r#""robots.0.count" = [6, 12]"#);
    let six = write_slice(&dir, "six", "1..2", r#""robots.0.count" = 6"#, "");
    let twelve = write_slice(&dir, "twelve", "1..4", r#""robots.0.count" = 12"#, "");
    // Not a trial of the design: another duration.
    let other = write_slice(&dir, "other", "3..3", r#""robots.0.count" = 6"#, "")
        .to_string_lossy()
        .to_string();
    let other_text = std::fs::read_to_string(&other).unwrap();
    std::fs::write(
        &other,
        other_text.replace("duration_s = 60", "duration_s = 50"),
    )
    .unwrap();

    let direct = dir.join("direct.db");
    ok(sweep(&design, &direct, &["--trajectories"]));
    let mut inputs = Vec::new();
    for f in [&six, &twelve, &PathBuf::from(&other)] {
        let db = f.with_extension("db");
        ok(sweep(f, &db, &["--trajectories"]));
        inputs.push(db);
    }
    let merged = dir.join("merged.db");
    // Stores of other sweeps are refused without --sweep.
    let out = formica()
        .arg("merge")
        .arg(&merged)
        .args(&inputs)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let out = ok(formica()
        .arg("merge")
        .arg(&merged)
        .args(&inputs)
        .arg("--sweep")
        .arg(&design)
        .output()
        .unwrap());
    let text = String::from_utf8_lossy(&out.stdout);
    // six: 2 x 2 taken; twelve: 2 x 3 of its 2 x 4 (seed 4 is not the design's); other: none.
    assert!(
        text.contains("10 of the 12 trials")
            && text.contains("4 stored trial(s) are not trials of it"),
        "{text}"
    );
    // The design's missing trials (seed 3 at N = 6) run; the rest are taken as stored.
    let out = ok(sweep(&design, &merged, &["--trajectories"]));
    assert!(
        String::from_utf8_lossy(&out.stdout).contains("ran 2 trials"),
        "{}",
        String::from_utf8_lossy(&out.stdout)
    );
    assert_eq!(rows(&merged), rows(&direct));
    let traj = |db: &Path| -> i64 {
        rusqlite::Connection::open(db)
            .unwrap()
            .query_row("SELECT COUNT(*) FROM trajectories", [], |r| r.get(0))
            .unwrap()
    };
    assert_eq!(traj(&merged), traj(&direct));
}

#[test]
fn report_splits_curves_by_case_when_two_cases_run_one_controller() {
    let dir = tmp("cases");
    let base = repo("scenarios/seed-transport.toml");
    // Three cases, two of them `occlusion`, over 2 x 2 other values: 12 parameter sets, too many
    // for a curve each, and swarm sizes for the time against swarm size.
    let text = format!(
        r#"name = "cases"
scenario = "{}"
seeds = "1..1"
duration_s = 30

[set]
"objects.0.mass" = 5.0

[[cases]]
label = "chen"
"robots.0.controller" = "occlusion"
"robots.0.params" = {{ spread_s = 0.0 }}

[[cases]]
label = "spread"
"robots.0.controller" = "occlusion"

[[cases]]
label = "walk"
"robots.0.controller" = "random-walk"

[vary]
"robots.0.count" = [6, 12]
"objects.0.floor_mu" = [0.01, 0.05]
"#,
        base.display().to_string().replace('\\', "/")
    );
    let file = dir.join("cases.toml");
    std::fs::write(&file, text).unwrap();
    let db = dir.join("cases.db");
    ok(sweep(&file, &db, &[]));
    let out_dir = dir.join("report");
    let md = report_without_gallery(&db, &out_dir);
    // By controller, "chen" and "spread" would be one curve.
    assert!(md.contains("survival curves, by label"), "{md}");
    let svg = std::fs::read_to_string(out_dir.join("survival.svg")).unwrap();
    for case in ["label = chen", "label = spread", "label = walk"] {
        assert!(svg.contains(case), "{case} not in the survival legend");
    }
}

#[test]
fn trials_a_changed_grid_no_longer_has_keep_their_rows_under_numbers_of_their_own() {
    let dir = tmp("regrid");
    let file = write_sweep(&dir, "1..2");
    let db = dir.join("regrid.db");
    ok(sweep(&file, &db, &["--limit", "4"]));
    // One varied value changed: trials of count 12 are no longer in the grid.
    drop_count_12(&file);
    let out = sweep(&file, &db, &[]);
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    let said = String::from_utf8_lossy(&ok(out).stdout).into_owned();
    let numbers = trial_numbers(&db);
    let mut unique = numbers.clone();
    unique.dedup();
    assert_eq!(numbers, unique, "two trials share a number");
    // The grid's 8 trials, then the ones it dropped (those of the first run with count 12).
    let dropped = numbers.len() - 8;
    assert!(dropped > 0, "{numbers:?}");
    assert_eq!(numbers, (0..numbers.len() as i64).collect::<Vec<_>>());
    assert!(
        err.contains(&format!(
            "{dropped} stored trial(s) belong to parameter sets or seeds this sweep file no longer has"
        )),
        "{err}"
    );
    assert!(
        said.contains(&format!(
            "holds 8 of the grid's 8 trials, and {dropped} of an earlier grid"
        )),
        "{said}"
    );
}

/// Changes [`write_sweep`]'s file so that its swarm sizes are 6 and 9: the trials of 12 robots
/// are no longer in its grid.
fn drop_count_12(file: &Path) {
    let text = std::fs::read_to_string(file)
        .unwrap()
        .replace("[6, 12]", "[6, 9]");
    std::fs::write(file, text).unwrap();
}

/// Every trial number of store `db`, in order.
fn trial_numbers(db: &Path) -> Vec<i64> {
    let conn = rusqlite::Connection::open(db).unwrap();
    let mut st = conn
        .prepare("SELECT trial FROM trials ORDER BY trial")
        .unwrap();
    st.query_map([], |r| r.get(0))
        .unwrap()
        .map(Result::unwrap)
        .collect()
}

#[test]
fn shards_of_a_changed_grid_merge_without_sharing_trial_numbers() {
    let dir = tmp("regrid-shards");
    let file = write_sweep(&dir, "1..2");
    let shards: Vec<PathBuf> = (0..2).map(|k| dir.join(format!("s{k}.db"))).collect();
    let run_shards = || {
        for (k, db) in shards.iter().enumerate() {
            ok(sweep(&file, db, &["--shard", &format!("{k}/2")]));
        }
    };
    run_shards();
    // Each shard keeps its trials of count 12, numbered from 8 in each store.
    drop_count_12(&file);
    run_shards();
    let merged = dir.join("merged.db");
    let out = formica()
        .arg("merge")
        .arg(&merged)
        .args(&shards)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    ok(out);
    let numbers = trial_numbers(&merged);
    assert_eq!(numbers, (0..12).collect::<Vec<_>>(), "{err}");
    assert!(err.contains("2 trial(s) shared a number"), "{err}");
}

#[test]
fn report_leaves_static_filling_out_of_success_rates_and_failures() {
    let dir = tmp("static");
    // A transport case, whose trials can succeed, beside static filling, which has no goal
    // and no `stop.on_filled`: its trials always end by timeout, and are no failures.
    let text = format!(
        r#"name = "static"
seeds = "1..2"
duration_s = 20

[[cases]]
label = "transport"
scenario = "{}"

[[cases]]
label = "static filling"
scenario = "{}"
"#,
        repo("scenarios/seed-transport.toml")
            .display()
            .to_string()
            .replace('\\', "/"),
        repo("scenarios/seed-fill-u-all.toml")
            .display()
            .to_string()
            .replace('\\', "/")
    );
    let file = dir.join("static.toml");
    std::fs::write(&file, text).unwrap();
    let db = dir.join("static.db");
    let out = String::from_utf8_lossy(&ok(sweep(&file, &db, &[])).stdout).into_owned();
    assert!(out.contains("successes of 2,"), "{out}");
    assert!(out.contains("2 with no success rule beside them"), "{out}");
    let md = report_without_gallery(&db, &dir.join("report"));
    assert!(
        md.contains("4 trials in `static.db`, 2 parameter set(s); 2 of them, in 1 parameter set(s), have no success rule"),
        "{md}"
    );
    assert!(md.contains("successes of the other 2"), "{md}");
    let row = md
        .lines()
        .find(|l| l.contains("| static filling |"))
        .expect("a row for the static case");
    assert!(row.contains("| – | no success rule |"), "{row}");
    let after = md.split("## Failed trials").nth(1).unwrap();
    let (failures, endings) = after
        .split_once("## Trials without a success rule")
        .expect("a section for the static trials");
    assert!(!failures.contains("static filling"), "{failures}");
    assert!(
        endings.contains("### static filling (2 trials: 2 timeout)"),
        "{endings}"
    );
}

#[test]
fn bad_sweep_files_exit_with_code_2_naming_file_and_key() {
    let dir = tmp("bad");
    let file = write_sweep(&dir, "1..2");
    let text = std::fs::read_to_string(&file).unwrap();
    for (from, to, expect) in [
        (
            "\"robots.0.count\"",
            "\"robots.0.cuont\"",
            "unknown field `cuont`",
        ),
        ("[6, 12]", "[6, 0]", "count must be at least 1"),
        (
            "\"robots.0.count\"",
            "\"robots.4.count\"",
            "index 4 is out of range",
        ),
        ("\"1..2\"", "\"2..1\"", "seeds"),
    ] {
        let bad = dir.join("bad.toml");
        std::fs::write(&bad, text.replace(from, to)).unwrap();
        let out = sweep(&bad, &dir.join("bad.db"), &[]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{err}");
        assert!(err.contains("bad.toml:"), "{err}");
        assert!(err.contains(expect), "{err}");
    }
}

#[test]
fn a_file_that_is_not_a_store_is_named_and_refused_with_code_2() {
    // A mistyped --db (a scenario, a CSV) gets the file's name and what is wrong, exit 2,
    // and the file is left as it was, for report, sweep and export alike.
    let dir = tmp("not-a-store");
    let file = write_sweep(&dir, "1..2");
    let not = dir.join("notes.db");
    std::fs::write(&not, "x = 1\n".repeat(200)).unwrap();
    let before = std::fs::read(&not).unwrap();
    let runs: [Vec<std::ffi::OsString>; 3] = [
        vec![
            "report".into(),
            not.clone().into(),
            "--out".into(),
            dir.join("r").into(),
        ],
        vec![
            "sweep".into(),
            file.clone().into(),
            "--db".into(),
            not.clone().into(),
        ],
        vec![
            "export".into(),
            not.clone().into(),
            "--csv".into(),
            dir.join("e.csv").into(),
        ],
    ];
    for args in runs {
        let out = formica().args(&args).output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(
            err.contains("notes.db: not a result store"),
            "{args:?}: {err}"
        );
    }
    assert_eq!(std::fs::read(&not).unwrap(), before);
}

#[test]
fn a_sweep_that_sets_the_seed_or_the_duration_twice_is_refused_at_the_line() {
    let dir = tmp("conflicts");
    let base = repo("scenarios/seed-transport.toml")
        .display()
        .to_string()
        .replace('\\', "/");
    for (body, line, says) in [
        (
            "seeds = \"1..2\"\n[vary]\n\"run.seed\" = [5, 6]\n",
            4,
            "`run.seed`: the sweep's `seeds` gives every trial its seed",
        ),
        (
            "seeds = \"1..2\"\nduration_s = 1200\n[set]\n\"run.duration_s\" = 60\n",
            3,
            "both give the duration",
        ),
        ("seeds = [1, 2, -3]\n", 2, "`seeds`: expected"),
        (
            &format!(
                "seeds = \"1\"\n[vary]\n\"objects.0.mass\" = [{}]\n\"robots.0.count\" = [{}]\n",
                (1..=400).map(|i| i.to_string()).collect::<Vec<_>>().join(", "),
                (1..=300).map(|i| i.to_string()).collect::<Vec<_>>().join(", ")
            ),
            5,
            "`robots.0.count`: the grid has more than 100000 parameter sets",
        ),
        (
            "seeds = \"1\"\n[vary]\n\"robots.0.count\" = [3, 5, 3]\n",
            4,
            "the value 3 is listed twice",
        ),
        (
            "seeds = \"1\"\n[vary]\n\"objects.0.mass\" = [50, 50.0]\n",
            4,
            "the value 50.0 is listed twice",
        ),
        (
            "seeds = \"1\"\n# [[cases]] in a comment\n[[cases]]\n\"robots.0.count\" = 3\n\n  [[cases]]\n\"robots.0.count\" = 3\n",
            7,
            "appears twice",
        ),
        (
            "seeds = \"1\"\n[[cases]]\nlabel = \"a\"\n[[cases]]\nlabel = \"b\"\n[[cases]]\nlabel = \"a\"\n\"robots.0.count\" = 3\n",
            7,
            "label \"a\" names an earlier case too",
        ),
        (
            "seeds = \"1..2\"\nduration_s = 2000000\n",
            3,
            "at most 1e6 seconds",
        ),
    ] {
        let file = dir.join("c.toml");
        std::fs::write(&file, format!("scenario = \"{base}\"\n{body}")).unwrap();
        let out = sweep(&file, &dir.join("c.db"), &["--dry-run"]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{body}: {err}");
        assert!(err.contains(&format!("c.toml:{line}:")), "{body}: {err}");
        assert!(err.contains(says), "{body}: {err}");
    }
}

#[test]
fn another_programs_sqlite_file_and_an_empty_file_are_refused_untouched() {
    // Read-only commands used to create the store's tables in any SQLite file they were
    // given (and switch it to WAL), then report "0 trials".
    let dir = tmp("foreign-sqlite");
    let file = write_sweep(&dir, "1..2");
    let other = dir.join("other.db");
    {
        let c = rusqlite::Connection::open(&other).unwrap();
        c.execute_batch("CREATE TABLE mydata (a, b); INSERT INTO mydata VALUES (1, 2);")
            .unwrap();
    }
    let before = std::fs::read(&other).unwrap();
    let empty = dir.join("empty.db");
    std::fs::write(&empty, "").unwrap();
    for (target, says) in [
        (
            &other,
            "not a Formica result store (it has the table `mydata`",
        ),
        (&empty, "an empty file, not a result store"),
    ] {
        let mut runs: Vec<Vec<std::ffi::OsString>> = vec![
            vec![
                "report".into(),
                target.into(),
                "--out".into(),
                dir.join("r").into(),
            ],
            vec![
                "export".into(),
                target.into(),
                "--csv".into(),
                dir.join("e.csv").into(),
            ],
            vec![
                "run".into(),
                "--db".into(),
                target.into(),
                "--trial".into(),
                "0".into(),
            ],
            vec!["merge".into(), dir.join("m.db").into(), target.into()],
        ];
        if target == &other {
            runs.push(vec![
                "sweep".into(),
                file.clone().into(),
                "--db".into(),
                target.into(),
            ]);
        }
        for args in runs {
            let out = formica().args(&args).output().unwrap();
            let err = String::from_utf8_lossy(&out.stderr);
            assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
            assert!(err.contains(says), "{args:?}: {err}");
        }
    }
    assert_eq!(std::fs::read(&other).unwrap(), before);
    assert_eq!(std::fs::read(&empty).unwrap(), b"");
}

#[test]
fn a_store_missing_a_metric_column_is_named_damaged() {
    // With `outcome` dropped, `report` printed 0 % successes; with another column dropped, it
    // failed at the first row with "Invalid column type Text at index: 17".
    let dir = tmp("damaged");
    let file = write_sweep(&dir, "1..1");
    let db = dir.join("s.db");
    ok(sweep(&file, &db, &["--limit", "1"]));
    {
        let c = rusqlite::Connection::open(&db).unwrap();
        c.execute_batch("ALTER TABLE trials DROP COLUMN outcome;")
            .unwrap();
    }
    for args in [
        vec!["report", "s.db", "--out", "r"],
        vec!["export", "s.db", "--csv", "e.csv"],
    ] {
        let out = formica().current_dir(&dir).args(&args).output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(
            err.contains("s.db: a damaged result store") && err.contains("lacks `outcome`"),
            "{args:?}: {err}"
        );
    }
}

#[test]
fn a_store_with_a_damaged_meta_value_is_named_and_left_as_it_was() {
    // A `writers` or `keys` list that did not decode was read as empty on resume and written
    // over (the store's record of which builds wrote it lost); `report` said only "decoding
    // meta writers".
    for (key, value, says) in [
        (
            "writers",
            "not json",
            "its meta value `writers` is not the JSON list",
        ),
        (
            "keys",
            "{\"a\": 1}",
            "its meta value `keys` is not the JSON list",
        ),
        ("results_format", "twenty", "`results_format` is \"twenty\""),
    ] {
        let dir = tmp(&format!("damaged-meta-{key}"));
        let file = write_sweep(&dir, "1..1");
        let db = dir.join("s.db");
        ok(sweep(&file, &db, &["--limit", "1"]));
        {
            let c = rusqlite::Connection::open(&db).unwrap();
            c.execute("UPDATE meta SET value = ?1 WHERE key = ?2", [value, key])
                .unwrap();
        }
        let mut runs = vec![vec!["sweep", "sweep.toml", "--db", "s.db", "--limit", "2"]];
        if key != "results_format" {
            runs.push(vec!["report", "s.db", "--out", "r"]);
        }
        for args in runs {
            let out = formica().current_dir(&dir).args(&args).output().unwrap();
            let err = String::from_utf8_lossy(&out.stderr);
            assert_eq!(out.status.code(), Some(2), "{key} {args:?}: {err}");
            assert!(
                err.contains("s.db: a damaged result store") && err.contains(says),
                "{key} {args:?}: {err}"
            );
        }
        let c = rusqlite::Connection::open(&db).unwrap();
        let kept: String = c
            .query_row("SELECT value FROM meta WHERE key = ?1", [key], |r| r.get(0))
            .unwrap();
        assert_eq!(kept, value, "{key}");
    }
}

#[test]
fn outputs_never_overwrite_the_store_or_sweep_file_being_read() {
    let dir = tmp("no-overwrite");
    let file = write_sweep(&dir, "1..1");
    let db = dir.join("s.db");
    ok(sweep(&file, &db, &["--limit", "1"]));
    let (store, sweep_text) = (std::fs::read(&db).unwrap(), std::fs::read(&file).unwrap());
    let sub = dir.join("sub").join("..").join("s.db");
    let refused: [Vec<std::ffi::OsString>; 7] = [
        // A report goes into a folder: not over the store it reads.
        vec![
            "report".into(),
            db.clone().into(),
            "--out".into(),
            db.clone().into(),
        ],
        vec![
            "export".into(),
            db.clone().into(),
            "--csv".into(),
            db.clone().into(),
        ],
        vec![
            "export".into(),
            db.clone().into(),
            "--csv".into(),
            sub.into(),
        ],
        vec![
            "export".into(),
            db.clone().into(),
            "--csv".into(),
            "-".into(),
            "--trajectories".into(),
            dir.join("s.db-wal").into(),
        ],
        vec![
            "slurm".into(),
            file.clone().into(),
            "--array".into(),
            "2".into(),
            "--script".into(),
            file.clone().into(),
        ],
        // More tasks than trials, and a time Slurm would not take.
        vec![
            "slurm".into(),
            file.clone().into(),
            "--array".into(),
            "100000".into(),
        ],
        vec![
            "slurm".into(),
            file.clone().into(),
            "--array".into(),
            "2".into(),
            "--time".into(),
            "4h".into(),
        ],
    ];
    for args in refused {
        let out = formica().args(&args).output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
    }
    assert_eq!(std::fs::read(&db).unwrap(), store);
    assert_eq!(std::fs::read(&file).unwrap(), sweep_text);
    // A script of its own it rewrites; any other file it leaves alone.
    let script = dir.join("job.slurm");
    for _ in 0..2 {
        ok(formica()
            .arg("slurm")
            .arg(&file)
            .args(["--array", "2", "--time", "1-12:00", "--script"])
            .arg(&script)
            .output()
            .unwrap());
    }
    let notes = dir.join("notes.txt");
    std::fs::write(&notes, "mine\n").unwrap();
    let out = formica()
        .arg("slurm")
        .arg(&file)
        .args(["--array", "2", "--script"])
        .arg(&notes)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert_eq!(std::fs::read_to_string(&notes).unwrap(), "mine\n");
}

#[test]
fn slurm_writes_a_job_array_over_the_shards() {
    let dir = tmp("slurm");
    let file = write_sweep(&dir, "1..2");
    let script = dir.join("job.slurm");
    ok(formica()
        .arg("slurm")
        .arg(&file)
        .args(["--array", "4", "--db-dir"])
        .arg(dir.join("shards"))
        .arg("--script")
        .arg(&script)
        // As the documentation writes it: a value that starts with dashes.
        .args(["--sbatch", "--partition=short"])
        .output()
        .unwrap());
    let s = std::fs::read_to_string(&script).unwrap();
    assert!(s.starts_with("#!/bin/bash\n"), "{s}");
    assert!(s.contains("#SBATCH --partition=short\n"), "{s}");
    assert!(s.contains("#SBATCH --array=0-3\n"), "{s}");
    assert!(s.contains("--shard \"$SLURM_ARRAY_TASK_ID/4\""), "{s}");
    assert!(s.contains("shard-$SLURM_ARRAY_TASK_ID.db"), "{s}");
}

#[test]
fn every_shipped_study_builds_every_parameter_set() {
    let dir = tmp("studies");
    for entry in std::fs::read_dir(repo("experiments")).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "toml") {
            // `--limit 0`: validate the file and build every parameter set's world, run nothing.
            let db = dir.join(path.file_name().unwrap()).with_extension("db");
            let out = sweep(&path, &db, &["--limit", "0"]);
            assert!(
                out.status.success(),
                "{}: {}",
                path.display(),
                String::from_utf8_lossy(&out.stderr)
            );
        }
    }
}

#[test]
fn the_obstacle_designs_slices_run_its_cases_its_seeds_and_its_grid() {
    // experiments/queiroz-macrae-obstacles.toml is put together from its slices by `formica
    // merge --sweep`, which takes a slice's trial in only if the design has the same canonical
    // scenario and seed: a case changed in one file and not the other would silently drop its
    // trials from the design's store.
    let read = |name: &str| -> toml::Table {
        let path = repo("experiments").join(name);
        toml::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap()
    };
    let design = read("queiroz-macrae-obstacles.toml");
    let cases = |t: &toml::Table| -> Vec<toml::Table> {
        t["cases"]
            .as_array()
            .unwrap()
            .iter()
            .map(|c| c.as_table().unwrap().clone())
            .collect()
    };
    let design_cases = cases(&design);
    let design_vary = design["vary"].as_table().unwrap();
    let mut slices = 0;
    for entry in std::fs::read_dir(repo("experiments")).unwrap() {
        let name = entry.unwrap().file_name().to_string_lossy().into_owned();
        if !name.starts_with("queiroz-macrae-obstacles-n") || !name.ends_with(".toml") {
            continue;
        }
        slices += 1;
        let slice = read(&name);
        assert_eq!(slice["seeds"], design["seeds"], "{name}: seeds");
        assert_eq!(
            slice["duration_s"], design["duration_s"],
            "{name}: duration"
        );
        let fixed = slice["set"].as_table().unwrap();
        for (key, values) in slice["vary"].as_table().unwrap() {
            let all = design_vary[key.as_str()].as_array().unwrap();
            for v in values.as_array().unwrap() {
                assert!(
                    all.contains(v),
                    "{name}: vary.{key} has {v}, not in the design"
                );
            }
        }
        for (key, value) in fixed {
            match design_vary.get(key) {
                Some(values) => assert!(
                    values.as_array().unwrap().contains(value),
                    "{name}: set.{key} = {value} is not one of the design's values"
                ),
                None => assert_eq!(Some(value), design["set"].get(key), "{name}: set.{key}"),
            }
        }
        for case in cases(&slice) {
            let label = &case["label"];
            let twin = design_cases
                .iter()
                .find(|c| &c["label"] == label)
                .unwrap_or_else(|| panic!("{name}: case {label} is not a case of the design"));
            assert_eq!(
                &case, twin,
                "{name}: case {label} differs from the design's"
            );
        }
    }
    assert_eq!(slices, 7, "the design's seven slices");
}

#[test]
fn a_report_digests_the_scenarios_of_a_sweep_that_gained_parameter_sets() {
    // A store begun with one swarm size and resumed after the sweep file gained another: its
    // report's scenario digest is the one a fresh store of the grown sweep gets, not the first.
    let dir = tmp("grown");
    let digest = |db: &Path, out: &str| {
        let md = report_without_gallery(db, &dir.join(out));
        md.lines()
            .find(|l| l.starts_with("Scenarios: SHA-256"))
            .unwrap_or_else(|| panic!("{md}"))
            .to_string()
    };
    let small = write_slice(&dir, "grown", "1..1", "", r#""robots.0.count" = [6]"#);
    let grown_db = dir.join("grown.db");
    ok(sweep(&small, &grown_db, &[]));
    let before = digest(&grown_db, "before");
    let grown = write_slice(&dir, "grown", "1..1", "", r#""robots.0.count" = [6, 8]"#);
    ok(sweep(&grown, &grown_db, &[]));
    let fresh_db = dir.join("fresh.db");
    ok(sweep(&grown, &fresh_db, &[]));
    let fresh = digest(&fresh_db, "fresh");
    assert_eq!(digest(&grown_db, "after"), fresh);
    assert_ne!(before, fresh);
}

#[test]
fn export_to_a_closed_pipe_ends_quietly() {
    // `formica export DB --csv - | head -1`: the reader goes before the rows are written.
    // Export used to fail with "writing CSV: Broken pipe" and exit 1; `run` never did.
    let dir = tmp("export-pipe");
    let file = write_sweep(&dir, "1..3");
    let db = dir.join("s.db");
    ok(sweep(&file, &db, &[]));
    let mut child = formica()
        .arg("export")
        .arg(&db)
        .args(["--csv", "-"])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let out = child.wait_with_output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        out.stderr.is_empty(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

#[cfg(target_os = "linux")]
#[test]
fn output_lost_to_a_full_disk_is_a_failure() {
    // `formica run ... --json > results.jsonl` on a full disk used to warn and exit 0, leaving
    // a short file that looked complete. A closed pipe (above) still ends quietly.
    let full = std::fs::File::create("/dev/full").unwrap();
    let out = formica()
        .arg("run")
        .arg(repo("scenarios/seed-transport.toml"))
        .args(["--seeds", "1..2", "--duration", "1", "--json"])
        .stdout(full)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("the output is incomplete"), "{err}");
}

#[test]
fn a_store_without_trials_takes_the_mended_sweep() {
    // A sweep stopped before its first trial ended (here `--limit 0`), its [set] then mended:
    // the empty store used to refuse it as "a different sweep"; a store with trials still does.
    let dir = tmp("empty-store");
    let file = write_sweep(&dir, "1..2");
    let db = dir.join("s.db");
    ok(sweep(&file, &db, &["--limit", "0"]));
    assert_eq!(count(&db), 0);
    let text = std::fs::read_to_string(&file).unwrap();
    // Mended: another mass, and the swarm size no longer varied (its empty column goes).
    std::fs::write(
        &file,
        text.replace("\"objects.0.mass\" = 5.0", "\"objects.0.mass\" = 6.0")
            .replace("\"robots.0.count\" = [6, 12]\n", ""),
    )
    .unwrap();
    ok(sweep(&file, &db, &["--limit", "1"]));
    assert_eq!(count(&db), 1);
    let header = rows(&db)[0].clone();
    assert!(!header.contains("robots.0.count"), "{header}");
    assert!(header.contains("robots.0.controller"), "{header}");
    let text = std::fs::read_to_string(&file).unwrap();
    std::fs::write(
        &file,
        text.replace("\"objects.0.mass\" = 6.0", "\"objects.0.mass\" = 7.0"),
    )
    .unwrap();
    let err = input_error(sweep(&file, &db, &[]));
    assert!(
        err.contains("a different sweep") && err.contains("delete the store"),
        "{err}"
    );
}

#[test]
fn reports_name_figures_of_long_or_non_ascii_values_apart() {
    // A 300-character value made a file name too long, and the report failed; `friction α`
    // and `friction β` both became `friction--`, so one heading showed the other's curves.
    let dir = tmp("figure-names");
    let long = "a".repeat(300);
    let text = format!(
        r#"name = "figure names"
scenario = "{}"
seeds = "1..2"
duration_s = 60

[set]
"objects.0.at" = [1.5, 0.0]

[vary]
"robots.0.count" = [6, 12]

[[cases]]
label = "friction α"
"objects.0.floor_mu" = 0.006

[[cases]]
label = "friction β"
"objects.0.floor_mu" = 0.003

[[cases]]
label = "{long}"
"objects.0.floor_mu" = 0.004
"#,
        repo("scenarios/seed-transport.toml")
            .display()
            .to_string()
            .replace('\\', "/")
    );
    let file = dir.join("names.toml");
    std::fs::write(&file, text).unwrap();
    let db = dir.join("names.db");
    ok(sweep(&file, &db, &[]));
    let out = dir.join("report");
    let summary = report_without_gallery(&db, &out);
    let figures: Vec<&str> = summary
        .lines()
        .filter_map(|l| l.split("](survival-robots-").nth(1))
        .collect();
    assert_eq!(figures.len(), 3, "{summary}");
    let mut names = figures.clone();
    names.sort_unstable();
    names.dedup();
    assert_eq!(names.len(), 3, "{figures:?}");
    assert!(figures.iter().all(|f| f.len() < 100), "{figures:?}");
    // A sweep name must fit on one line (it heads the report).
    let bad = dir.join("bad.toml");
    std::fs::write(
        &bad,
        std::fs::read_to_string(&file)
            .unwrap()
            .replace("name = \"figure names\"", "name = \"x\\n# heading\""),
    )
    .unwrap();
    let o = sweep(&bad, &dir.join("bad.db"), &[]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("one-line text"));
}

#[test]
fn failure_sections_of_cases_times_vary_name_each_set() {
    // Cases x [vary]: the sections of failed trials were headed by the case label alone, two
    // sections for each label that could not be told apart.
    let dir = tmp("cases-vary-failures");
    let text = format!(
        r#"name = "cases by vary"
scenario = "{}"
seeds = "1..2"
duration_s = 3

[vary]
"robots.0.count" = [4, 8]

[[cases]]
label = "light"
"objects.0.mass" = 5.0

[[cases]]
label = "heavy"
"objects.0.mass" = 80.0
"#,
        repo("scenarios/seed-transport.toml")
            .display()
            .to_string()
            .replace('\\', "/")
    );
    let file = dir.join("cv.toml");
    std::fs::write(&file, text).unwrap();
    let db = dir.join("cv.db");
    ok(sweep(&file, &db, &[]));
    let summary = report_without_gallery(&db, &dir.join("report"));
    let headings: Vec<&str> = summary
        .lines()
        .filter(|l| l.starts_with("### light") || l.starts_with("### heavy"))
        .collect();
    assert_eq!(headings.len(), 4, "{summary}");
    assert!(
        headings
            .iter()
            .any(|h| h.starts_with("### light, robots.0.count=4 (")),
        "{headings:?}"
    );
    let mut distinct = headings.clone();
    distinct.sort_unstable();
    distinct.dedup();
    assert_eq!(distinct.len(), 4, "{headings:?}");
}

#[test]
fn a_report_of_a_partial_store_says_so() {
    let dir = tmp("partial-report");
    let file = write_sweep(&dir, "1..2");
    let db = dir.join("s.db");
    ok(sweep(&file, &db, &["--limit", "3"]));
    let summary = report_without_gallery(&db, &dir.join("part"));
    assert!(
        summary.contains("**A partial store**: it holds 3 of the 8 trials of its sweep"),
        "{summary}"
    );
    ok(sweep(&file, &db, &[]));
    let summary = report_without_gallery(&db, &dir.join("whole"));
    assert!(!summary.contains("partial store"), "{summary}");
}

#[test]
fn merge_warns_of_a_trial_stored_twice_with_different_results() {
    let dir = tmp("merge-differing");
    let file = write_sweep(&dir, "1..1");
    let db = dir.join("s.db");
    ok(sweep(&file, &db, &[]));
    let tampered = dir.join("t.db");
    std::fs::copy(&db, &tampered).unwrap();
    rusqlite::Connection::open(&tampered)
        .unwrap()
        .execute(
            "UPDATE trials SET sim_time_s = sim_time_s + 1 WHERE trial = 0",
            [],
        )
        .unwrap();
    let merged = dir.join("m.db");
    let _ = std::fs::remove_file(&merged);
    let out = formica()
        .arg("merge")
        .arg(&merged)
        .arg(&db)
        .arg(&tampered)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(0));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("1 trial(s) are already merged with another result"),
        "{err}"
    );
    // The same store twice: nothing differs, nothing to say.
    let again = dir.join("m2.db");
    let _ = std::fs::remove_file(&again);
    let out = formica()
        .arg("merge")
        .arg(&again)
        .arg(&db)
        .arg(&db)
        .output()
        .unwrap();
    assert!(!String::from_utf8_lossy(&out.stderr).contains("warning"));
    // Merged into the sweep file's store (`--sweep`), the same: warned of once, and only there.
    let into = dir.join("m3.db");
    let _ = std::fs::remove_file(&into);
    let out = formica()
        .arg("merge")
        .arg(&into)
        .arg(&db)
        .arg(&tampered)
        .arg("--sweep")
        .arg(&file)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(0));
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(err.matches("warning").count(), 1, "{err}");
    assert!(
        err.contains("t.db: warning: 1 trial(s) are already merged with another result"),
        "{err}"
    );
}

#[test]
fn scenarios_of_one_file_name_in_two_folders_stay_apart_in_reports() {
    // Both were labelled `seed-transport`: one category, one row label, their rates pooled.
    let dir = tmp("same-stem");
    for (folder, mass) in [("light", "5.0"), ("heavy", "500.0")] {
        std::fs::create_dir_all(dir.join(folder)).unwrap();
        let text = std::fs::read_to_string(repo("scenarios/seed-transport.toml"))
            .unwrap()
            .replace("mass = 50.0", &format!("mass = {mass}"));
        std::fs::write(dir.join(folder).join("seed-transport.toml"), text).unwrap();
    }
    let file = dir.join("stems.toml");
    std::fs::write(
        &file,
        "name = \"stems\"\nseeds = \"1..2\"\nduration_s = 5\n[vary]\n\
         scenario = [\"light/seed-transport.toml\", \"heavy/seed-transport.toml\"]\n",
    )
    .unwrap();
    let db = dir.join("stems.db");
    ok(sweep(&file, &db, &[]));
    let summary = report_without_gallery(&db, &dir.join("report"));
    assert!(
        summary.contains("| light/seed-transport.toml |"),
        "{summary}"
    );
    assert!(
        summary.contains("| heavy/seed-transport.toml |"),
        "{summary}"
    );
}
