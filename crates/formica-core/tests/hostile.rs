//! Hostile or unusual scenario files (issue 15): one test per class of crash, hang, memory
//! blow-up, silent acceptance or misplaced error that mutated files found. Each is an input
//! error at the right `file:line:column`, or runs within bounded time and memory.
//!
//! The whole test binary runs under a 2 GiB allocator cap: a test that asked for more would
//! abort it.

use cap::Cap;
use formica::experiment::{run, RunOptions};
use formica::geometry::{convex_hull, Primitive, Vec2};
use formica::{Overrides, Scenario, ScenarioError, World};
use std::alloc::System;
use std::time::{Duration, Instant};

#[global_allocator]
static ALLOC: Cap<System> = Cap::new(System, 2 << 30);

const ROBOTS: &str = "[[robots]]\ncount = 3\ncontroller = \"random-walk\"\nplacement = { random = { min = [0.5, -1.0], max = [2.0, 1.0] } }\n";
const OBJECT: &str = "[[objects]]\nat = [-1.0, 0.0]\nshape = { box = [0.5, 0.5] }\n";

/// A 6 x 4 m arena, then `body`.
fn text(body: &str) -> String {
    format!("# A test scenario.\n\n[arena]\nsize = [6.0, 4.0]\n\n{body}")
}

/// The error `text` gives: (line, column, message).
fn refused(text: &str) -> (usize, usize, String) {
    match Scenario::parse(text, "t.toml") {
        Err(ScenarioError::Invalid {
            line,
            column,
            message,
            ..
        }) => (line, column, message),
        Err(e) => panic!("unexpected {e}"),
        Ok(_) => panic!("accepted:\n{text}"),
    }
}

/// The line of the first line of `text` that contains `needle` (1-based).
fn line_of(text: &str, needle: &str) -> usize {
    text.lines()
        .position(|l| l.contains(needle))
        .unwrap_or_else(|| panic!("`{needle}` not in the text"))
        + 1
}

/// `body` is refused at the line that contains `needle`, with a message that contains `msg`.
fn refused_at(body: &str, needle: &str, msg: &str) {
    let t = text(body);
    let (line, _, message) = refused(&t);
    assert_eq!(line, line_of(&t, needle), "{message}\n{t}");
    assert!(message.contains(msg), "`{msg}` not in: {message}");
}

/// Builds and runs `sc` for `ticks` ticks; returns how long it took.
fn run_ticks(sc: &Scenario, ticks: f32) -> Duration {
    let t0 = Instant::now();
    let opts = RunOptions {
        overrides: Overrides {
            duration_s: Some(ticks / sc.spec.run.tick_hz),
            ..Default::default()
        },
        ..Default::default()
    };
    run(sc, &opts).unwrap_or_else(|e| panic!("{e}"));
    t0.elapsed()
}

#[test]
fn random_span_overflow_is_refused() {
    let body = format!(
        "{OBJECT}[[robots]]\ncount = 3\ncontroller = \"random-walk\"\nplacement = {{ random = {{ min = [-3e38, -3e38], max = [3e38, 3e38] }} }}\n"
    );
    refused_at(
        &body,
        "placement",
        "placement.random.min[0]: expected -2000 to 2000 m, got -3e38",
    );
}

#[test]
fn degenerate_disc_is_refused() {
    for r in ["1e-23", "0.0005", "0"] {
        let body = format!("[[objects]]\nat = [-1.0, 0.0]\nshape = {{ disc = {r} }}\n{ROBOTS}");
        refused_at(
            &body,
            "disc",
            "objects[0].shape.disc: expected 0.001 to 1000 m",
        );
    }
    // The geometry refuses it by itself too (for shapes built in code).
    assert!(Primitive::Disc(1e-23).validate().is_err());
}

