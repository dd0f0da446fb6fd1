//! The `formica` command as users call it.

mod common;
use common::{formica, input_error, ok, repo};

fn tmp(name: &str) -> std::path::PathBuf {
    common::tmp("cli", name)
}

/// `formica check` on `text` written to `dir/scenario.toml`: it must succeed; its output.
fn check_text(dir: &std::path::Path, text: &str) -> String {
    let f = dir.join("scenario.toml");
    std::fs::write(&f, text).unwrap();
    let out = formica().arg("check").arg(&f).output().unwrap();
    assert!(out.status.success());
    String::from_utf8(out.stdout).unwrap()
}

/// `formica run --duration 1` on `text` written to `file`: it must succeed; its stderr.
fn run_briefly_stderr(file: &std::path::Path, text: &str) -> String {
    std::fs::write(file, text).unwrap();
    let out = formica()
        .args(["run", "--duration", "1"])
        .arg(file)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(out.status.success(), "{stderr}");
    stderr
}

#[test]
fn every_shipped_scenario_checks() {
    for entry in std::fs::read_dir(repo("scenarios")).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "toml") {
            let out = formica().arg("check").arg(&path).output().unwrap();
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
fn check_names_the_shapes_of_walls_that_are_not_boxes() {
    let out = formica()
        .arg("check")
        .arg(repo("scenarios/pillars.toml"))
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains("arena: 3 x 3 m, 4 extra walls (3 discs, 1 polygon by `shape`)"),
        "{text}"
    );
    let out = formica()
        .arg("check")
        .arg(repo("scenarios/qm-middle.toml"))
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("arena: 3 x 3 m, 1 extra wall\n"), "{text}");
}

#[test]
fn run_json_has_the_promised_keys_and_out_writes_files() {
    let dir = tmp("out");
    let out = formica()
        .args(["run"])
        .arg(repo("scenarios/seed-transport.toml"))
        .args(["--seed", "3", "--duration", "20", "--json", "--out"])
        .arg(&dir)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    for key in [
        "scenario",
        "seed",
        "outcome",
        "sim_time_s",
        "ticks",
        "robots",
        "goal_distance_m",
        "object_path_m",
        "path_efficiency",
        "wall_time_s",
    ] {
        assert!(v.get(key).is_some(), "missing {key} in {v}");
    }
    assert_eq!(v["seed"], 3);
    assert_eq!(v["ticks"], 200);
    for f in ["object.csv", "robots.csv", "final.png", "result.json"] {
        let meta = std::fs::metadata(dir.join(f)).unwrap_or_else(|_| panic!("{f} not written"));
        assert!(meta.len() > 0, "{f} is empty");
    }
    let csv = std::fs::read_to_string(dir.join("object.csv")).unwrap();
    assert_eq!(
        csv.lines().count(),
        1 + 201,
        "header plus one row per tick and the start"
    );
}

fn strip_wall_time(s: &str) -> String {
    s.lines()
        .map(|l| {
            let mut v: serde_json::Value = serde_json::from_str(l).unwrap();
            if let Some(o) = v.as_object_mut() {
                o.remove("wall_time_s");
            }
            v.to_string()
        })
        .collect::<Vec<_>>()
        .join("\n")
}

#[test]
fn static_filling_runs_close_with_filling_figures_not_a_success_rate() {
    let out = formica()
        .arg("run")
        .arg(repo("scenarios/seed-fill-u-all.toml"))
        .args(["--seeds", "1..2", "--duration", "60"])
        .output()
        .unwrap();
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    let last = text.lines().last().unwrap_or_default();
    assert!(
        last.starts_with("seed-fill-u-all: 2 trials; no success rule"),
        "{last}"
    );
    assert!(last.contains("of a capacity of 11"), "{last}");
    assert!(last.contains("runs without false stops"), "{last}");
    assert!(!last.contains("success 0.0 %"), "{last}");
    // The JSON summary has no success figures either (it read 0 %, [0, 0.66] and a path
    // efficiency of 0).
    let out = formica()
        .arg("run")
        .arg(repo("scenarios/seed-fill-u-all.toml"))
        .args(["--seeds", "1..2", "--duration", "60", "--json"])
        .output()
        .unwrap();
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    let summary: serde_json::Value =
        serde_json::from_str(text.lines().last().unwrap_or_default()).unwrap();
    for key in [
        "success_rate",
        "success_ci95",
        "median_time_s",
        "mean_path_efficiency",
    ] {
        assert_eq!(summary[key], serde_json::Value::Null, "{key}: {summary}");
    }
    assert_eq!(summary["trials"], 2);
}

#[test]
fn seeds_in_parallel_do_not_depend_on_thread_count() {
    let run = |threads: &str| {
        let out = formica()
            .arg("run")
            .arg(repo("scenarios/seed-transport.toml"))
            .args([
                "--seeds",
                "1..4",
                "--duration",
                "15",
                "--json",
                "--threads",
                threads,
            ])
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        strip_wall_time(&String::from_utf8_lossy(&out.stdout))
    };
    let one = run("1");
    assert_eq!(one, run("2"));
    let lines: Vec<&str> = one.lines().collect();
    assert_eq!(lines.len(), 5);
    let summary: serde_json::Value = serde_json::from_str(lines[4]).unwrap();
    assert!(summary.get("seed").is_none());
    for key in [
        "trials",
        "success_rate",
        "success_ci95",
        "median_time_s",
        "mean_path_efficiency",
    ] {
        assert!(summary.get(key).is_some(), "missing {key}");
    }
    assert_eq!(summary["trials"], 4);
}

fn check_error(text: &str, want_line: usize, want: &str) {
    let dir = tmp(&format!("bad{want_line}"));
    let file = dir.join("bad.toml");
    std::fs::write(&file, text).unwrap();
    let err = input_error(formica().arg("run").arg(&file).output().unwrap());
    assert!(
        err.contains(&format!("bad.toml:{want_line}:")),
        "no file:line in {err}"
    );
    assert!(err.contains(want), "expected `{want}` in {err}");
}

