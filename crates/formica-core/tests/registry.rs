//! Controllers, loop functions and robot models from outside the crate, through a `Registry`.

mod common;
use formica::controller::{Actuation, Controller, ControllerFactory, RobotRng};
use formica::sensors::{Readings, SensorLayout, SensorNeeds};
use formica::{LoopFunctions, Outcome, Overrides, Registry, RunOptions, RunResult, World};

/// Spins in place; counts its light sensors into its state name.
struct Spin {
    layout: SensorLayout,
    lights: usize,
}

impl Controller for Spin {
    fn step(&mut self, r: &Readings, _rng: &mut RobotRng) -> Actuation {
        self.lights = r.light.len();
        Actuation::from_twist(0.0, 1.0, &self.layout)
    }
    fn state(&self) -> &'static str {
        if self.lights == 16 {
            "sixteen"
        } else {
            "spinning"
        }
    }
}

fn spin(params: Option<&toml::Table>, layout: &SensorLayout) -> Result<ControllerFactory, String> {
    if let Some(p) = params {
        if !p.is_empty() {
            return Err("`spin` takes no parameters".into());
        }
    }
    let layout = layout.clone();
    let needs = SensorNeeds {
        light: true,
        ..SensorNeeds::default()
    };
    Ok(ControllerFactory::new(needs, move || {
        Box::new(Spin {
            layout: layout.clone(),
            lights: 0,
        })
    }))
}

/// Ends the run at `stop_tick` with success and reports fields, one of them a reserved name.
struct Stopper {
    stop_tick: u64,
    ticks: u64,
}

impl LoopFunctions for Stopper {
    fn post_step(&mut self, _world: &World) {
        self.ticks += 1;
    }
    fn is_finished(&self, world: &World) -> Option<Outcome> {
        (world.tick >= self.stop_tick).then_some(Outcome::Success)
    }
    fn finish(&self, _world: &World, r: &mut RunResult) {
        r.extra.insert("stopper_ticks".into(), self.ticks.into());
        r.extra.insert("seed".into(), "not the seed".into());
    }
}

fn registry() -> Registry {
    let mut r = Registry::builtin();
    let mut sixteen = formica::robot::RobotModel::khepera4();
    sixteen.light_angles = (0..16).map(|i| (22.5 * i as f32).to_radians()).collect();
    r.controller("spin", spin)
        .and_then(|r| r.model("sixteen-eyes", sixteen))
        .and_then(|r| {
            r.loop_functions("stopper", |sc, _world| {
                // Only for scenarios named `stop-early`.
                (sc.name == "stop-early").then(|| {
                    Box::new(Stopper {
                        stop_tick: 7,
                        ticks: 0,
                    }) as Box<dyn LoopFunctions>
                })
            })
        })
        .expect("valid registrations");
    r
}

const TEXT: &str = r#"name = "stop-early"
[arena]
size = [3.0, 3.0]
[[lights]]
at = [1.0, 0.0]
[[robots]]
model = "sixteen-eyes"
controller = "spin"
placement = { poses = [[0.0, 0.0, 0.0], [-0.5, 0.0, 0.0]] }
[run]
duration_s = 10
"#;