#[test]
fn degenerate_polygons_are_refused() {
    for (poly, msg) in [
        ("[[0, 0], [1, 0], [2, 0]]", "all lie on one straight line"),
        (
            "[[0, 0], [1, 0], [2, 0], [3, 0]]",
            "all lie on one straight line",
        ),
        // A spike of no width: the outline folds back on itself at (1, 0) (the message named
        // "vertex 2 on the line through vertices 1 and 3 (collinear)").
        (
            "[[0, 0], [1, 0], [0.5, 0], [0, 1]]",
            "folds back on itself at vertex (1, 0)",
        ),
        ("[[0, 0], [0.0005, 0], [0, 1]]", "coincide"),
        ("[[0, 0], [0, 0], [0, 1], [0, 1]]", "coincide"),
        ("[[0, 0], [1, 1]]", "3 to 1000 vertices"),
    ] {
        let body =
            format!("[[objects]]\nat = [-1.0, 0.0]\nshape = {{ polygon = {poly} }}\n{ROBOTS}");
        refused_at(&body, "polygon", msg);
    }
}

#[test]
fn repeated_vertices_and_vertices_on_a_straight_edge_are_dropped() {
    // Outlines exported from drawing tools repeat their first vertex at the end and carry
    // points in the middle of straight edges: the shape is the triangle all the same.
    let triangle = [
        Vec2::new(0.0, 0.0),
        Vec2::new(1.0, 0.0),
        Vec2::new(0.0, 1.0),
    ];
    for poly in [
        vec![[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]],
        vec![[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [0.0, 0.0]],
        vec![[0.0, 0.0], [1.0, 0.0], [1.0, 0.0], [0.0, 1.0]],
        vec![[0.0, 0.0], [0.5, 0.0], [1.0, 0.0], [0.0, 1.0]],
        vec![
            [0.0, 0.0],
            [0.25, 0.0],
            [0.5, 0.0],
            [1.0, 0.0],
            [0.5, 0.5],
            [0.0, 1.0],
            [0.0, 0.5],
        ],
    ] {
        let p = Primitive::Polygon(poly.clone());
        assert!(p.validate().is_ok(), "{poly:?}");
        assert_eq!(p.outline(0), triangle, "{poly:?}");
        let shape = p.shared_shape().expect("a valid triangle");
        let area = shape.mass_properties(1.0).mass();
        assert!((area - 0.5).abs() < 1e-6, "{poly:?}: {area}");
    }
    // And a scenario file takes them.
    let body = format!(
        "[[objects]]\nat = [-1.0, 0.0]\nshape = {{ polygon = [[0, 0], [0.25, 0], [0.5, 0], [0.5, 0.5], [0, 0.5], [0, 0]] }}\n{ROBOTS}"
    );
    let t = text(&body);
    Scenario::parse(&t, "t.toml").unwrap_or_else(|e| panic!("{e}\n{t}"));
}

#[test]
fn a_point_with_a_third_number_is_refused_not_cut_short() {
    // `at = [2.5, 0.0, 0.5]` (x, y, z, as ARGoS writes it) used to lose its 0.5 silently.
    for (body, needle, msg) in [
        (
            "[[objects]]\nat = [-1.0, 0.0, 0.5]\nshape = { box = [0.5, 0.5] }\n",
            "[-1.0, 0.0, 0.5]",
            "`at`: expected two numbers [x, y], got 3",
        ),
        (
            "[[objects]]\nat = [-1.0, 0.0]\nshape = { box = [0.5, 0.5, 0.2] }\n",
            "[0.5, 0.5, 0.2]",
            "`box`: expected two numbers [x, y], got 3",
        ),
        (
            "[[objects]]\nat = [-1.0, 0.0]\nshape = { polygon = [[0, 0], [1, 0, 0], [0, 1]] }\n",
            "[1, 0, 0]",
            "`polygon`: each item is [x, y], 2 numbers; got 3",
        ),
    ] {
        let t = text(&format!("{body}{ROBOTS}"));
        let (line, _, message) = refused(&t);
        assert_eq!(line, line_of(&t, needle), "{message}\n{t}");
        assert!(message.contains(msg), "`{msg}` not in: {message}");
    }
    // A controller's own parameters are its business: a list of three there is fine.
    let body = format!(
        "{OBJECT}[[robots]]\ncount = 3\ncontroller = \"random-walk\"\nparams = {{ at = [1, 2, 3] }}\nplacement = {{ random = {{ min = [0.5, -1.0], max = [2.0, 1.0] }} }}\n"
    );
    let t = text(&body);
    if let Err(e) = Scenario::parse(&t, "t.toml") {
        panic!("{e}");
    }
}

#[test]
fn huge_regular_sides_is_refused() {
    let body = format!(
        "[[objects]]\nat = [-1.0, 0.0]\nshape = {{ regular = {{ sides = 4000000000, radius = 0.3 }} }}\n{ROBOTS}"
    );
    refused_at(&body, "regular", "regular.sides: expected 3 to 1000 sides");
    // Sides shorter than a millimetre.
    let body = format!(
        "[[objects]]\nat = [-1.0, 0.0]\nshape = {{ regular = {{ sides = 1000, radius = 0.01 }} }}\n{ROBOTS}"
    );
    refused_at(&body, "regular", "sides at least 0.001 m long");
}

#[test]
fn huge_robot_count_is_an_input_error() {
    for n in ["770000000000000000", "4294967296", "100001"] {
        let body = format!(
            "{OBJECT}[[robots]]\ncount = {n}\ncontroller = \"random-walk\"\nplacement = {{ random = {{ min = [0.5, -1.0], max = [2.0, 1.0] }} }}\n"
        );
        refused_at(
            &body,
            &format!("count = {n}"),
            "count must be at least 1 and at most 100000",
        );
    }
    // All groups together.
    let group = "[[robots]]\ncount = 60000\ncontroller = \"random-walk\"\nplacement = { random = { min = [0.5, -1.0], max = [2.0, 1.0] } }\n";
    let t = text(&format!("{OBJECT}{group}{group}"));
    let (line, _, message) = refused(&t);
    assert_eq!(line, t.lines().count() - 2, "{message}");
    assert!(message.contains("got 120000 up to this group"), "{message}");
}

#[test]
fn hundred_thousand_robots_are_accepted_and_run() {
    // A 1 km arena, 100,000 robots on a grid: the limits are wide enough for real work.
    let t = "[arena]\nsize = [1000.0, 1000.0]\n[[robots]]\ncount = 100000\ncontroller = \"random-walk\"\nplacement = { grid = { center = [0.0, 0.0], spacing = 0.5 } }\n[run]\nduration_s = 0.2\n";
    let sc = Scenario::parse(t, "t.toml").unwrap();
    let took = run_ticks(&sc, 2.0);
    assert!(took < Duration::from_secs(60), "{took:?}");
}

#[test]
fn long_thin_spread_in_huge_arena_runs_in_bounded_memory() {
    // Robots along a 900 m line in a 1 km arena: the neighbour grid is sized from the arena
    // and the robot count (capped), not from the spread.
    let poses: Vec<String> = (0..200)
        .map(|k| format!("[{}, 0.0, 0.0]", -450.0 + 4.5 * k as f32))
        .collect();
    let t = format!(
        "[arena]\nsize = [1000.0, 1000.0]\n[[robots]]\ncontroller = \"random-walk\"\nplacement = {{ poses = [{}] }}\n",
        poses.join(", ")
    );
    let sc = Scenario::parse(&t, "t.toml").unwrap();
    let before = ALLOC.allocated();
    let mut w = World::new(&sc, &Overrides::default()).unwrap();
    for _ in 0..3 {
        w.step();
    }
    let held = ALLOC.allocated().saturating_sub(before);
    drop(w);
    // Other tests run alongside: a loose bound, far below the gigabytes of a spread-sized grid.
    assert!(held < 512 << 20, "{} MiB", held >> 20);
}

#[test]
fn far_away_object_is_refused() {
    for at in ["[3e7, 3e7]", "[3.4e38, 0.0]"] {
        let body = format!("[[objects]]\nat = {at}\nshape = {{ box = [0.5, 0.5] }}\n{ROBOTS}");
        refused_at(&body, "at = ", "objects[0].at[0]: expected -2000 to 2000 m");
    }
}

#[test]
fn object_outside_arena_is_refused() {
    let body = format!("[[objects]]\nat = [2.9, 0.0]\nshape = {{ box = [0.5, 0.5] }}\n{ROBOTS}");
    let t = text(&body);
    let sc = Scenario::parse(&t, "t.toml").unwrap();
    let e = World::new(&sc, &Overrides::default())
        .err()
        .unwrap()
        .to_string();
    let line = line_of(&t, "[[objects]]");
    assert!(e.starts_with(&format!("t.toml:{line}:")), "{e}");
    assert!(e.contains("objects[0]: reaches outside the arena"), "{e}");
}

#[test]
fn object_inside_wall_is_refused() {
    let body = format!(
        "[[walls]]\nat = [-1.0, 0.0]\nsize = [0.2, 2.0]\n{OBJECT}[[robots]]\ncount = 1\ncontroller = \"random-walk\"\nplacement = {{ poses = [[1.0, 0.0, 0.0]] }}\n"
    );
    let t = text(&body);
    let sc = Scenario::parse(&t, "t.toml").unwrap();
    let e = World::new(&sc, &Overrides::default())
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("objects[0]: starts inside walls[0]"), "{e}");
    // Touching an arena wall from inside: the wall is centred on the border.
    let body = "[[objects]]\nat = [2.74, 0.0]\nshape = { box = [0.5, 0.5] }\n[[robots]]\ncount = 1\ncontroller = \"random-walk\"\nplacement = { poses = [[0.0, 0.0, 0.0]] }\n";
    let sc = Scenario::parse(&text(body), "t.toml").unwrap();
    let e = World::new(&sc, &Overrides::default())
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("starts inside an arena wall"), "{e}");
}