const GOOD: &str = "[arena]\nsize = [6.0, 4.0]\n\n[[objects]]\nat = [-1.0, 0.0]\nshape = { box = [0.5, 0.5] }\n\n[[robots]]\ncount = 2\ncontroller = \"random-walk\"\nplacement = { poses = [[1.0, 0.0, 0.0], [1.5, 0.0, 0.0]] }\n";

#[test]
fn broken_files_get_file_line_and_expectation_with_exit_2() {
    check_error(
        &GOOD.replace("count = 2", "count = 2\nspeed = 3"),
        10,
        "unknown field `speed`",
    );
    check_error(
        &GOOD.replace("count = 2", "count = \"two\""),
        9,
        "invalid type",
    );
    check_error(
        &GOOD.replace(
            "{ box = [0.5, 0.5] }",
            "{ polygon = [[0, 0], [1, 1], [1, 0], [0, 1]] }",
        ),
        6,
        "self-intersecting",
    );
    check_error(
        &GOOD.replace("[1.5, 0.0, 0.0]", "[2.98, 0.0, 0.0]"),
        11,
        "inside a wall",
    );
    check_error(
        &GOOD.replace("[1.5, 0.0, 0.0]", "[-1.0, 0.1, 0.0]"),
        11,
        "overlaps objects[0]",
    );
    check_error("[arena\nsize = 1", 1, "");
    // Placements in the file's terms (serde said "wanted exactly 1 element, more than 1
    // element" for a heading beside the kind, and named Rust types elsewhere).
    let placement = "placement = { poses = [[1.0, 0.0, 0.0], [1.5, 0.0, 0.0]] }";
    check_error(
        &GOOD.replace(
            placement,
            "placement = { random = { min = [0.5, -1.0], max = [2.0, 1.0] }, heading_deg = 0.0 }",
        ),
        11,
        "`heading_deg` goes inside the kind's own table",
    );
    check_error(
        &GOOD.replace(placement, "placement = {}"),
        11,
        "exactly one of `random`, `grid` or `poses`, found none",
    );
    check_error(
        &GOOD.replace(placement, "placement = \"random\""),
        11,
        "found the string \"random\"",
    );
    check_error(
        &GOOD.replace(
            placement,
            "placement = { grid = { center = [1.0, 0.0], spacing = \"a\" } }",
        ),
        11,
        "placement.grid: invalid type: string \"a\", expected a number in `spacing`",
    );
    check_error(
        &GOOD.replace("count = 2", "count = 2.5"),
        9,
        "expected a whole number",
    );
    // -3 is a whole number: what is wrong is its sign.
    check_error(
        &GOOD.replace("count = 2", "count = -3"),
        9,
        "integer `-3`, expected a whole number, 0 or more",
    );
}

#[test]
fn endless_files_deep_keys_and_a_full_stderr_get_exit_2_not_a_crash() {
    // An endless "file" is refused once past the size limit, not read into memory.
    let out = formica().args(["check", "/dev/zero"]).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("larger than"));
    // A dotted key of 20,000 parts (it overflowed the stack building nested tables).
    let key = vec!["a"; 20_000].join(".");
    let out = formica()
        .arg("check")
        .arg(repo("scenarios/seed-transport.toml"))
        .args(["--set", &format!("{key}=1")])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("at most 32 dot-separated parts"));
    // An error message to a stderr that cannot be written (a full disk) still exits 2.
    if let Ok(full) = std::fs::File::create("/dev/full") {
        let out = formica()
            .args(["check", "no-such-file.toml"])
            .stderr(full)
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(2));
    }
}

