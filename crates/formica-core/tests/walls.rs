//! Walls of any shape: pillars (discs) and polygons are walls to sensors, bodies, the wall
//! rule and the optimal path, as boxes are.

mod common;
use common::*;
use formica::experiment::{optimal_path, Outcome, RunOptions};
use formica::geometry::Vec2;
use formica::robot::RobotModel;
use formica::Scenario;

const PILLAR: &str = "[[walls]]\nat = [1.0, 0.0]\nshape = { disc = 0.2 }\n";

#[test]
fn proximity_reads_a_pillar_at_the_gap_geometry_gives() {
    let m = RobotModel::khepera4();
    for d in [0.02f32, 0.05, 0.09, 0.13] {
        // The pillar's face is at x = 0.8; the robot faces it along the x axis.
        let x = 0.8 - m.radius - d;
        let sc = scenario(&format!("{PILLAR}{}", watcher(&[[x, 0.0, 0.0]])));
        let mut run = start(&sc, 1);
        run.world.step();
        let got = run.world.robots[0].readings.proximity[0];
        let want = m.proximity_curve.reading(d, m.proximity_range);
        assert!(
            (got - want).abs() < 0.02,
            "d = {d}: read {got}, curve says {want}"
        );
        assert_eq!(run.world.robots[0].readings.proximity[4], 0.0);
    }
}

#[test]
fn a_robot_driving_into_a_pillar_or_a_polygon_stops_at_its_face() {
    // A triangle pointing west, its tip at x = 0.8 on the robot's line.
    let triangle = "[[walls]]\nat = [1.0, 0.0]\nshape = { polygon = [[-0.2, 0.0], [0.2, -0.3], [0.2, 0.3]] }\n";
    for wall in [PILLAR, triangle] {
        let sc = scenario(&format!("{wall}{}", pushers(&[[0.0, 0.0, 0.0]], 0.1)));
        let mut run = start(&sc, 1);
        let r = RobotModel::khepera4().radius;
        for _ in 0..200 {
            run.world.step();
            let x = run.world.robot_pose(0).position().x;
            assert!(x < 0.8 - r + 0.002, "{wall}: robot at x = {x}");
        }
        // It got there (20 s at 0.1 m/s would take it 2 m).
        let x = run.world.robot_pose(0).position().x;
        assert!(x > 0.8 - r - 0.01, "{wall}: robot stopped at x = {x}");
    }
}

#[test]
fn a_wall_contains_the_points_inside_its_outline_only() {
    // A box turned 90 degrees and a concave L: a point in the L's notch is outside it.
    let walls = "[[walls]]\nat = [-1.0, 0.0]\nsize = [1.0, 0.2]\nyaw_deg = 90.0\n\
                 [[walls]]\nat = [1.0, 0.0]\nshape = { polygon = [[0.0, 0.0], [0.4, 0.0], [0.4, 0.1], [0.1, 0.1], [0.1, 0.4], [0.0, 0.4]] }\n";
    let run = start(&scenario(walls), 1);
    let (bar, l) = (&run.world.walls[4], &run.world.walls[5]);
    assert!(bar.contains(Vec2::new(-1.0, 0.45)) && !bar.contains(Vec2::new(-0.8, 0.0)));
    assert!(l.contains(Vec2::new(1.05, 0.3)) && l.contains(Vec2::new(1.3, 0.05)));
    assert!(!l.contains(Vec2::new(1.3, 0.3)));
    // The arena's own walls: the east one is centred on x = 3.
    assert!(run
        .world
        .walls
        .iter()
        .any(|w| w.contains(Vec2::new(3.0, 0.0))));
    assert!(!run
        .world
        .walls
        .iter()
        .any(|w| w.contains(Vec2::new(2.0, 0.0))));
}

#[test]
fn the_wall_rule_fails_a_run_whose_object_touches_a_pillar() {
    let sc = scenario(&format!(
        "{PILLAR}[[objects]]\nat = [0.0, 0.0]\nshape = {{ box = [0.3, 0.3] }}\nmass = 1.0\n{}[stop]\non_wall = true\non_goal = false\n[run]\nduration_s = 60\n",
        pushers(&[[-0.3, 0.0, 0.0]], 0.1)
    ));
    let (res, _) = formica::experiment::run(&sc, &RunOptions::default()).unwrap();
    assert_eq!(res.outcome, Outcome::Wall, "{res:?}");
    // The box's east face (x + 0.15) met the pillar's face at x = 0.8.
    assert!(res.sim_time_s > 5.0 && res.sim_time_s < 15.0, "{res:?}");
}