#[test]
fn objects_that_start_overlapping_are_refused_and_touching_ones_are_not() {
    // Before, the contact solver threw them apart in the first tick (a 50 kg box jumped 2 cm
    // and turned 5 degrees with no robot near).
    let two = |x: f32| {
        format!(
            "[[objects]]\nat = [0.0, 0.0]\nshape = {{ box = [0.5, 0.5] }}\n[[objects]]\nname = \"b\"\nat = [{x}, 0.1]\nshape = {{ disc = 0.2 }}\nmovable = false\n{ROBOTS}"
        )
    };
    let t = text(&two(0.4));
    let sc = Scenario::parse(&t, "t.toml").unwrap();
    let e = World::new(&sc, &Overrides::default())
        .err()
        .unwrap()
        .to_string();
    let line = t
        .match_indices("[[objects]]")
        .nth(1)
        .map(|(at, _)| t[..at].lines().count() + 1);
    assert!(e.starts_with(&format!("t.toml:{}:", line.unwrap())), "{e}");
    assert!(
        e.contains("objects[1] (\"b\"): starts overlapping objects[0]"),
        "{e}"
    );
    // The disc touching the box's east face (x = 0.25 + 0.2).
    let sc = Scenario::parse(&text(&two(0.45)), "t.toml").unwrap();
    assert!(World::new(&sc, &Overrides::default()).is_ok());
}