#[test]
fn missing_file_is_an_input_error() {
    let out = formica()
        .args(["check", "no-such-file.toml"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("no-such-file.toml"));
}

#[test]
fn bench_prints_json_lines() {
    let out = formica()
        .args([
            "bench",
            "--robots",
            "10,40",
            "--ticks",
            "5",
            "--min-time",
            "0",
            "--json",
        ])
        .output()
        .unwrap();
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    let lines: Vec<serde_json::Value> = text
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(lines.len(), 2);
    assert_eq!(lines[1]["robots"], 40);
    assert!(lines[1]["robot_ticks_per_s"].as_f64().unwrap() > 0.0);
    assert!(lines[1].get("peak_memory_mib").is_some());
    assert_eq!(lines[1]["workload"], "transport");
    assert_eq!(lines[1]["threads"], 1);
    for key in [
        "physics_s",
        "sense_s",
        "control_s",
        "us_per_robot_tick",
        "setup_s",
    ] {
        assert!(lines[1][key].as_f64().unwrap() >= 0.0, "{key}");
    }
    // The run took time, and it is split between the three.
    let part = |k: &str| lines[1][k].as_f64().unwrap();
    assert!(part("us_per_robot_tick") > 0.0);
    assert!(part("physics_s") > 0.0 && part("sense_s") > 0.0 && part("control_s") > 0.0);
}

/// Every workload runs, and two threads give the same end state as one.
#[test]
fn bench_workloads_and_threads() {
    let line = |args: &[&str]| -> serde_json::Value {
        let out = formica()
            .args(["bench", "--ticks", "20", "--min-time", "0", "--json"])
            .args(args)
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        serde_json::from_str(String::from_utf8_lossy(&out.stdout).lines().last().unwrap()).unwrap()
    };
    for w in ["fill-transport", "random-walk"] {
        assert_eq!(line(&["--workload", w, "--robots", "30"])["workload"], w);
    }
    let one = line(&["--robots", "120"]);
    let two = line(&["--robots", "120", "--threads", "2"]);
    assert_eq!(two["threads"], 2);
    assert_eq!(one["digest"], two["digest"]);
    let out = formica()
        .args(["bench", "--workload", "nope"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
}

#[test]
fn check_takes_the_controller_override_run_takes() {
    // Every group's controller replaced, as `run --controller` does, its parameters kept
    // (and checked against the new controller, as `run` checks them).
    let out = formica()
        .arg("check")
        .arg(repo("scenarios/seed-transport.toml"))
        .args(["--controller", "random-walk"])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(text.contains("controller random-walk"), "{text}");
    assert!(!text.contains("controller occlusion"), "{text}");
    let out = formica()
        .arg("check")
        .arg(repo("scenarios/mixed-swarm-u.toml"))
        .args(["--controller", "random-walk"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("robots[1] controller `random-walk`") && err.contains("circle_led"),
        "{err}"
    );
    // The error says the params are the file's controller's, and how to replace them; with
    // them replaced, the run goes.
    assert!(
        err.contains("robots[1].params were written for `occlusion`")
            && err.contains("--set 'robots.1.params={}'"),
        "{err}"
    );
    // Placed at the params the new controller refused (line 48), not at the file's
    // controller line; `run --controller` too (qm-middle's params are on line 55).
    assert!(err.contains("mixed-swarm-u.toml:48:"), "{err}");
    let err = input_error(
        formica()
            .arg("run")
            .arg(repo("scenarios/qm-middle.toml"))
            .args(["--controller", "random-walk", "--duration", "1"])
            .output()
            .unwrap(),
    );
    assert!(
        err.contains("qm-middle.toml:55:") && err.contains("written for `occlusion`"),
        "{err}"
    );
    // A --set of one key merges into the file's params, whose keys are still refused: the
    // hint stays; a --set of the whole table replaces them, and there is no file's to blame.
    for (set, hint) in [
        ("robots.0.params.speed=0.2", true),
        ("robots.0.params={ speed = \"x\" }", false),
    ] {
        let err = input_error(
            formica()
                .arg("run")
                .arg(repo("scenarios/qm-middle.toml"))
                .args([
                    "--controller",
                    "random-walk",
                    "--duration",
                    "1",
                    "--set",
                    set,
                ])
                .output()
                .unwrap(),
        );
        assert_eq!(
            err.contains("written for `occlusion`"),
            hint,
            "{set}: {err}"
        );
    }
    let out = formica()
        .arg("check")
        .arg(repo("scenarios/mixed-swarm-u.toml"))
        .args(["--controller", "random-walk"])
        .args(["--set", "robots.0.params={}", "--set", "robots.1.params={}"])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let err = input_error(
        formica()
            .arg("check")
            .arg(repo("scenarios/seed-transport.toml"))
            .args(["--controller", "no-such"])
            .output()
            .unwrap(),
    );
    assert!(
        err.contains("--controller") && err.contains("no-such"),
        "{err}"
    );
}

#[test]
fn set_overrides_any_scenario_key_and_bad_values_are_input_errors() {
    let out = formica()
        .arg("run")
        .arg(repo("scenarios/seed-transport.toml"))
        .args([
            "--set",
            "robots.0.count=7",
            "--set",
            "run.duration_s=5",
            "--json",
        ])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["robots"], 7);
    assert_eq!(v["ticks"], 50);
    let err = input_error(
        formica()
            .arg("run")
            .arg(repo("scenarios/seed-transport.toml"))
            .args(["--set", "robots.0.count=0"])
            .output()
            .unwrap(),
    );
    assert!(
        err.contains("robots.0.count") && err.contains("at least 1"),
        "{err}"
    );
    // A controller parameter, checked when the world is built: at the --set, not at a line of
    // the file (which used to be a line of the text written back with the overrides).
    let err = input_error(
        formica()
            .arg("run")
            .arg(repo("scenarios/seed-transport.toml"))
            .args([
                "--set",
                "run.duration_s=5",
                "--set",
                "robots.0.params.nope=1",
            ])
            .output()
            .unwrap(),
    );
    assert!(
        err.contains("--set:2:1: `robots.0.params.nope` = 1: ")
            && err.contains("unknown field `nope`"),
        "{err}"
    );
}

#[test]
fn set_values_that_are_not_toml_are_refused_not_taken_for_strings() {
    let scenario = repo("scenarios/seed-transport.toml");
    for (set, says) in [
        ("robots.0.count=99999999999999999999", "number out of range"),
        ("robots.0.count=[1,2", "not a TOML value"),
        ("robots.0.count=5\nrun.seed=3", "without line breaks"),
        ("=3", "no key"),
    ] {
        let out = formica()
            .arg("check")
            .arg(&scenario)
            .args(["--set", set])
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{set}: {err}");
        assert!(err.contains(says), "{set}: {err}");
    }
    // A bare word is still the string it spells, and check takes --set as run does.
    let out = formica()
        .arg("check")
        .arg(&scenario)
        .args([
            "--set",
            "robots.0.model=foot-bot",
            "--set",
            "robots.0.count=3",
        ])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success() && text.contains("3 x foot-bot"),
        "{text}"
    );
}

#[test]
fn numeric_options_out_of_range_get_their_own_message() {
    let scenario = repo("scenarios/seed-transport.toml");
    for (args, says) in [
        (
            vec!["run", "S", "--duration", "-1"],
            "--duration: expected more than 0",
        ),
        (
            vec!["run", "S", "--seeds", "-1..3"],
            "--seeds: expected A..B",
        ),
        (vec!["run", "S", "--seeds", "1..2000000"], "at most 1000000"),
        (
            vec!["run", "S", "--threads", "100000"],
            "--threads: expected 1 to 1024",
        ),
        (
            vec!["run", "S", "--threads", "0"],
            "--threads: expected 1 to 1024",
        ),
        (
            vec!["bench", "--robots", "20001"],
            "holds at most 20000 robots",
        ),
    ] {
        let args: Vec<std::ffi::OsString> = args
            .iter()
            .map(|a| {
                if *a == "S" {
                    scenario.clone().into()
                } else {
                    (*a).into()
                }
            })
            .collect();
        let out = formica().args(&args).output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(says), "{args:?}: {err}");
        assert!(!err.contains("tip: to pass"), "{args:?}: {err}");
    }
}

#[test]
fn check_and_run_warn_of_objects_that_cannot_do_what_the_file_asks() {
    let scenario = repo("scenarios/seed-transport.toml");
    let warned = |sets: &[&str], says: &str| {
        let mut cmd = formica();
        cmd.arg("check").arg(&scenario);
        for s in sets {
            cmd.args(["--set", s]);
        }
        let out = cmd.output().unwrap();
        let text = String::from_utf8_lossy(&out.stdout);
        assert!(out.status.success(), "{sets:?}");
        text.lines()
            .any(|l| l.contains("warning:") && l.contains(says))
    };
    // The shipped file: none of these.
    for says in [
        "separate pieces",
        "cannot move",
        "outside the arena",
        "no trial can succeed",
    ] {
        assert!(!warned(&[], says), "{says}");
    }
    // Two boxes 0.5 m apart made one object; touching, they are one piece.
    let text = std::fs::read_to_string(&scenario).unwrap();
    let parts = |x: f32| {
        text.replace(
            "shape = { box = [0.5, 0.5] }",
            &format!("parts = [{{ box = [0.3, 0.3], at = [-{x}, 0.0] }}, {{ box = [0.3, 0.3], at = [{x}, 0.0] }}]"),
        )
    };
    let dir = tmp("pieces");
    std::fs::create_dir_all(&dir).unwrap();
    assert!(check_text(&dir, &parts(0.4)).contains("form 2 separate pieces (parts [0] [1])"));
    assert!(!check_text(&dir, &parts(0.15)).contains("separate pieces"));
    // Two robots against the 50 kg box (2.94 N of friction; 1.5 N each).
    assert!(warned(&["robots.0.count=1"], "cannot move"));
    assert!(!warned(&["robots.0.count=2"], "cannot move"));
    // What the light ring sees at the object: none of these in the shipped file.
    for says in [
        "no taller than the light sensors",
        "under 0.1",
        "is not the goal",
    ] {
        assert!(!warned(&[], says), "{says}");
    }
    // A box lower than the Khepera IV's light sensors (0.0145 m).
    assert!(warned(
        &["objects.0.height=0.01"],
        "no taller than the light sensors"
    ));
    // A goal so dim that it reads under 0.1 at the box (3.5 m away: exp(-2 x 3.5 / 2) = 0.03;
    // at intensity 4, 0.17).
    assert!(warned(&["lights.0.intensity=2.0"], "under 0.1"));
    assert!(!warned(&["lights.0.intensity=4.0"], "under 0.1"));
    // A second light that is not the goal, 1.5 m north of the box.
    let lit = text.replace(
        "[[objects]]",
        "[[lights]]\nat = [0.0, 1.5]\ngoal = false\n\n[[objects]]",
    );
    assert!(check_text(&dir, &lit).contains("light 1 is not the goal but reads"));
    // A goal light far beyond the east wall, and one just beyond it.
    assert!(warned(&["lights.0.at=[9.0, 0.0]"], "no trial can succeed"));
    assert!(warned(&["lights.0.at=[3.2, 0.0]"], "outside the arena"));
    // A box 0.1 m from the north wall's face (1.95 m): no Khepera IV (0.14 m) passes; 0.2 m,
    // or without the wall rule, no warning.
    let gap = "no robot can pass between";
    assert!(warned(
        &["objects.0.at=[-1.0, 1.6]"],
        "starts 0.10 m from an arena wall"
    ));
    assert!(!warned(&["objects.0.at=[-1.0, 1.5]"], gap));
    assert!(!warned(
        &["objects.0.at=[-1.0, 1.6]", "stop.on_wall=false"],
        gap
    ));
    // A moving goal whose path leads beyond the east wall; one that stays inside.
    assert!(warned(
        &["lights.0.path=[[2.5, 0.0, 0.0], [4.0, 1.0, 60.0]]"],
        "lights.0.path[1]: (4, 1) at 60 s"
    ));
    assert!(!warned(
        &["lights.0.path=[[2.5, 0.0, 0.0], [2.5, 1.0, 60.0]]"],
        "path leads outside"
    ));
    // A goal light inside the east wall, as tall as the light: hidden from every robot.
    assert!(warned(
        &["lights.0.at=[3.0, 0.0]"],
        "stands inside an arena wall"
    ));
    assert!(!warned(
        &["lights.0.at=[3.0, 0.0]", "lights.0.height=0.6"],
        "stands inside"
    ));
    // A wall across the arena between box and goal; a wall with a gap the box fits through.
    let wall = |size: &str| {
        text.replace(
            "[[robots]]",
            &format!("[[walls]]\nat = [1.0, 0.0]\nsize = {size}\n\n[[robots]]"),
        )
    };
    assert!(check_text(&dir, &wall("[0.1, 4.0]")).contains("no way to the goal light"));
    // (3.0 m long: gaps of 0.45 m, narrower than the 0.5 m box, which the check says too.)
    assert!(check_text(&dir, &wall("[0.1, 3.0]")).contains("no way to the goal light"));
    assert!(!check_text(&dir, &wall("[0.1, 2.0]")).contains("no way to the goal light"));
    // A second movable box: robots push either, success measures the first.
    let two = text.replace(
        "[[robots]]",
        "[[objects]]\nname = \"other\"\nat = [1.0, 1.2]\nshape = { box = [0.3, 0.3] }\n\n[[robots]]",
    );
    assert!(check_text(&dir, &two)
        .contains("objects 0 \"box\", 1 \"other\" are movable: each carries a beacon"));
    // Fillers beside `occlusion` robots, whose circling LED is the fillers' "attached" blue.
    let mixed = text.replace(
        "[run]",
        "[[robots]]\ncount = 5\ncontroller = \"fill-transport\"\n\
         placement = { random = { min = [-2.0, -2.0], max = [2.0, 2.0] } }\n\n[run]",
    );
    assert!(check_text(&dir, &mixed).contains("robots.0 runs occlusion, whose robots light blue"));
    // ... unless they circle in another colour.
    let magenta = mixed.replace(
        "controller = \"occlusion\"",
        "controller = \"occlusion\"\nparams = { circle_led = \"magenta\" }",
    );
    assert!(!check_text(&dir, &magenta).contains("light blue"));
    // A 20 g box: lighter than the solver iterations keep contacts with (20 times a robot).
    assert!(warned(
        &["objects.0.mass=0.02"],
        "robots squeezing it may sink"
    ));
    assert!(!warned(
        &["objects.0.mass=0.05"],
        "robots squeezing it may sink"
    ));
    // A target nothing can push: check says no trial succeeds, as run does.
    let out = ok(formica()
        .arg("check")
        .arg(&scenario)
        .args(["--set", "objects.0.movable=false"])
        .output()
        .unwrap());
    assert!(String::from_utf8_lossy(&out.stdout)
        .contains("stop: no movable object to carry to the goal, so no trial succeeds"));
    // `run` prints the same warnings before it runs.
    let out = formica()
        .arg("run")
        .arg(&scenario)
        .args(["--set", "robots.0.count=1", "--duration", "0.1"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success() && err.contains("cannot move"), "{err}");
}

#[test]
fn a_closed_stdout_neither_panics_nor_loses_the_out_files() {
    // As `formica run ... --out DIR | head -0`: the reader is gone before the first line.
    let out = tmp("closed-stdout");
    let mut child = formica()
        .args(["run", "--seed", "1", "--duration", "5", "--out"])
        .arg(&out)
        .arg(repo("scenarios/seed-transport.toml"))
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let done = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&done.stderr);
    assert!(done.status.success(), "{:?}: {stderr}", done.status);
    assert!(!stderr.contains("panicked"), "{stderr}");
    for f in ["object.csv", "robots.csv", "result.json", "final.png"] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
}

#[test]
fn check_and_run_warn_when_occlusion_cannot_reach_round_the_object() {
    // The U's radius is 0.62 m: an object_reach of 0.6 m is too short, as the controller's
    // rule (radius + 0.2 m) says; 0.85 m is enough, and so is the default, which is sized to
    // the object the beacon tracks (0.82 m here). `run` warns too.
    let u = std::fs::read_to_string(repo("scenarios/fill-transport-u.toml")).unwrap();
    let dir = tmp("reach");
    let text = |params: &str| {
        u.replace(
            "controller = \"fill-transport\"",
            &format!("controller = \"occlusion\"\nparams = {{ {params} }}"),
        )
    };
    let warning = "warning: object_reach is 0.6 m but the object's radius is 0.62 m";
    let short = check_text(&dir, &text("object_reach = 0.6"));
    assert!(
        short.contains(warning) && short.contains("at least 0.82"),
        "{short}"
    );
    let default = check_text(&dir, &text(""));
    assert!(
        !default.contains("warning") && default.contains("object_reach 0.82 m: sized to"),
        "{default}"
    );
    let enough = check_text(&dir, &text("object_reach = 0.85"));
    assert!(!enough.contains("warning"), "{enough}");
    // The advice itself, printed to the centimetre, is enough.
    let advised = check_text(&dir, &text("object_reach = 0.82"));
    assert!(!advised.contains("warning"), "{advised}");
    let run_short = run_briefly_stderr(&dir.join("short.toml"), &text("object_reach = 0.6"));
    assert!(
        run_short.contains(&warning["warning: ".len()..]),
        "{run_short}"
    );
    let run_default = run_briefly_stderr(&dir.join("default.toml"), &text(""));
    assert!(!run_default.contains("warning"), "{run_default}");
    // The U's back is within reach of robots going round it: they push, slowly.
    assert!(
        short.contains("near its ends") && !short.contains("fails"),
        "{short}"
    );
    // A 1.0 m box with a reach of 0.6 m: robots going round it are 0.60 m from its centre at
    // best, beyond 0.6 m with their gap, so none pushes (seeds 1-10: 0 delivered; with 0.91,
    // or the default, 10 of 10).
    let seed = std::fs::read_to_string(repo("scenarios/seed-transport.toml")).unwrap();
    let big = seed.replace("box = [0.5, 0.5]", "box = [1.0, 1.0]");
    assert_ne!(big, seed);
    assert!(!check_text(&dir, &big).contains("warning"));
    let short_big = big.replace(
        "controller = \"occlusion\"",
        "controller = \"occlusion\"\nparams = { object_reach = 0.6 }",
    );
    assert_ne!(short_big, big);
    let fails = check_text(&dir, &short_big);
    assert!(
        fails.contains("transport fails") && fails.contains("at least 0.91"),
        "{fails}"
    );
}

#[test]
fn run_gives_the_warnings_that_need_no_world_when_its_world_cannot_be_built() {
    // No goal light, and more robots than the start region holds: the run fails to place them
    // (exit 2, the file's line), after warning that no trial could succeed anyway.
    let text = std::fs::read_to_string(repo("scenarios/seed-transport.toml"))
        .unwrap()
        .replace("goal = true", "goal = false")
        .replace("count = 20", "count = 5000")
        .replace(
            "min = [-2.0, -2.0], max = [2.0, 2.0]",
            "min = [-0.5, -0.5], max = [0.5, 0.5]",
        );
    let dir = tmp("warn-unbuilt");
    let file = dir.join("crowded.toml");
    std::fs::write(&file, text).unwrap();
    let out = formica()
        .args(["run", "--duration", "1"])
        .arg(&file)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("no light is the goal"), "{stderr}");
    assert!(stderr.contains("no free spot for robot"), "{stderr}");
}

