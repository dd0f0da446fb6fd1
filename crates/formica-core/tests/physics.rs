//! Physics behaviour that experiments rely on.

mod common;
use common::*;
use formica::ops;
use proptest::prelude::*;

fn box_displacement(robots: &str, seconds: u32) -> f32 {
    let sc = scenario(&format!("{}{}", seed_box(0.0, 0.0), robots));
    let mut run = start(&sc, 1);
    let before = run.world.object_center(0);
    for _ in 0..seconds * 10 {
        run.world.step();
    }
    (run.world.object_center(0) - before).length()
}

#[test]
fn one_khepera_cannot_move_the_seed_box() {
    // Touching the box's west face, driving east at full push.
    let d = box_displacement(&pushers(&[[-0.33, 0.0, 0.0]], 0.2), 20);
    assert!(d < 0.01, "one robot moved the 50 kg box by {d} m");
}

#[test]
fn three_kheperas_move_the_seed_box() {
    let d = box_displacement(
        &pushers(
            &[[-0.33, -0.16, 0.0], [-0.33, 0.0, 0.0], [-0.33, 0.16, 0.0]],
            0.1,
        ),
        20,
    );
    assert!(d > 0.5, "three robots moved the box only {d} m in 20 s");
}

#[test]
fn a_robot_holding_still_is_pushed_by_at_most_its_drive_force() {
    // A stopped robot resists with its motors, up to its drive force: it is no wall. Two
    // Khepera IV in a line (the rear one pushing the front one: 3 N) drive a stopped Khepera IV
    // (1.5 N) ahead of them at about their own speed, 0.1 m/s; one Khepera IV (1.5 N) does
    // not move a stopped foot-bot (15 N).
    let pushed = |still_model: &str, pusher_xs: &[f32]| {
        let poses: Vec<[f32; 3]> = pusher_xs.iter().map(|x| [*x, 0.0, 0.0]).collect();
        let sc = scenario(&format!(
            "{}model = \"{still_model}\"\n{}",
            still_robots(&[[0.5, 0.0, 0.0]]),
            pushers(&poses, 0.1)
        ));
        let mut run = start(&sc, 1);
        for _ in 0..100 {
            run.world.step();
        }
        let a = run.world.robot_pose(0).position();
        let b = run.world.robot_pose(1).position();
        assert!(b.x < a.x, "the pusher passed through the stopped robot");
        a.x - 0.5
    };
    let by_two = pushed("khepera4", &[0.0, -0.15]);
    assert!(
        by_two > 0.5,
        "two pushers moved a stopped Khepera IV only {by_two} m in 10 s"
    );
    let foot_bot = pushed("foot-bot", &[0.0]);
    assert!(
        foot_bot.abs() < 0.01,
        "one Khepera IV moved a stopped foot-bot {foot_bot} m"
    );
}

fn inside_arena(run: &formica::experiment::Run) -> bool {
    (0..run.world.robots.len()).all(|i| {
        let p = run.world.robot_pose(i).position();
        p.x.abs() < 3.0 && p.y.abs() < 2.0
    }) && (0..run.world.objects.len()).all(|i| {
        let c = run.world.object_center(i);
        c.x.abs() < 3.0 && c.y.abs() < 2.0
    })
}

#[test]
fn robots_at_full_speed_into_walls_stay_inside() {
    // Robots aimed at every wall and corner at the model's top speed (clamped to 0.8 m/s).
    let poses: Vec<[f32; 3]> = (0..16)
        .map(|k| {
            let a = k as f32 * 22.5;
            let r = a.to_radians();
            [ops::cos(r) * 1.0, ops::sin(r) * 1.0, a]
        })
        .collect();
    let sc = scenario(&pushers(&poses, 5.0));
    let mut run = start(&sc, 1);
    for _ in 0..600 {
        run.world.step();
        assert!(
            inside_arena(&run),
            "a robot left the arena at t = {}",
            run.world.time_s
        );
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 6, ..ProptestConfig::default() })]
    #[test]
    fn nothing_leaves_the_arena(seed in 0u64..1000, n in 5usize..40) {
        let sc = scenario(&format!(
            "{}[[robots]]\ncount = {n}\ncontroller = \"random-walk\"\nparams = {{ speed = 0.5 }}\nplacement = {{ random = {{ min = [-2.8, -1.8], max = [2.8, 1.8] }} }}\n",
            seed_box(0.0, 0.0).replace("floor_mu = 0.006", "floor_mu = 0.0005"),
        ));
        let mut run = start(&sc, seed);
        for _ in 0..400 {
            run.world.step();
        }
        prop_assert!(inside_arena(&run));
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 16, ..ProptestConfig::default() })]
    #[test]
    fn floor_friction_never_accelerates_a_body(
        vx in -1.0f32..1.0,
        vy in -1.0f32..1.0,
        w in -4.0f32..4.0,
        mu in 0.05f32..0.6,
        yaw in 0.0f32..360.0,
        disc in proptest::bool::ANY,
    ) {
        // A 0.6 x 0.2 m box or a 0.2 m disc of 5 kg, launched and left to friction: its
        // kinetic energy never grows, step after step.
        let (shape, inertia) = if disc {
            ("{ disc = 0.2 }", 5.0 * 0.2 * 0.2 / 2.0)
        } else {
            ("{ box = [0.6, 0.2] }", 5.0 * (0.36 + 0.04) / 12.0)
        };
        let sc = scenario(&format!(
            "[[objects]]\nat = [0.0, 0.0]\nyaw_deg = {yaw}\nshape = {shape}\nmass = 5.0\nfloor_mu = {mu}\n"
        ));
        let mut run = start(&sc, 1);
        let body = run.world.objects[0].body;
        run.world
            .physics
            .set_velocity(body, formica::geometry::Vec2::new(vx, vy), w);
        let energy = |world: &formica::World| {
            let v = world.physics.velocity(body).length_squared();
            let w = world.physics.angular_velocity(body);
            0.5 * 5.0 * v + 0.5 * inertia * w * w
        };
        let mut last = energy(&run.world);
        let mut grew = None;
        for _ in 0..80 {
            run.world.step_with(|world| {
                let e = energy(world);
                if e > last * (1.0 + 1e-5) + 1e-9 && grew.is_none() {
                    grew = Some((last, e));
                }
                last = e;
            });
        }
        prop_assert!(grew.is_none(), "kinetic energy grew: {grew:?}");
        prop_assert!(last < 1e-9, "still moving after 8 s: {last} J");
    }
}

#[test]
fn an_object_of_overlapping_parts_has_its_mass_spread_over_their_union() {
    // The seed's U is written as three boxes whose arms run 0.1 m into its back: its centre of
    // mass is the union's (x = -0.8833), not the parts' sum (-0.875, which
    // counted the two 0.1 x 0.2 m overlaps twice), whether it moves or not.
    for movable in ["true", "false"] {
        let sc = shipped_with(
            "fill-transport-u.toml",
            &[
                ("objects.0.movable", movable),
                ("objects.0.yaw_deg", "30.0"),
            ],
        );
        let run = start(&sc, 1);
        let c = run.world.object_center(0);
        let first = -(2.0 * 0.1 * 1.0 + 0.2 * 0.75 - 2.0 * 0.02 * 0.8);
        let want = ops::unit(30f32.to_radians()) * (first / 0.36);
        assert!(
            (c - want).length() < 1e-4,
            "movable = {movable}: {c} against {want}"
        );
    }
}