#[test]
fn robot_outside_arena_is_refused() {
    let body = format!(
        "{OBJECT}[[robots]]\ncontroller = \"random-walk\"\nplacement = {{ poses = [[5.0, 0.0, 0.0]] }}\n"
    );
    let t = text(&body);
    let sc = Scenario::parse(&t, "t.toml").unwrap();
    let e = World::new(&sc, &Overrides::default())
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("is outside the arena"), "{e}");
    assert!(
        e.starts_with(&format!("t.toml:{}:", line_of(&t, "placement"))),
        "{e}"
    );
}

#[test]
fn zero_or_negative_walls_are_refused() {
    for (key, v) in [
        ("wall_thickness", "0"),
        ("wall_thickness", "-0.1"),
        ("wall_height", "0.0"),
        ("wall_height", "-1"),
    ] {
        let t = format!("[arena]\nsize = [6.0, 4.0]\n{key} = {v}\n{OBJECT}{ROBOTS}");
        let (line, _, message) = refused(&t);
        assert_eq!(line, 3, "{message}");
        assert!(
            message.contains(&format!("arena.{key}: expected 0.001 to 100 m")),
            "{message}"
        );
    }
}

#[test]
fn negative_noise_and_camera_range_are_refused() {
    for (key, msg) in [
        (
            "proximity_noise = -1.0",
            "sensors.proximity_noise: expected 0 to 10",
        ),
        (
            "camera_range = -1.0",
            "sensors.camera_range: expected 0.001 to 100 m",
        ),
        (
            "camera_range = 1e30",
            "sensors.camera_range: expected 0.001 to 100 m",
        ),
        (
            "position_noise = -0.01",
            "sensors.position_noise: expected 0 to 1000 m",
        ),
    ] {
        let body = format!("{OBJECT}{ROBOTS}sensors = {{ {key} }}\n");
        refused_at(&body, key, msg);
    }
}