#[test]
fn check_warns_when_the_object_starts_at_the_goal() {
    // seed-transport's box starts 3.5 m from the goal light; with the light moved onto the
    // box every run would succeed on its first tick, and check says so.
    let text = std::fs::read_to_string(repo("scenarios/seed-transport.toml")).unwrap();
    let dir = tmp("goal-at-start");
    let check = |text: String| check_text(&dir, &text);
    let fine = check(text.clone());
    assert!(!fine.contains("succeeds at once"), "{fine}");
    assert!(text.contains("at = [2.5, 0.0]"));
    let at_goal = check(text.replacen("at = [2.5, 0.0]", "at = [-1.0, 0.1]", 1));
    assert!(
        at_goal.contains("starts 0.10 m from the goal") && at_goal.contains("succeeds at once"),
        "{at_goal}"
    );
}

#[test]
fn check_warns_when_a_filling_beacon_stands_over_open_floor() {
    // seed-fill-u's beacon stands over the U's back wall; moved over open floor 0.35 m east of
    // it, a filler that reaches the spot below it without touching the U circles there, and
    // check says so (not for the shipped file).
    let text = std::fs::read_to_string(repo("scenarios/seed-fill-u.toml")).unwrap();
    let dir = tmp("beacon-open-floor");
    let check = |text: String| check_text(&dir, &text);
    let fine = check(text.clone());
    assert!(!fine.contains("open floor"), "{fine}");
    assert!(text.contains("at = [-0.8, 0.0]"));
    let open = check(text.replacen("at = [-0.8, 0.0]", "at = [-0.3, 0.0]", 1));
    assert!(
        open.contains(
            "lights.0 stands over open floor at (-0.30, 0.00), 0.35 m from the nearest object"
        ) && open.contains("khepera4 sense 0.19 m"),
        "{open}"
    );
}