#[test]
fn a_registered_controller_model_and_loop_function_run() {
    let reg = registry();
    let sc = reg
        .parse(TEXT, "spin.toml")
        .unwrap_or_else(|e| panic!("{e}"));
    let (r, _) = formica::run(&sc, &RunOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(r.controller, "spin");
    assert_eq!((r.outcome, r.ticks), (Outcome::Success, 7));
    assert_eq!(r.extra["stopper_ticks"], 7);
    // A reserved name is renamed after its loop functions; the real field is untouched.
    assert_eq!(r.seed, 1);
    assert_eq!(r.extra["stopper.seed"], "not the seed");
    assert!(!r.extra.contains_key("seed"));
    // The JSON line carries the fields after the built-in ones, and reads back equal.
    let line = serde_json::to_string(&r).unwrap();
    assert!(line.contains(r#""wall_time_s":"#), "{line}");
    assert!(
        line.ends_with(r#","stopper.seed":"not the seed","stopper_ticks":7}"#),
        "{line}"
    );
    let back: RunResult = serde_json::from_str(&line).unwrap();
    assert_eq!(back, r);

    let mut w = World::new(&sc, &Overrides::default()).unwrap();
    w.step();
    w.step();
    assert_eq!(w.groups[0].model_name, "sixteen-eyes");
    assert_eq!(w.robots[0].state, "sixteen");
    assert_eq!(w.robots[0].readings.light.len(), 16);
}

#[test]
fn loop_functions_that_decline_leave_other_runs_alone() {
    let reg = registry();
    let text = TEXT.replace("stop-early", "no-stop");
    let sc = reg.parse(&text, "spin.toml").unwrap();
    let (r, _) = formica::run(&sc, &RunOptions::default()).unwrap();
    assert_eq!(r.outcome, Outcome::Timeout);
    assert!(r.extra.is_empty());
    assert!(!serde_json::to_string(&r).unwrap().contains("stopper"));
}

#[test]
fn unknown_names_list_what_the_registry_has() {
    let reg = registry();
    let e = reg
        .parse(&TEXT.replace("\"spin\"", "\"spun\""), "spin.toml")
        .unwrap_err()
        .to_string();
    assert_eq!(
        e,
        "spin.toml:8:14: robots[0].controller: unknown controller `spun`, expected one of \
         random-walk, constant, filling, fill-transport, occlusion, spin"
    );
    let e = reg
        .parse(&TEXT.replace("sixteen-eyes", "six-eyes"), "spin.toml")
        .unwrap_err()
        .to_string();
    assert_eq!(
        e,
        "spin.toml:7:9: robots[0].model: unknown robot model `six-eyes`, expected one of \
         khepera4, foot-bot, e-puck, sixteen-eyes"
    );
    // The process-wide registry (the built-ins here) does not know them.
    let e = formica::Scenario::parse(TEXT, "spin.toml")
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("spin.toml:7:9: robots[0].model: unknown robot model `sixteen-eyes`"));
    // A group without `model` takes khepera4; without it in the registry, the group is named.
    let mut bare = Registry::empty();
    formica::controllers::register(&mut bare).unwrap();
    let text = TEXT
        .replace("model = \"sixteen-eyes\"\n", "")
        .replace("spin", "constant");
    let e = bare.parse(&text, "t.toml").unwrap_err().to_string();
    assert_eq!(
        e,
        "t.toml:6:1: robots[0].model: unknown robot model `khepera4`: this registry has none"
    );
}

#[test]
fn parameter_errors_and_overrides_go_through_the_registry() {
    let reg = registry();
    let text = TEXT.replace(
        "controller = \"spin\"",
        "controller = \"spin\"\nparams = { fast = true }",
    );
    let sc = reg.parse(&text, "spin.toml").unwrap();
    let e = match World::new(&sc, &Overrides::default()) {
        Err(e) => e.to_string(),
        Ok(_) => panic!("parameters accepted"),
    };
    assert_eq!(
        e,
        "spin.toml:9:10: robots[0] controller `spin`: `spin` takes no parameters"
    );
    // `--set`-style overrides resolve names in the same registry.
    let set = |k: &str, v: &str| vec![(k.to_string(), toml::Value::String(v.into()))];
    let sc = reg
        .parse_with_overrides(
            TEXT,
            "spin.toml",
            &set("robots.0.model", "e-puck"),
            ("--set", "robots.0.model=e-puck"),
        )
        .unwrap();
    assert_eq!(sc.spec.robots[0].get_ref().model.get_ref(), "e-puck");
    let e = reg
        .parse_with_overrides(
            TEXT,
            "spin.toml",
            &set("robots.0.controller", "nope"),
            ("--set", "robots.0.controller=nope"),
        )
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with("--set:1:1: `robots.0.controller` = \"nope\": spin.toml rejects it"),
        "{e}"
    );
    assert!(
        e.contains(
            "expected one of random-walk, constant, filling, fill-transport, occlusion, spin"
        ),
        "{e}"
    );
}

#[test]
fn builtin_scenarios_are_unchanged_through_an_extended_registry() {
    let reg = registry();
    let text = common::shipped_text("seed-transport.toml");
    let opts = RunOptions {
        overrides: Overrides {
            duration_s: Some(20.0),
            ..Default::default()
        },
        ..Default::default()
    };
    let plain = common::shipped("seed-transport.toml");
    let extended = reg.parse(&text, "seed-transport.toml").unwrap();
    let (mut a, ta) = formica::run(&plain, &opts).unwrap();
    let (mut b, tb) = formica::run(&extended, &opts).unwrap();
    a.wall_time_s = 0.0;
    b.wall_time_s = 0.0;
    assert_eq!((a, ta), (b, tb));
}

/// Drives ahead, then, from its third step on, with a NaN left wheel (a controller's bug).
struct GoesNan {
    steps: u32,
}

impl Controller for GoesNan {
    fn step(&mut self, _r: &Readings, _rng: &mut RobotRng) -> Actuation {
        self.steps += 1;
        Actuation {
            left: if self.steps >= 3 { f32::NAN } else { 0.1 },
            right: 0.1,
            ..Actuation::default()
        }
    }
    fn state(&self) -> &'static str {
        "driving"
    }
}

#[test]
fn a_nan_wheel_speed_stops_the_run_naming_the_controller_not_a_robot_standing_still() {
    let mut reg = Registry::builtin();
    reg.controller("goes-nan", |_, _| {
        Ok(ControllerFactory::new(SensorNeeds::default(), || {
            Box::new(GoesNan { steps: 0 })
        }))
    })
    .unwrap();
    let text = TEXT
        .replace("\"spin\"", "\"goes-nan\"")
        .replace("sixteen-eyes", "khepera4");
    let sc = reg
        .parse(&text, "nan.toml")
        .unwrap_or_else(|e| panic!("{e}"));
    let mut w = World::new(&sc, &Overrides::default()).unwrap();
    for _ in 0..3 {
        w.step();
    }
    let err = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| w.step()))
        .expect_err("a NaN wheel speed was taken");
    let msg = err.downcast_ref::<String>().cloned().unwrap_or_default();
    assert!(
        msg.contains("controller `goes-nan` gave robot 0 the wheel speeds (NaN, 0.1)")
            && msg.contains("not NaN"),
        "{msg}"
    );
}