#[test]
fn tick_hz_out_of_range_is_refused() {
    for hz in ["0.001", "0", "-5", "1001", "1e9"] {
        let body = format!("{OBJECT}{ROBOTS}[run]\ntick_hz = {hz}\n");
        refused_at(&body, "tick_hz", "run.tick_hz: expected 1 to 1000 ticks/s");
    }
}

#[test]
fn coarse_physics_step_is_guarded() {
    // 2 ticks/s and one physics step: robots at full speed would tunnel out of the arena.
    let t = text(&format!(
        "{OBJECT}{ROBOTS}[run]\ntick_hz = 2\nsubsteps = 1\n"
    ));
    let sc = Scenario::parse(&t, "t.toml").unwrap();
    assert!(sc.physics_warning().is_some());
    // With automatic sub-steps it is fine.
    let t = text(&format!("{OBJECT}{ROBOTS}[run]\ntick_hz = 2\n"));
    assert!(Scenario::parse(&t, "t.toml")
        .unwrap()
        .physics_warning()
        .is_none());
}

#[test]
fn long_durations_and_release_times_are_refused() {
    refused_at(
        &format!("{OBJECT}{ROBOTS}[run]\nduration_s = 1e30\n"),
        "duration_s",
        "run.duration_s: expected more than 0 and at most 1e6 s",
    );
    refused_at(
        &format!("{OBJECT}{ROBOTS}release = {{ interval_s = 1e30 }}\n"),
        "release",
        "release.interval_s: expected 0 to 1e6 s",
    );
}

#[test]
fn whole_file_errors_point_at_their_key() {
    // A missing table: at the file's first entry, not at 1:1 (a comment).
    let t = format!("# A scenario without an arena.\n\nname = \"x\"\n{OBJECT}{ROBOTS}");
    let (line, column, message) = refused(&t);
    assert_eq!((line, column), (3, 1), "{message}");
    assert!(message.contains("missing field `arena`"), "{message}");
    // Whole-file checks point at their key.
    let t = text(&format!(
        "{OBJECT}{ROBOTS}[run]\nduration_s = 5\ntick_hz = 0.5\n"
    ));
    let (line, column, _) = refused(&t);
    assert_eq!((line, column), (line_of(&t, "tick_hz"), 1));
    let t = "# c\n[arena]\nsize = [6.0, -4.0]\n";
    let (line, column, message) = refused(t);
    assert_eq!((line, column), (3, 14), "{message}");
}

#[test]
fn seed_above_i64_is_refused() {
    let body = format!("{OBJECT}{ROBOTS}[run]\nseed = 9223372036854775808\n");
    refused_at(
        &body,
        "seed",
        "run.seed: expected 0 to 9223372036854775807 (TOML integers are 64-bit signed)",
    );
}

#[test]
fn deeply_nested_arrays_are_refused() {
    let t = format!(
        "{}x = {}1{}\n",
        text(""),
        "[".repeat(100_000),
        "]".repeat(100_000)
    );
    let (line, _, message) = refused(&t);
    assert_eq!(line, line_of(&t, "x = "));
    assert!(message.contains("nested more than 32 deep"), "{message}");
}

#[test]
fn far_away_object_metrics_finish() {
    // A U near the corner of a 1 km arena, filling robots round it: the fill metrics (areas,
    // cavity capacity) take their usual time.
    let t = "[arena]\nsize = [1000.0, 1000.0]\n[[objects]]\nat = [480.0, 480.0]\nshape = { polygon = [[-0.4, -0.4], [0.4, -0.4], [0.4, 0.4], [0.25, 0.4], [0.25, -0.25], [-0.25, -0.25], [-0.25, 0.4], [-0.4, 0.4]] }\n[[robots]]\ncount = 5\ncontroller = \"filling\"\nplacement = { random = { min = [478.0, 478.0], max = [482.0, 479.0] } }\n[stop]\non_filled = 0.5\n";
    let sc = Scenario::parse(t, "t.toml").unwrap();
    let took = run_ticks(&sc, 5.0);
    assert!(took < Duration::from_secs(10), "{took:?}");
}