#[test]
fn check_warns_when_the_camera_goal_has_no_goal_colour() {
    // Relays (and goal_sensor = "camera") see the goal in relay.goal_color (cyan): a goal light
    // without that colour is never seen, so check says which key to set. The shipped qm maps
    // colour their goal and get no warning.
    let dir = tmp("goal-colour");
    let check = |text: String| check_text(&dir, &text);
    let qm = std::fs::read_to_string(repo("scenarios/qm-open.toml")).unwrap();
    let coloured = check(qm.clone());
    assert!(!coloured.contains("warning"), "{coloured}");
    let plain = check(qm.replace("color = \"cyan\"\n", ""));
    assert!(
        plain.contains("in cyan, but the goal light has no colour")
            && plain.contains("set lights.0.color = \"cyan\""),
        "{plain}"
    );
    let seed = std::fs::read_to_string(repo("scenarios/seed-transport.toml")).unwrap();
    let camera = check(seed.replace(
        "controller = \"occlusion\"",
        "controller = \"occlusion\"\nparams = { goal_sensor = \"camera\" }",
    ));
    assert!(
        camera.contains("but the goal light has no colour"),
        "{camera}"
    );
    let light = check(seed);
    assert!(!light.contains("goal light has no colour"), "{light}");
    // `run` says it too, on stderr, before it runs.
    let stderr = run_briefly_stderr(
        &dir.join("plain.toml"),
        &qm.replace("color = \"cyan\"\n", ""),
    );
    assert!(
        stderr.contains("warning: robots.0 sees the goal with its camera"),
        "{stderr}"
    );
}