#[test]
fn the_optimal_path_goes_round_a_pillar() {
    // A 0.4 m box (grown by half its side, 0.2 m) from (0, -1) to (0, 1) round a pillar of
    // 0.25 m at the origin: round a circle of 0.45 m, tangent, arc, tangent.
    let sc = scenario(
        "[[walls]]\nat = [0.0, 0.0]\nshape = { disc = 0.25 }\n[[objects]]\nat = [0.0, -1.0]\nshape = { box = [0.4, 0.4] }\n",
    );
    let run = start(&sc, 1);
    let r = 0.45f64;
    let exact = 2.0 * (1.0 - r * r).sqrt() + r * (std::f64::consts::PI - 2.0 * r.acos());
    let got = optimal_path(&run.world, 0, Vec2::new(0.0, -1.0), Vec2::new(0.0, 1.0));
    // The pillar is a 16-sided polygon drawn round it: a little longer, never shorter.
    assert!(got >= exact && got < exact * 1.01, "{got} against {exact}");
    // An object nothing can push is gone round as a wall is (before, the path went through it).
    let sc = scenario(
        "[[objects]]\nat = [0.0, -1.0]\nshape = { box = [0.4, 0.4] }\n[[objects]]\nat = [0.0, 0.0]\nshape = { disc = 0.25 }\nmovable = false\n",
    );
    let run = start(&sc, 1);
    let fixed = optimal_path(&run.world, 0, Vec2::new(0.0, -1.0), Vec2::new(0.0, 1.0));
    assert_eq!(fixed, got);
    // A concave polygon (a U opening south) is gone round by its convex pieces: the path
    // from its mouth's middle to the point above it leaves by the mouth.
    let u = "[[walls]]\nat = [0.0, 0.0]\nshape = { polygon = [[-0.6, -0.6], [-0.4, -0.6], [-0.4, 0.4], [0.4, 0.4], [0.4, -0.6], [0.6, -0.6], [0.6, 0.6], [-0.6, 0.6]] }\n[[objects]]\nat = [0.0, -1.5]\nshape = { box = [0.1, 0.1] }\n";
    let run = start(&scenario(u), 1);
    let got = optimal_path(&run.world, 0, Vec2::new(0.0, 0.0), Vec2::new(0.0, 1.0));
    // Down 0.65 (clear of the arms' ends, grown by 0.05), across 0.65, up 1.65, back 0.65,
    // give or take the grown corners.
    assert!(got > 3.0 && got < 4.0, "{got}");
}

#[test]
fn a_wall_takes_a_size_or_a_shape_and_says_where_it_is_wrong() {
    for (wall, says) in [
        (
            "[[walls]]\nat = [0.0, 0.0]\nsize = [0.2, 0.2]\nshape = { disc = 0.1 }\n",
            "walls[0]: give either `size` (a box) or `shape`, not both",
        ),
        (
            "[[walls]]\nat = [0.0, 0.0]\n",
            "walls[0]: expected a `size` (a box) or a `shape`",
        ),
        (
            "[[walls]]\nat = [0.0, 0.0]\nshape = { polygon = [[0.0, 0.0], [1.0, 1.0], [1.0, 0.0], [0.0, 1.0]] }\n",
            "walls[0].shape:",
        ),
        (
            "[[walls]]\nat = [0.0, 0.0]\nshape = { disc = -1.0 }\n",
            "walls[0].shape.disc",
        ),
    ] {
        let text = format!("[arena]\nsize = [6.0, 4.0]\n{wall}");
        let err = Scenario::parse(&text, "w.toml").unwrap_err().to_string();
        assert!(err.contains(says), "{wall}: {err}");
        // At the wall's table, or at the key that is wrong (line 5).
        assert!(
            ["w.toml:3:", "w.toml:4:", "w.toml:5:"]
                .iter()
                .any(|l| err.starts_with(l)),
            "{err}"
        );
    }
}

#[test]
fn box_walls_are_written_back_as_before() {
    // The canonical form of a box wall (what a store's digest is of) has no `shape` key.
    let sc = scenario("[[walls]]\nat = [0.5, 0.0]\nsize = [0.2, 1.0]\n");
    let text = toml::to_string(&sc.spec).unwrap();
    assert!(
        text.contains("size = [") && !text.contains("shape"),
        "{text}"
    );
}
