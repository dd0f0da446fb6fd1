//! Sensors read what geometry says.

mod common;
use common::*;
use formica::ops;
use formica::robot::RobotModel;
use formica::sensors::light_blocked;

/// A robot that reads proximity and light but stands still.
fn watcher(poses: &[[f32; 3]]) -> String {
    robot_group(
        "random-walk",
        "speed = 0.0, turn_every_s = 1e9, avoid_threshold = 10.0",
        poses,
    )
}

#[test]
fn proximity_follows_the_khepera_curve_at_known_distances() {
    let m = RobotModel::khepera4();
    // East wall's inner face is at x = 3 - 0.05 = 2.95.
    for d in [0.02f32, 0.05, 0.07, 0.09, 0.11, 0.13] {
        let x = 2.95 - m.radius - d;
        let sc = scenario(&watcher(&[[x, 0.0, 0.0]]));
        let mut run = start(&sc, 1);
        run.world.step();
        let got = run.world.robots[0].readings.proximity[0];
        let want = m.proximity_curve.reading(d, m.proximity_range);
        assert!(
            (got - want).abs() < 0.02,
            "d = {d}: read {got}, curve says {want}"
        );
        // The sensor pointing away sees nothing.
        assert_eq!(run.world.robots[0].readings.proximity[4], 0.0);
    }
}

#[test]
fn proximity_sees_the_side_where_the_obstacle_is() {
    // Wall to the robot's left (north wall, robot facing east): sensor at +90 deg fires.
    let sc = scenario(&watcher(&[[0.0, 1.95 - 0.0704 - 0.03, 0.0]]));
    let mut run = start(&sc, 1);
    run.world.step();
    let p = &run.world.robots[0].readings.proximity;
    assert!(p[2] > 0.5, "left sensor read {}", p[2]);
    assert_eq!(p[6], 0.0);
}

const LIGHT: &str = "[[lights]]\nat = [2.5, 0.0]\nheight = 0.5\nintensity = 10.0\n";

#[test]
fn light_is_hidden_behind_the_object() {
    let sc = scenario(&format!(
        "{LIGHT}{}{}",
        seed_box(0.0, 0.0),
        watcher(&[[-1.0, 0.0, 0.0], [-1.0, 1.5, 0.0]])
    ));
    let mut run = start(&sc, 1);
    run.world.step();
    let hidden: f32 = run.world.robots[0].readings.light.iter().sum();
    let seen: f32 = run.world.robots[1].readings.light.iter().sum();
    assert_eq!(hidden, 0.0, "light seen through a 0.5 m tall box");
    assert!(seen > 0.0);
    // The strongest sensor of the seeing robot faces the light (east-south-east: sensor 0 or 7).
    let l = &run.world.robots[1].readings.light;
    let best = (0..8).max_by(|a, b| l[*a].total_cmp(&l[*b])).unwrap();
    assert!(best == 0 || best == 7, "brightest sensor {best}: {l:?}");
}

#[test]
fn light_is_visible_past_a_short_robot_but_not_one_right_in_front() {
    // Robot 0 at x = -1 looks at the light at (2.5, 0, 0.5); robot 1 is 0.4 m ahead on the line.
    let sc = scenario(&format!(
        "{LIGHT}{}",
        watcher(&[[-1.0, 0.0, 0.0], [-0.6, 0.0, 0.0]])
    ));
    let mut run = start(&sc, 1);
    run.world.step();
    let seen: f32 = run.world.robots[0].readings.light.iter().sum();
    assert!(
        seen > 0.0,
        "a 5.8 cm robot 0.4 m away hid a light 0.5 m high"
    );
    // Right in front (0.15 m centre to centre) the line of sight is still below its top.
    let sc = scenario(&format!(
        "{LIGHT}{}",
        watcher(&[[-1.0, 0.0, 0.0], [-0.85, 0.0, 0.0]])
    ));
    let mut run = start(&sc, 1);
    run.world.step();
    let seen: f32 = run.world.robots[0].readings.light.iter().sum();
    assert_eq!(seen, 0.0, "a robot right in front should hide the light");
}

#[test]
fn occlusion_rule_is_height_at_entry() {
    // Sensor 1.45 cm up, light 0.5 m up and 3.5 m away: at 0.4 m the ray is 7 cm up.
    assert!(!light_blocked(0.0145, 0.5, 3.5, 0.4, 0.058));
    assert!(light_blocked(0.0145, 0.5, 3.5, 0.1, 0.058));
    assert!(light_blocked(0.0145, 0.5, 3.5, 3.0, 0.5));
}

#[test]
fn light_strength_follows_distance_law() {
    // exp(-2 D / I) with D the 3D distance.
    let sc = scenario(&format!("{LIGHT}{}", watcher(&[[0.5, 0.0, 0.0]])));
    let mut run = start(&sc, 1);
    run.world.step();
    let m = RobotModel::khepera4();
    let d = (4.0f32 + (0.5f32 - m.light_height) * (0.5f32 - m.light_height)).sqrt();
    let want = ops::exp(-2.0 * d / 10.0);
    let got = run.world.robots[0].readings.light[0];
    assert!((got - want).abs() < 1e-4, "{got} vs {want}");
}

/// A robot whose controller reads the camera (LED green so others can see it).
fn camera_watchers(poses: &[[f32; 3]]) -> String {
    robot_group(
        "constant",
        "left = 0.0, right = 0.0, led = \"red\", camera = true",
        poses,
    )
}

#[test]
fn camera_sees_the_object_colour_and_lit_robots_unless_hidden() {
    // Robot 0 faces east at (-1, 0); the green box's west face is 0.75 m ahead.
    // Robot 1 is north of it, in view; robot 2 sits behind the box, hidden from robot 0.
    let sc = scenario(&format!(
        "{}{}",
        seed_box(0.0, 0.0),
        camera_watchers(&[[-1.0, 0.0, 0.0], [-1.0, 0.8, 0.0], [0.6, 0.0, 0.0]])
    ));
    let mut run = start(&sc, 1);
    // Two ticks: LEDs light up when the first decisions are acted on.
    run.world.step();
    run.world.step();
    let blobs = &run.world.robots[0].readings.blobs;
    let object = blobs
        .iter()
        .find(|b| !b.is_robot)
        .unwrap_or_else(|| panic!("no object blob in {blobs:?}"));
    assert_eq!(object.color, formica::scenario::Color::Green);
    assert!(
        (object.distance - 0.75).abs() < 0.01,
        "distance {}",
        object.distance
    );
    assert!(object.bearing.abs() < 0.01, "bearing {}", object.bearing);
    let robots: Vec<_> = blobs.iter().filter(|b| b.is_robot).collect();
    assert_eq!(robots.len(), 1, "only the robot in view: {blobs:?}");
    assert_eq!(robots[0].color, formica::scenario::Color::Red);
    assert!((robots[0].bearing - std::f32::consts::FRAC_PI_2).abs() < 0.05);
}