#[test]
fn huge_object_metrics_finish() {
    // A U 900 m wide and a 0.5 m x 900 m bar: the metrics' cost does not grow with the area.
    // A U 60 m wide, small enough to be packed disc by disc, took over two minutes before the
    // packing's total work was bounded (`MAX_PACKING_WORK`): about 4 s now.
    for shape in [
        "{ polygon = [[-450, -450], [450, -450], [450, 450], [300, 450], [300, -300], [-300, -300], [-300, 450], [-450, 450]] }",
        "{ polygon = [[-30, -30], [30, -30], [30, 30], [18, 30], [18, -18], [-18, -18], [-18, 30], [-30, 30]] }",
        "{ box = [0.5, 900.0] }",
    ] {
        let t = format!("[arena]\nsize = [1000.0, 1000.0]\n[[objects]]\nat = [0.0, 0.0]\nshape = {shape}\n[[robots]]\ncount = 5\ncontroller = \"filling\"\nplacement = {{ random = {{ min = [-10.0, -480.0], max = [10.0, -470.0] }} }}\n[stop]\non_filled = 0.5\n");
        let sc = Scenario::parse(&t, "t.toml").unwrap();
        let took = run_ticks(&sc, 3.0);
        assert!(took < Duration::from_secs(10), "{shape}: {took:?}");
    }
}

#[test]
fn degenerate_hull_input_does_not_panic() {
    let p = Vec2::new(1.0, 2.0);
    for pts in [
        vec![p, p, p, p],
        vec![p, Vec2::new(2.0, 2.0), Vec2::new(3.0, 2.0)],
        vec![
            p,
            Vec2::new(f32::NAN, 0.0),
            Vec2::new(f32::INFINITY, 1.0),
            p,
        ],
        vec![
            Vec2::new(3e7, 3e7),
            Vec2::new(3e7, 3e7 + 1e-3),
            Vec2::new(3e7 + 1e-3, 3e7),
        ],
    ] {
        let _ = convex_hull(&pts);
    }
}

/// The error building `sc`'s world gives: (file, line, message).
fn build_refused(sc: &Scenario) -> (String, usize, String) {
    match World::new(sc, &Overrides::default()) {
        Err(ScenarioError::Invalid {
            file,
            line,
            message,
            ..
        }) => (file, line, message),
        Err(e) => panic!("unexpected {e}"),
        Ok(_) => panic!("built"),
    }
}

#[test]
fn errors_found_while_building_a_world_with_overrides_name_the_file_or_the_override() {
    // A scenario given overrides is written back to TOML with them; errors found after
    // parsing (the controller's parameters, checked when the world is built) used to give a
    // line of that written-back text under the file's name: a line the file may not have.
    let good = text(&format!(
        "{OBJECT}\n[[robots]]\ncount = 3\ncontroller = \"occlusion\"\n\
         placement = {{ random = {{ min = [0.5, -1.0], max = [2.0, 1.0] }} }}\n\n\
         [[lights]]\nat = [2.5, 0.0]\ngoal = true\n"
    ));
    let sweep = "seeds = \"1..2\"\n\n[vary]\n\"robots.0.params.bogus\" = [1, 2]\n";
    let ov = |k: &str, v: toml::Value| vec![(k.to_string(), v)];
    // An override that the controller refuses: at the override, in the file it comes from.
    let sc = Scenario::parse_with_overrides(
        &good,
        "t.toml",
        &ov("robots.0.params.bogus", toml::Value::Integer(1)),
        ("sweep.toml", sweep),
    )
    .unwrap();
    let (file, line, message) = build_refused(&sc);
    assert_eq!((file.as_str(), line), ("sweep.toml", 4), "{message}");
    assert!(
        message.contains("`robots.0.params.bogus` = 1: t.toml rejects it")
            && message.contains("unknown field `bogus`"),
        "{message}"
    );
    // The file's own mistake, with an unrelated override: at the file's line.
    let bad = good.replace(
        "controller = \"occlusion\"",
        "controller = \"occlusion\"\nparams = { nope = 1 }",
    );
    let sc = Scenario::parse_with_overrides(
        &bad,
        "t.toml",
        &ov("run.duration_s", toml::Value::Float(10.0)),
        ("sweep.toml", "[set]\n\"run.duration_s\" = 10.0\n"),
    )
    .unwrap();
    let (file, line, message) = build_refused(&sc);
    assert_eq!(
        (file.as_str(), line),
        ("t.toml", line_of(&bad, "nope")),
        "{message}"
    );
    assert!(message.contains("unknown field `nope`"), "{message}");
}

