//! The example's own binary, `formica-phototaxis`, through `run`, `check`, `sweep` (with
//! `export` and `report` of its store) and `serve`, as a user calls them.

use std::io::{BufRead, BufReader, Read, Write};
use std::path::PathBuf;
use std::process::{Child, Command, Output, Stdio};
use std::time::Duration;

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_formica-phototaxis"))
}

/// A path in this example's folder.
fn here(p: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(p)
}

/// A fresh temporary folder for test `name`.
fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!(
        "formica-custom-controller-{}-{name}",
        std::process::id()
    ));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("temporary folder");
    d
}

fn ok(o: &Output) -> String {
    assert!(
        o.status.success(),
        "exit {:?}\nstdout: {}\nstderr: {}",
        o.status.code(),
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    String::from_utf8_lossy(&o.stdout).into_owned()
}

fn json(line: &str) -> serde_json::Map<String, serde_json::Value> {
    let v: serde_json::Value = serde_json::from_str(line).expect("a JSON line");
    v.as_object().cloned().expect("a JSON object")
}

#[test]
fn run_gives_the_controller_and_its_end_of_run_fields_deterministically() {
    let once = || {
        let o = bin()
            .args(["run", "--json", "--seed", "3"])
            .arg(here("scenarios/phototaxis.toml"))
            .output()
            .expect("runs");
        let mut r = json(ok(&o).trim());
        r.remove("wall_time_s");
        r
    };
    let r = once();
    assert_eq!(r["controller"], "phototaxis");
    assert_eq!(r["robots"], 12);
    let fraction = r["gathered_fraction"].as_f64().expect("a number");
    assert!((0.0..=1.0).contains(&fraction), "{r:?}");
    assert!(r.contains_key("gather_time_s"), "{r:?}");
    // Gathering succeeded, or the run went to its time limit.
    match r["outcome"].as_str() {
        Some("success") => assert_eq!(fraction, 1.0),
        Some("timeout") => assert_eq!(r["sim_time_s"], 120.0),
        other => panic!("outcome {other:?}"),
    }
    assert_eq!(once(), r, "same seed, same result");

    // Text output names the fields too.
    let o = bin()
        .args(["run", "--duration", "5"])
        .arg(here("scenarios/phototaxis.toml"))
        .output()
        .expect("runs");
    assert!(ok(&o).contains(", gathered_fraction "));
}

#[test]
fn run_seeds_and_builtin_scenarios_work_in_the_same_binary() {
    let o = bin()
        .args(["run", "--json", "--seeds", "1..3", "--duration", "20"])
        .arg(here("scenarios/phototaxis.toml"))
        .output()
        .expect("runs");
    let text = ok(&o);
    let lines: Vec<_> = text.lines().map(json).collect();
    assert_eq!(lines.len(), 4, "three runs and a summary: {text}");
    for (seed, r) in (1..=3).zip(&lines) {
        assert_eq!(r["seed"], seed);
        assert!(r.contains_key("gathered_fraction"));
    }
    assert_eq!(lines[3]["trials"], 3);

    // A shipped scenario with a built-in controller: no gathering fields.
    let o = bin()
        .args(["run", "--json", "--duration", "5"])
        .arg(here("../../scenarios/seed-transport.toml"))
        .output()
        .expect("runs");
    let r = json(ok(&o).trim());
    assert_eq!(r["controller"], "occlusion");
    assert!(!r.contains_key("gathered_fraction"), "{r:?}");
    // --controller takes the new name as well as the built-in ones.
    let o = bin()
        .args([
            "run",
            "--json",
            "--duration",
            "5",
            "--controller",
            "phototaxis",
        ])
        .arg(here("../../scenarios/seed-transport.toml"))
        .output()
        .expect("runs");
    assert_eq!(json(ok(&o).trim())["controller"], "phototaxis");
}

#[test]
fn check_describes_the_model_and_the_controller() {
    let o = bin()
        .arg("check")
        .arg(here("scenarios/phototaxis.toml"))
        .output()
        .expect("runs");
    let text = ok(&o);
    assert!(
        text.contains("robots[0]: 12 x demo-bot, controller phototaxis"),
        "{text}"
    );
    assert!(text.contains("proximity=true light=true"), "{text}");
}

#[test]
fn unknown_names_and_bad_parameters_are_input_errors_with_their_position() {
    let dir = tmp("bad");
    let base = std::fs::read_to_string(here("scenarios/phototaxis.toml")).expect("reads");
    let cases = [
        (
            base.replace("\"phototaxis\"\nparams", "\"phototaxi\"\nparams"),
            ":24:14: robots[0].controller: unknown controller `phototaxi`, expected one of random-walk, constant, filling, fill-transport, occlusion, phototaxis",
        ),
        (
            base.replace("\"demo-bot\"", "\"demo-bott\""),
            ":22:9: robots[0].model: unknown robot model `demo-bott`, expected one of khepera4, foot-bot, e-puck, demo-bot",
        ),
        (
            base.replace("speed = 0.15", "speed = 2.0"),
            ":25:10: robots[0] controller `phototaxis`: `speed` = 2 m/s is above this model's top speed of 0.8 m/s",
        ),
        (
            base.replace("speed = 0.15", "sped = 0.15"),
            ":25:10: robots[0] controller `phototaxis`: unknown field `sped`",
        ),
    ];
    for (i, (text, want)) in cases.iter().enumerate() {
        let path = dir.join(format!("bad{i}.toml"));
        std::fs::write(&path, text).expect("writes");
        for cmd in ["run", "check"] {
            let o = bin().arg(cmd).arg(&path).output().expect("runs");
            let err = String::from_utf8_lossy(&o.stderr);
            assert_eq!(o.status.code(), Some(2), "{cmd} {i}: {err}");
            let at = format!("error: {}{want}", path.display());
            assert!(err.starts_with(&at), "{cmd} {i}:\n{err}\nwanted {at}");
        }
    }
    let o = bin()
        .args(["run", "--controller", "nope"])
        .arg(here("scenarios/phototaxis.toml"))
        .output()
        .expect("runs");
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("occlusion, phototaxis"));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn sweep_stores_the_end_of_run_fields_and_export_and_report_show_them() {
    let dir = tmp("sweep");
    let db = dir.join("speed.db");
    let sweep = || {
        bin()
            .args(["sweep", "--quiet", "--db"])
            .arg(&db)
            .arg(here("sweep.toml"))
            .output()
            .expect("runs")
    };
    let text = ok(&sweep());
    assert!(text.contains("ran 6 trials"), "{text}");
    assert!(ok(&sweep()).contains("ran 0 trials"), "resumes");

    let o = bin()
        .args(["export", "--csv", "-"])
        .arg(&db)
        .output()
        .expect("runs");
    let csv = ok(&o);
    let header: Vec<&str> = csv.lines().next().unwrap_or("").split(',').collect();
    assert_eq!(
        header[..4],
        ["trial", "seed", "params", "robots.0.params.speed"]
    );
    assert_eq!(
        header[header.len() - 2..],
        ["gather_time_s", "gathered_fraction"]
    );
    assert_eq!(csv.lines().count(), 7, "{csv}");
    let col = header.len() - 1;
    for row in csv.lines().skip(1) {
        let cell = row.rsplit(',').next().unwrap_or("");
        let v: f64 = cell
            .parse()
            .unwrap_or_else(|_| panic!("column {col}: {row}"));
        assert!((0.0..=1.0).contains(&v), "{row}");
    }

    let out = dir.join("report");
    let o = bin()
        .args(["report", "--out"])
        .arg(&out)
        .arg(&db)
        .output()
        .expect("runs");
    ok(&o);
    let md = std::fs::read_to_string(out.join("summary.md")).expect("summary.md");
    assert!(md.contains("`gathered_fraction` (mean)"), "{md}");
    // Its loop functions may end a run with success (there is no goal light): the report
    // gives success rates, not "no success rule".
    assert!(!md.contains("no success rule"), "{md}");
    assert!(md.contains("## Failed trials"), "{md}");
    // Failed trials replay with this binary, which knows the controller; so does the report's
    // provenance name it.
    assert!(
        md.contains("`formica-phototaxis serve --db speed.db --trial "),
        "{md}"
    );
    assert!(
        md.contains("`formica-phototaxis report speed.db --out "),
        "{md}"
    );
    assert!(!md.contains("`formica serve"), "{md}");
    assert!(out.join("failures").is_dir());
    assert!(out
        .join("extra-gathered-fraction-robots-0-params-speed.png")
        .is_file());
    let _ = std::fs::remove_dir_all(&dir);
}

/// The exported CSV of store `db`, rows without their `wall_time_s` cell.
fn export_without_wall_time(db: &std::path::Path) -> Vec<String> {
    let o = bin()
        .args(["export", "--csv", "-"])
        .arg(db)
        .output()
        .expect("runs");
    let csv = ok(&o);
    let header: Vec<&str> = csv.lines().next().unwrap_or("").split(',').collect();
    let wall = header
        .iter()
        .position(|c| *c == "wall_time_s")
        .expect("a wall_time_s column");
    csv.lines()
        .map(|l| {
            let mut cells: Vec<&str> = l.split(',').collect();
            cells.remove(wall);
            cells.join(",")
        })
        .collect()
}

#[test]
fn sharded_sweeps_merge_with_their_end_of_run_fields() {
    let dir = tmp("shards");
    let run = |args: &[&str], db: &std::path::Path| {
        let o = bin()
            .args(["sweep", "--quiet"])
            .args(args)
            .arg("--db")
            .arg(db)
            .arg(here("sweep.toml"))
            .output()
            .expect("runs");
        ok(&o);
    };
    let (whole, a, b, merged) = (
        dir.join("whole.db"),
        dir.join("a.db"),
        dir.join("b.db"),
        dir.join("merged.db"),
    );
    run(&[], &whole);
    run(&["--shard", "0/2"], &a);
    run(&["--shard", "1/2"], &b);
    let o = bin()
        .arg("merge")
        .args([&merged, &a, &b])
        .output()
        .expect("runs");
    ok(&o);
    let rows = export_without_wall_time(&merged);
    assert!(
        rows[0].ends_with("gather_time_s,gathered_fraction"),
        "{rows:?}"
    );
    assert_eq!(rows, export_without_wall_time(&whole));
    let _ = std::fs::remove_dir_all(&dir);
}

/// One HTTP request to the server at `authority`; the whole answer.
fn http(authority: &str, method: &str, path: &str) -> Result<String, String> {
    let mut s = std::net::TcpStream::connect(authority).map_err(|e| e.to_string())?;
    s.set_read_timeout(Some(Duration::from_secs(10)))
        .map_err(|e| e.to_string())?;
    write!(
        s,
        "{method} {path} HTTP/1.1\r\nHost: {authority}\r\nContent-Length: 0\r\nConnection: close\r\n\r\n"
    )
    .map_err(|e| e.to_string())?;
    let mut resp = String::new();
    let _ = s.read_to_string(&mut resp);
    if resp.starts_with("HTTP/1.1 200") {
        Ok(resp)
    } else {
        Err(format!("{method} {path}: {resp:.300}"))
    }
}

/// Starts `formica serve` (`cmd`) and reads the address (`127.0.0.1:PORT`) from the first line
/// it prints.
fn serve(mut cmd: Command) -> (Child, Result<String, String>) {
    let mut child = cmd
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("starts");
    let mut line = String::new();
    if let Some(out) = child.stdout.take() {
        let _ = BufReader::new(out).read_line(&mut line);
    }
    let address = line
        .split_whitespace()
        .find(|w| w.starts_with("http://"))
        .map(|url| {
            url.trim_start_matches("http://")
                .trim_end_matches('/')
                .to_string()
        })
        .ok_or_else(|| format!("no address in `{line}`"));
    (child, address)
}

#[test]
fn serve_shows_the_custom_controller_on_loopback() {
    let mut cmd = bin();
    cmd.args(["serve", "--port", "0"])
        .arg(here("scenarios/phototaxis.toml"));
    let (mut child, address) = serve(cmd);
    let result = (|| {
        let authority = &address?;
        if !authority.starts_with("127.0.0.1:") {
            return Err(format!("listening on {authority}, not loopback"));
        }
        let page = http(authority, "GET", "/")?;
        if !page.contains("<html") {
            return Err(format!("not the page: {page:.200}"));
        }
        let scene = http(authority, "GET", "/api/scene")?;
        if !scene.contains("\"model\":\"demo-bot\"")
            || !scene.contains("\"controller\":\"phototaxis\"")
        {
            return Err(format!("scene without the group: {scene:.400}"));
        }
        let state = http(authority, "POST", "/api/step?n=20")?;
        if !state.contains("\"tick\":20") {
            return Err(format!("did not step: {state:.300}"));
        }
        let state = http(authority, "GET", "/api/state")?;
        if !["homing", "avoiding", "wandering"]
            .iter()
            .any(|s| state.contains(s))
        {
            return Err(format!("no phototaxis state: {state:.600}"));
        }
        Ok(())
    })();
    let _ = child.kill();
    let _ = child.wait();
    result.expect("serve answers on loopback");
}

/// The four provenance fields of every result.
const PROVENANCE: [&str; 4] = [
    "formica_version",
    "git_commit",
    "scenario_sha256",
    "platform",
];

/// The sweep's store in a fresh folder for test `name`.
fn swept(name: &str) -> (PathBuf, PathBuf) {
    let dir = tmp(name);
    let db = dir.join("speed.db");
    let o = bin()
        .args(["sweep", "--quiet", "--db"])
        .arg(&db)
        .arg(here("sweep.toml"))
        .output()
        .expect("runs");
    ok(&o);
    (dir, db)
}

#[test]
fn stored_trials_replay_with_their_end_of_run_fields_and_carry_provenance() {
    let (dir, db) = swept("replay");
    // Every stored trial replays exactly, its end-of-run fields included.
    let o = bin()
        .args(["run", "--trial", "all", "--db"])
        .arg(&db)
        .output()
        .expect("runs");
    let text = ok(&o);
    assert!(
        text.contains("replayed 6 trials, 6 end as stored, 0 differ"),
        "{text}"
    );
    // One replay's JSON line: the custom fields and the provenance of this build.
    let o = bin()
        .args(["run", "--json", "--trial", "4", "--db"])
        .arg(&db)
        .output()
        .expect("runs");
    let r = json(ok(&o).trim());
    assert_eq!(r["controller"], "phototaxis");
    assert!(r.contains_key("gathered_fraction"), "{r:?}");
    for k in PROVENANCE {
        assert!(r[k].as_str().is_some_and(|s| !s.is_empty()), "{k}: {r:?}");
    }
    assert!(String::from_utf8_lossy(&o.stderr).contains("ends as stored"));
    // --version is formica's, with the commit that every result carries.
    let o = bin().arg("--version").output().expect("runs");
    let v = ok(&o);
    assert!(
        v.starts_with(&format!("formica {} (commit ", env!("CARGO_PKG_VERSION"))),
        "{v}"
    );
    let commit = v
        .split("(commit ")
        .nth(1)
        .and_then(|s| s.split(',').next())
        .unwrap_or("");
    assert_eq!(r["git_commit"], commit);

    // The store: provenance columns in every row, before the end-of-run fields in the export.
    let o = bin()
        .args(["export", "--csv", "-"])
        .arg(&db)
        .output()
        .expect("runs");
    let csv = ok(&o);
    let header: Vec<&str> = csv.lines().next().unwrap_or("").split(',').collect();
    let at = |c: &str| header.iter().position(|h| *h == c).expect(c);
    assert!(at("platform") < at("wall_time_s"), "{header:?}");
    assert!(at("wall_time_s") < at("gather_time_s"), "{header:?}");
    let c = rusqlite::Connection::open(&db).expect("opens");
    let empty: i64 = c
        .query_row(
            "SELECT COUNT(*) FROM trials WHERE git_commit IS NULL OR git_commit = ''
                 OR scenario_sha256 IS NULL OR scenario_sha256 = ''",
            [],
            |r| r.get(0),
        )
        .expect("counts");
    assert_eq!(empty, 0);

    // A stored end-of-run field that the replay does not reproduce fails it, by name.
    c.execute(
        "UPDATE trials SET gathered_fraction = gathered_fraction + 0.5 WHERE trial = 1",
        [],
    )
    .expect("updates");
    drop(c);
    let o = bin()
        .args(["run", "--trial", "1", "--db"])
        .arg(&db)
        .output()
        .expect("runs");
    assert_eq!(o.status.code(), Some(1));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("does NOT end as stored"), "{text}");
    assert!(text.contains("gathered_fraction: "), "{text}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn serve_replays_a_stored_trial_and_checks_it_against_the_store() {
    let (dir, db) = swept("serve-replay");
    let mut cmd = bin();
    cmd.args(["serve", "--port", "0", "--trial", "2", "--db"])
        .arg(&db);
    let (mut child, address) = serve(cmd);
    let result = (|| {
        let authority = &address?;
        let scene = http(authority, "GET", "/api/scene")?;
        if !scene.contains("trial 2 of speed.db") {
            return Err(format!("not the replay: {scene:.400}"));
        }
        // 60 s at 10 ticks per second: this runs it to its end.
        let state = http(authority, "POST", "/api/step?n=1000")?;
        if !state.contains("\"matches\":true") {
            return Err(format!("does not end as stored: {state:.2000}"));
        }
        Ok(())
    })();
    let _ = child.kill();
    let _ = child.wait();
    let _ = std::fs::remove_dir_all(&dir);
    result.expect("the replay ends as stored");
}