#[test]
fn a_file_of_the_wrong_kind_is_named_with_the_command_that_takes_it() {
    let dir = tmp("wrong-kind");
    std::fs::create_dir_all(&dir).unwrap();
    let store = dir.join("study.db");
    std::fs::write(&store, b"SQLite format 3\0 and then pages").unwrap();
    let sweep = repo("experiments/smoke.toml");
    let scenario = repo("scenarios/seed-transport.toml");
    let afile = dir.join("afile");
    std::fs::write(&afile, "").unwrap();
    for (args, says) in [
        (
            vec!["run".into(), sweep.clone().into_os_string()],
            "a sweep file",
        ),
        (
            vec![
                "record".into(),
                sweep.into(),
                "--out".into(),
                dir.join("x.gif").into(),
            ],
            "a sweep file",
        ),
        (
            vec!["run".into(), store.clone().into_os_string()],
            "formica run --db",
        ),
        (vec!["serve".into(), store.into()], "formica run --db"),
        (
            vec!["sweep".into(), scenario.clone().into(), "--dry-run".into()],
            "a scenario file",
        ),
        (
            vec!["run".into(), scenario.into(), "--out".into(), afile.into()],
            "a file, not a folder",
        ),
    ] {
        let args: Vec<std::ffi::OsString> = args;
        let out = formica().args(&args).output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(says), "{args:?}: {err}");
    }
    // `[set.robots.0]` in a sweep file: the error says how to write it.
    let bad = dir.join("table.toml");
    std::fs::write(
        &bad,
        format!(
            "scenario = {:?}\nseeds = \"1..2\"\n[set.robots.0]\ncount = 3\n",
            repo("scenarios/seed-transport.toml")
                .display()
                .to_string()
                .replace('\\', "/")
        ),
    )
    .unwrap();
    let out = formica()
        .args(["sweep", "--dry-run"])
        .arg(&bad)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("\"robots.0.count\" = 3"), "{err}");
}