#[test]
fn a_file_of_millions_of_values_is_refused_before_it_is_parsed() {
    // Parsing keeps a few hundred bytes a value: a 20 MB file of zeros took 2.7 GB before the
    // count was checked first.
    let zeros = vec!["0"; formica::limits::MAX_VALUES + 10].join(",");
    let t = text(&format!(
        "[[robots]]\ncount = 3\ncontroller = \"random-walk\"\nparams = {{ x = [{zeros}] }}\n"
    ));
    let (line, _, message) = refused(&t);
    assert_eq!(line, line_of(&t, "params = "));
    assert!(message.contains("more than 2000000 values"), "{message}");
}

#[test]
fn a_file_that_is_not_utf8_is_refused_at_its_line_and_column() {
    let path = std::env::temp_dir().join(format!("formica-utf8-{}.toml", std::process::id()));
    std::fs::write(&path, b"a = 1\n# caf\xc3\xa9 \xff\n").unwrap();
    let e = formica::limits::read_text(&path).unwrap_err();
    assert!(
        e.to_string().contains("line 2, column 8 has the byte 0xff"),
        "{e}"
    );
    // As a scenario: at its line and column, as every input error.
    let sc = Scenario::load(&path).err().unwrap().to_string();
    std::fs::remove_file(&path).unwrap();
    let want = format!("{}:2:8: not UTF-8 text: the byte 0xff", path.display());
    assert_eq!(sc, want);
}

#[test]
fn an_override_below_what_an_error_is_about_is_named_not_blamed() {
    // The object is outside the arena in the file itself; an override of its mass used to be
    // reported as the key the file rejects.
    let t = text(&format!(
        "[[objects]]\nat = [2.9, 0.0]\nshape = {{ box = [0.5, 0.5] }}\n{ROBOTS}"
    ));
    let sweep = "seeds = \"1..2\"\n\n[vary]\n\"objects.0.mass\" = [10.0, 20.0]\n";
    let sc = Scenario::parse_with_overrides(
        &t,
        "t.toml",
        &[("objects.0.mass".to_string(), toml::Value::Float(10.0))],
        ("sweep.toml", sweep),
    )
    .unwrap();
    let (file, line, message) = build_refused(&sc);
    assert_eq!(
        (file.as_str(), line),
        ("t.toml", line_of(&t, "[[objects]]")),
        "{message}"
    );
    assert!(message.contains("reaches outside the arena"), "{message}");
    assert!(
        message.contains("(with `objects.0.mass` = 10.0 from sweep.toml)")
            && !message.contains("rejects it"),
        "{message}"
    );
}

/// `shape` (TOML) as object 0, built into a world and run for a second.
fn builds_and_runs(shape: &str) {
    let t = text(&format!(
        "[[objects]]\nat = [-1.0, 0.0]\nshape = {shape}\n{ROBOTS}"
    ));
    let sc = Scenario::parse(&t, "t.toml").unwrap_or_else(|e| panic!("{e}"));
    let mut w = World::new(&sc, &Overrides::default()).unwrap_or_else(|e| panic!("{e}"));
    for _ in 0..10 {
        w.step();
    }
}

#[test]
fn fine_outlines_within_the_limits_are_accepted() {
    // parry drops a convex outline's vertices where its sides turn by less than about 1.5 deg,
    // and refused these until the outline was taken as it is.
    builds_and_runs("{ regular = { sides = 240, radius = 0.3 } }");
    builds_and_runs("{ regular = { sides = 1000, radius = 0.5 } }");
    builds_and_runs("{ polygon = [[0.0, 0.0], [0.5, 0.0], [0.25, 0.003]] }");
    // A gear of 600 and of 1000 teeth: parry's convex parts fail, so the triangles are used.
    for n in [600usize, 1000] {
        let pts: Vec<String> = (0..n)
            .map(|k| {
                let r = if k % 2 == 0 { 0.5 } else { 0.45 };
                let (s, c) = formica::ops::sin_cos(std::f32::consts::TAU * k as f32 / n as f32);
                format!("[{:.5}, {:.5}]", r * c, r * s)
            })
            .collect();
        builds_and_runs(&format!("{{ polygon = [{}] }}", pts.join(", ")));
    }
}
