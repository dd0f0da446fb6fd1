//! The process-wide registry: changed at run time (as a Python binding would), seen by
//! `Scenario::parse`; scenarios loaded before keep what they were checked against. In a test
//! binary of its own, since it changes process-wide state.

use formica::{Outcome, Registry, Scenario};

const TEXT: &str = r#"[arena]
size = [2.0, 2.0]
[[robots]]
controller = "still"
placement = { poses = [[0.0, 0.0, 0.0]] }
[run]
duration_s = 1
"#;

#[test]
fn runtime_registration_reaches_scenario_parse() {
    let before = Registry::global();
    let builtin = Scenario::parse(&TEXT.replace("still", "constant"), "t.toml").unwrap();
    assert!(Scenario::parse(TEXT, "t.toml").is_err());

    Registry::update_global(|r| {
        r.controller("still", |_params, layout| {
            let still: toml::Table =
                toml::from_str("left = 0.0\nright = 0.0").map_err(|e| e.to_string())?;
            formica::controllers::constant::factory(Some(&still), layout)
        })
        .map(|_| ())
    })
    .unwrap();
    let sc = Scenario::parse(TEXT, "t.toml").unwrap();
    let (r, _) = formica::run(&sc, &Default::default()).unwrap();
    assert_eq!(
        (r.controller.as_str(), r.outcome),
        ("still", Outcome::Timeout)
    );
    assert_eq!(r.goal_distance_m, None);

    // Snapshots taken before do not change, and old scenarios still run.
    assert!(!before.has_controller("still"));
    assert!(!builtin.registry().has_controller("still"));
    assert!(formica::run(&builtin, &Default::default()).is_ok());

    // Installing replaces the whole registry.
    Registry::builtin().install();
    assert!(Scenario::parse(TEXT, "t.toml").is_err());
}