#[test]
fn check_on_a_sweep_file_points_to_sweep_dry_run() {
    let out = formica()
        .arg("check")
        .arg(repo("experiments/unseen.toml"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("a sweep file") && err.contains("--dry-run"),
        "{err}"
    );
    // A broken scenario still gets the scenario's own error, with its line.
    let dir = tmp("check-sweep");
    let f = dir.join("s.toml");
    std::fs::write(&f, "name = \"x\"\n").unwrap();
    let out = formica().arg("check").arg(&f).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("missing field `arena`"), "{err}");
}

#[test]
fn check_and_run_say_when_no_light_is_the_goal() {
    // A transport scenario whose one light sets goal = false can never succeed: check says so
    // in its stop line and as a warning, and run warns before it runs.
    let dir = tmp("no-goal");
    let seed = std::fs::read_to_string(repo("scenarios/seed-transport.toml")).unwrap();
    let with_goal = check_text(&dir, &seed);
    assert!(
        with_goal.contains("stop: success when object 0 \"box\" is within")
            && !with_goal.contains("no light is the goal"),
        "{with_goal}"
    );
    let no_goal = seed.replace("goal = true", "goal = false");
    let checked = check_text(&dir, &no_goal);
    assert!(
        checked.contains("stop: no goal light, so no trial succeeds")
            && checked.contains("warning: robots.0 runs occlusion, which carries the object to the goal light, but no light is the goal"),
        "{checked}"
    );
    let stderr = run_briefly_stderr(&dir.join("no-goal.toml"), &no_goal);
    assert!(stderr.contains("no light is the goal"), "{stderr}");
    // Controllers that carry nothing are not warned about.
    let walk = check_text(
        &dir,
        &no_goal.replace("controller = \"occlusion\"", "controller = \"random-walk\""),
    );
    assert!(!walk.contains("no light is the goal"), "{walk}");
}

#[test]
fn check_warns_when_relays_cannot_see_the_object_and_a_goal_at_once() {
    // qm-open's goal is 2.83 m from the object. Its cameras reach 4.5 m; with the default
    // camera (1.5 m) and scan (1.0 m) no robot sees both at once, and relays never start
    // (0 of 10 runs). check, run and sweep --dry-run say so; a goal memory silences it.
    let dir = tmp("camera-range");
    let check = |text: String| check_text(&dir, &text);
    let qm = std::fs::read_to_string(repo("scenarios/qm-open.toml")).unwrap();
    let long = check(qm.clone());
    assert!(!long.contains("warning"), "{long}");
    let short_text = qm.replace(", camera_range = 4.5, scan_range = 4.5", "");
    assert_ne!(short_text, qm);
    let short = check(short_text.clone());
    assert!(
        short.contains("but the goal is 2.83 m from the object")
            && short.contains("camera_range and scan_range to at least 2.9"),
        "{short}"
    );
    let memory = check(short_text.replace(
        "params = { relays = true }",
        "params = { relays = true, relay = { gate_memory_s = 60 } }",
    ));
    assert!(!memory.contains("warning"), "{memory}");
    let stderr = run_briefly_stderr(&dir.join("short.toml"), &short_text);
    assert!(stderr.contains("robots may never start"), "{stderr}");
    let sweep = dir.join("short-sweep.toml");
    std::fs::write(&sweep, "scenario = \"short.toml\"\nseeds = \"1..2\"\n").unwrap();
    let out = formica()
        .args(["sweep", "--dry-run", "--db"])
        .arg(dir.join("dry.db"))
        .arg(&sweep)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        out.status.success() && stderr.contains("robots may never start"),
        "{stderr}"
    );
}

#[test]
fn a_physics_step_too_coarse_for_contacts_is_refused_unless_forced() {
    // One physics step per tick lets a Khepera IV at 0.8 m/s move 8 cm per step, more than a
    // third of its radius: check warns, run refuses, --force runs.
    let text = std::fs::read_to_string(repo("scenarios/seed-transport.toml")).unwrap();
    let f = tmp("coarse").join("coarse.toml");
    std::fs::write(&f, text.replace("[run]\n", "[run]\nsubsteps = 1\n")).unwrap();
    let out = formica().arg("check").arg(&f).output().unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success() && stdout.contains("warning: at 10 ticks/s and 1 physics step(s)"),
        "{stdout}"
    );
    let out = formica()
        .arg("run")
        .arg(&f)
        .args(["--duration", "1"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && stderr.contains("--force"),
        "{stderr}"
    );
    let out = formica()
        .arg("run")
        .arg(&f)
        .args(["--duration", "1", "--force"])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn one_seed_given_to_seeds_runs_that_seed() {
    let sc = repo("scenarios/seed-transport.toml");
    let run = |args: &[&str]| {
        let out = ok(formica()
            .arg("run")
            .arg(&sc)
            .args(["--duration", "2", "--json"])
            .args(args)
            .output()
            .unwrap());
        let text = String::from_utf8_lossy(&out.stdout).to_string();
        let first = text.lines().next().unwrap().to_string();
        let v: serde_json::Value = serde_json::from_str(&first).unwrap();
        (
            v["seed"].clone(),
            v["ticks"].clone(),
            v["goal_distance_m"].clone(),
        )
    };
    let one = run(&["--seeds", "3"]);
    assert_eq!(one.0, serde_json::json!(3));
    assert_eq!(one, run(&["--seeds", "3..3"]));
    assert_eq!(one, run(&["--seed", "3"]));
}

#[test]
fn seed_range_too_large_is_refused() {
    let sc = repo("scenarios/seed-transport.toml");
    for (range, msg) in [
        (
            "0..18446744073709551615",
            "expected A..B with 0 <= A <= B <= 9223372036854775807",
        ),
        (
            "0..10000000",
            "10000001 seeds; at most 10000000 trials a call",
        ),
        ("5..3", "expected A..B"),
    ] {
        let out = formica()
            .arg("run")
            .arg(&sc)
            .args(["--seeds", range])
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{range}: {err}");
        assert!(err.contains(msg), "{range}: {err}");
    }
    let out = formica()
        .arg("run")
        .arg(&sc)
        .args(["--seed", "9223372036854775808"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    // Sweep files, `--dry-run` included.
    let dir = tmp("seed-range");
    std::fs::create_dir_all(&dir).unwrap();
    let base = std::fs::canonicalize(&sc).unwrap();
    for (seeds, vary, msg) in [
        (
            "\"0..18446744073709551615\"",
            "",
            "s.toml:2:1: `seeds`: expected A..B",
        ),
        (
            "\"1..5000000\"",
            "\"robots.0.count\" = [1, 2, 3]\n",
            "more than 10000000 trials",
        ),
    ] {
        let sweep = dir.join("s.toml");
        std::fs::write(
            &sweep,
            format!(
                "scenario = {:?}\nseeds = {seeds}\n[vary]\n{vary}\"run.duration_s\" = [1]\n",
                base.display().to_string()
            ),
        )
        .unwrap();
        let out = formica()
            .args(["sweep", "--dry-run"])
            .arg(&sweep)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{seeds}: {err}");
        assert!(
            err.contains(msg) && err.contains("s.toml:"),
            "{seeds}: {err}"
        );
    }
}

#[test]
fn a_run_without_an_object_has_no_path_figures() {
    // Robots alone (the custom-controller example's gathering): no object, so no path length
    // and no path efficiency; they read 0.000 as if an object had stood still.
    let dir = tmp("no-object");
    let file = dir.join("alone.toml");
    let text = "[arena]\nsize = [4.0, 4.0]\n\n[[robots]]\ncount = 2\ncontroller = \"random-walk\"\nplacement = { poses = [[1.0, 0.0, 0.0], [-1.0, 0.0, 0.0]] }\n";
    std::fs::write(&file, text).unwrap();
    let out = ok(formica()
        .arg("run")
        .arg(&file)
        .args(["--duration", "2", "--json"])
        .output()
        .unwrap());
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(v["object_path_m"].is_null(), "{v}");
    assert!(v["path_efficiency"].is_null(), "{v}");
    let out = ok(formica()
        .arg("run")
        .arg(&file)
        .args(["--duration", "2"])
        .output()
        .unwrap());
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(!text.contains("path efficiency"), "{text}");
    // With an object, both are numbers.
    let out = ok(formica()
        .arg("run")
        .arg(repo("scenarios/seed-transport.toml"))
        .args(["--duration", "2", "--json"])
        .output()
        .unwrap());
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(
        v["object_path_m"].is_f64() && v["path_efficiency"].is_f64(),
        "{v}"
    );
}

#[test]
fn run_warns_about_the_controller_it_runs_not_the_files() {
    // `run --controller filling` on a file of `occlusion` robots with no goal light: the
    // warning is `filling`'s (robots below a light over open floor circle there), as `check`
    // with the same arguments gives it, not `occlusion`'s (no light is the goal).
    let out = formica()
        .arg("run")
        .arg(repo("scenarios/seed-transport.toml"))
        .args(["--controller", "filling", "--set", "lights.0.goal=false"])
        .args(["--seed", "1", "--duration", "1"])
        .output()
        .unwrap();
    assert!(out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("warning: lights.0 stands over open floor"),
        "{err}"
    );
    assert!(!err.contains("occlusion"), "{err}");
}

#[test]
fn check_warns_of_robots_released_after_the_end_and_of_a_goal_radius_of_zero() {
    let check = |sets: &[&str]| {
        let mut cmd = formica();
        cmd.arg("check").arg(repo("scenarios/seed-transport.toml"));
        for s in sets {
            cmd.args(["--set", s]);
        }
        let out = cmd.output().unwrap();
        assert!(out.status.success(), "{sets:?}");
        String::from_utf8_lossy(&out.stdout).into_owned()
    };
    // Releases at 10, 110, ..., 1110 s of a 1200 s run: 12 of the 20 enter.
    let late = check(&["robots.0.release={start_s=10.0,interval_s=100.0}"]);
    assert!(
        late.contains("warning: robots.0: release starts at 10 s")
            && late.contains("12 of its 20 robots enter"),
        "{late}"
    );
    let never = check(&["robots.0.release={start_s=5000.0}"]);
    assert!(never.contains("0 of its 20 robots enter"), "{never}");
    let zero = check(&["stop.goal_radius=0.0"]);
    assert!(zero.contains("warning: stop.goal_radius is 0"), "{zero}");
    let fine = check(&["robots.0.release={interval_s=5.0}"]);
    assert!(!fine.contains("warning"), "{fine}");
}

#[test]
fn check_warns_of_a_wall_wholly_outside_the_arena_and_prints_no_negative_zero() {
    let check = |set: &str| {
        let out = formica()
            .arg("check")
            .arg(repo("scenarios/seed-transport.toml"))
            .args(["--set", set])
            .output()
            .unwrap();
        assert!(out.status.success(), "{set}");
        String::from_utf8_lossy(&out.stdout).into_owned()
    };
    let far = check("walls=[{at=[50.0,0.0],size=[0.5,0.5]}]");
    assert!(
        far.contains("warning: walls[0] at (50, 0) lies wholly outside the arena"),
        "{far}"
    );
    // Astride the east wall (the arena reaches x = 3): partly inside, no warning.
    let astride = check("walls=[{at=[3.2,0.0],size=[0.5,0.5]}]");
    assert!(!astride.contains("warning"), "{astride}");
    // No robots: their force is 0.00 N, not -0.00 (an empty f32 sum).
    let none = check("robots=[]");
    assert!(
        none.contains("at most 0.00 N") && !none.contains("-0.00"),
        "{none}"
    );
}
