//! Sub-goal relays (issue 14) in the shipped Queiroz & MacRae maps, judged from the ground
//! truth the controllers never see; and moving goals.

mod common;

use common::{shipped, shipped_text, shipped_with, start};
use formica::geometry::Vec2;
use formica::visibility::crosses;
use formica::Scenario;

/// One relay episode: robot, where and when it began, and the object's centre distance from
/// the robot each tick while it lasted.
struct Episode {
    robot: usize,
    at: Vec2,
    begin_s: f64,
    /// (time, object centre distance) per tick while relaying.
    near: Vec<(f64, f32)>,
    /// The gap between the robot's body and the object's surface (m), per tick as `near`.
    gap: Vec<f32>,
    ended: bool,
}

/// Runs `sc` with `seed` for at most `max_s` (or until it ends) and collects relay episodes.
fn episodes(sc: &Scenario, seed: u64, max_s: f64) -> (Vec<Episode>, Option<String>) {
    let mut run = start(sc, seed);
    let mut open: Vec<Option<usize>> = vec![None; run.world.robots.len()];
    let mut out: Vec<Episode> = Vec::new();
    loop {
        let o = run.step();
        let w = &run.world;
        let t = w.target.unwrap();
        let c = w.object_center(t);
        for (i, r) in w.robots.iter().enumerate() {
            let p = w.robot_pose(i).position();
            let gap = w.physics.distance_to(w.objects[t].body, p) - w.groups[r.group].model.radius;
            match (r.state == "relay", open[i]) {
                (true, None) => {
                    open[i] = Some(out.len());
                    out.push(Episode {
                        robot: i,
                        at: p,
                        begin_s: w.time_s,
                        near: vec![(w.time_s, (c - p).length())],
                        gap: vec![gap],
                        ended: false,
                    });
                }
                (true, Some(k)) => {
                    out[k].near.push((w.time_s, (c - p).length()));
                    out[k].gap.push(gap);
                }
                (false, Some(k)) => {
                    out[k].ended = true;
                    open[i] = None;
                }
                (false, None) => {}
            }
        }
        if let Some(o) = o {
            return (out, Some(format!("{o:?}")));
        }
        if w.time_s >= max_s {
            return (out, None);
        }
    }
}

fn rect(c: Vec2, size: Vec2, grow: f32) -> Vec<[f64; 2]> {
    let (hx, hy) = (
        f64::from(size.x / 2.0 + grow),
        f64::from(size.y / 2.0 + grow),
    );
    let (x, y) = (f64::from(c.x), f64::from(c.y));
    vec![
        [x - hx, y - hy],
        [x + hx, y - hy],
        [x + hx, y + hy],
        [x - hx, y + hy],
    ]
}

#[test]
fn a_relay_forms_where_an_obstacle_hides_the_goal() {
    let sc = shipped("qm-middle.toml");
    let mut firsts = 0;
    for seed in 1..=3 {
        let (eps, _) = episodes(&sc, seed, 300.0);
        assert!(!eps.is_empty(), "seed {seed}: no relay formed in 300 s");
        let run = start(&sc, seed);
        let w = &run.world;
        let goal = w.goal().unwrap();
        let wall = &w.walls[4];
        let grown = rect(wall.center, wall.size, 0.1);
        // The first relay of a run can only have lost the real goal (no other goal colour is
        // shown yet): the obstacle stands between it and the goal.
        let first = &eps[0];
        let p = |v: Vec2| [f64::from(v.x), f64::from(v.y)];
        assert!(
            crosses(&grown, p(first.at), p(goal)),
            "seed {seed}: robot {} relayed at ({:.2}, {:.2}) at {:.1} s with a clear view of \
             the goal",
            first.robot,
            first.at.x,
            first.at.y,
            first.begin_s
        );
        firsts += 1;
    }
    assert_eq!(firsts, 3);
}

#[test]
fn a_relay_dissolves_when_the_object_arrives() {
    // The 0.4 m square, its surface 0.2 to 0.283 m from its centre. A relay leaves when its
    // colour scan puts the object within `relay.release_m` (0.1 m) of its body: relays end
    // with the object's centre within 0.5 m, and none stays on for more than 2 s once the true
    // gap between its body and the object's surface is under 0.1 m (scan bins and noise
    // delay it by a tick or so).
    let sc = shipped("qm-middle.toml");
    let (mut arrivals, mut reached) = (0, 0);
    for seed in 1..=4 {
        let (eps, _) = episodes(&sc, seed, 1200.0);
        for e in &eps {
            let (_, last) = *e.near.last().unwrap();
            if e.ended && last <= 0.5 {
                arrivals += 1;
            }
            if let Some(k) = e.gap.iter().position(|d| *d < 0.1) {
                reached += 1;
                let (t0, _) = e.near[k];
                let (t_last, _) = *e.near.last().unwrap();
                assert!(
                    e.ended && t_last - t0 <= 2.0,
                    "seed {seed}: robot {} still relays {:.1} s after the object came within \
                     0.1 m",
                    e.robot,
                    t_last - t0
                );
            }
        }
    }
    assert!(
        arrivals > 0 && reached > 0,
        "in 4 runs, {arrivals} relays ended with the object at them, {reached} had it within \
         0.1 m"
    );
}

/// The shipped map `file` with the study's H for its object and `count` robots running
/// `fill-transport` (with the map's relays).
fn fill_transport_h(file: &str, count: usize) -> Scenario {
    let h = "[[-0.2, -0.2], [-0.1, -0.2], [-0.1, -0.05], [0.1, -0.05], [0.1, -0.2], \
             [0.2, -0.2], [0.2, 0.2], [0.1, 0.2], [0.1, 0.05], [-0.1, 0.05], [-0.1, 0.2], \
             [-0.2, 0.2]]";
    let text = shipped_text(file)
        .replace(
            "shape = { box = [0.4, 0.4] }",
            &format!("shape = {{ polygon = {h} }}"),
        )
        .replace("count = 20", &format!("count = {count}"))
        .replace(
            "controller = \"occlusion\"",
            "controller = \"fill-transport\"",
        );
    Scenario::parse(&text, file).unwrap()
}

/// How seed `seed` of `sc` ends, run to its end ("Success", "Timeout", ...).
fn outcome(sc: &Scenario, seed: u64) -> String {
    format!("{:?}", start(sc, seed).run_to_end())
}

#[test]
fn relays_bring_the_object_round_the_corner() {
    // Issue 14's corner map: the object and the goal either side of a wall from the west
    // wall. With relays the object goes round the wall's free end. Seed 1 timed out before
    // pushers checked in their colour scan that the object, not the wall, hides the goal
    // (`relay.occlusion_bins`) and went round the shorter way: the object was pushed into the
    // wall's end and the arena's east wall.
    let sc = shipped("qm-corner.toml");
    for seed in 1..=4 {
        assert_eq!(outcome(&sc, seed), "Success", "seed {seed}");
    }
}

#[test]
fn a_chain_of_relays_reaches_an_object_in_a_closed_compartment() {
    // Queiroz and MacRae's two-corners map: the object's compartment, below the first wall,
    // is hidden from everything that sees the goal. Relays must form out of sight of the
    // object (`relay.blind_after_s`); with that switched off none ever forms and the object
    // never moves (0 of 50 before). Seeds that succeed in the study (seed 1 did until
    // pushers slid, results format 9).
    let sc = shipped("qm-two-corners.toml");
    for seed in [7, 49] {
        assert_eq!(outcome(&sc, seed), "Success", "seed {seed}");
    }
    let text = shipped_text("qm-two-corners.toml").replace(
        "params = { relays = true }",
        "params = { relays = true, relay = { blind_after_s = 1e9 } }",
    );
    let sc = Scenario::parse(&text, "qm-two-corners.toml").unwrap();
    let (eps, outcome) = episodes(&sc, 1, 600.0);
    assert!(eps.is_empty(), "{} relays without blind relays", eps.len());
    assert_eq!(outcome, None);
}

#[test]
fn no_relay_forms_in_the_open_map() {
    let sc = shipped("qm-open.toml");
    for seed in 1..=3 {
        let (eps, outcome) = episodes(&sc, seed, 1200.0);
        assert!(
            eps.is_empty(),
            "seed {seed}: {} relays in the open map, the first robot {} at {:.1} s",
            eps.len(),
            eps[0].robot,
            eps[0].begin_s
        );
        assert_eq!(outcome.as_deref(), Some("Success"), "seed {seed}");
    }
}

#[test]
fn relays_are_off_by_default() {
    // The middle map with `occlusion`'s default parameters instead of its `relays = true`: no
    // relay forms.
    let sc = shipped_with("qm-middle.toml", &[("robots.0.params", "{}")]);
    let (eps, _) = episodes(&sc, 1, 120.0);
    assert!(eps.is_empty());
}

#[test]
fn a_moving_goal_follows_its_schedule() {
    // No stop rule: the run lasts past the schedule's middle whatever the robots do.
    let sc = shipped_with("qm-moving-goal.toml", &[("stop.on_goal", "false")]);
    let mut run = start(&sc, 1);
    let g0 = run.world.goal().unwrap();
    assert_eq!((g0.x, g0.y), (1.0, 1.0));
    while run.world.time_s < 90.0 - 1e-9 {
        assert!(run.step().is_none(), "stopped at {} s", run.world.time_s);
    }
    // Halfway from (1, 1) at 30 s to (1, -1) at 150 s.
    let g = run.world.goal().unwrap();
    assert!((g.x - 1.0).abs() < 1e-4 && g.y.abs() < 1e-3, "{g:?}");
    let spec = &sc.spec.lights[0];
    let at = |t: f32| spec.get_ref().position_at(t);
    assert_eq!(at(0.0), [1.0, 1.0]);
    assert_eq!(at(30.0), [1.0, 1.0]);
    assert_eq!(at(90.0), [1.0, 0.0]);
    assert_eq!(at(120.0), [1.0, -0.5]);
    assert_eq!(at(1000.0), [1.0, -1.0]);
}

#[test]
fn a_bad_goal_schedule_is_refused_at_its_key() {
    let base = shipped_text("qm-moving-goal.toml");
    let back = base.replace(
        "path = [[30.0, 1.0, 1.0], [150.0, 1.0, -1.0]]",
        "path = [[30.0, 1.0, 1.0], [20.0, 1.0, -1.0]]",
    );
    let e = Scenario::parse(&back, "m.toml").unwrap_err().to_string();
    assert!(
        e.contains("lights[0].path[1]") && e.contains("increasing"),
        "{e}"
    );
    let far = base.replace(
        "path = [[30.0, 1.0, 1.0], [150.0, 1.0, -1.0]]",
        "path = [[30.0, 1.0, 1.0], [150.0, 1.0, -1.0e9]]",
    );
    let e = Scenario::parse(&far, "m.toml").unwrap_err().to_string();
    assert!(e.contains("lights[0].path[1][2]"), "{e}");
    let late = base.replace(
        "path = [[30.0, 1.0, 1.0], [150.0, 1.0, -1.0]]",
        "path = [[30.0, 1.0, 1.0], [1.0e9, 1.0, -1.0]]",
    );
    let e = Scenario::parse(&late, "m.toml").unwrap_err().to_string();
    assert!(e.contains("lights[0].path[1][0]"), "{e}");
    let short = base.replace(
        "path = [[30.0, 1.0, 1.0], [150.0, 1.0, -1.0]]",
        "path = [[30.0, 1.0]]",
    );
    assert!(Scenario::parse(&short, "m.toml").is_err());
}

/// Queiroz and MacRae's baseline: Chen's rule alone with their goal perception, the goal seen
/// by the camera as a coloured region, relays off (`goal_sensor = "camera"`).
const CHEN_CAMERA: &str = "params = { relays = false, goal_sensor = \"camera\", \
                           occluder_angle_deg = 180.0, push_goal_bias_deg = 0.0 }";

#[test]
fn chens_rule_with_the_camera_goal_completes_the_open_map_without_relays() {
    // With the light ring, a neighbour 1.5 cm above the floor hides the goal as the object
    // does, and Chen's rule alone completed 2 of these 4 seeds (46 % of seeds 1 to 50). With
    // the goal seen by the camera (robots are shorter than the goal region), all 4.
    let text = shipped_text("qm-open.toml").replace("params = { relays = true }", CHEN_CAMERA);
    let sc = Scenario::parse(&text, "qm-open.toml").unwrap();
    for seed in 1..=4 {
        let (eps, outcome) = episodes(&sc, seed, 1200.0);
        assert!(
            eps.is_empty(),
            "seed {seed}: a relay formed with relays off"
        );
        assert_eq!(outcome.as_deref(), Some("Success"), "seed {seed}");
    }
}

#[test]
fn chens_rule_with_the_camera_goal_fails_the_corner_map() {
    // Nothing leads the object round the wall: it stays in its corner.
    let text = shipped_text("qm-corner.toml").replace("params = { relays = true }", CHEN_CAMERA);
    let sc = Scenario::parse(&text, "qm-corner.toml").unwrap();
    for seed in 1..=2 {
        assert_ne!(outcome(&sc, seed), "Success", "seed {seed}");
    }
}

#[test]
fn relays_need_the_camera_goal() {
    let text = shipped_text("qm-open.toml").replace(
        "params = { relays = true }",
        "params = { relays = true, goal_sensor = \"light\" }",
    );
    let sc = Scenario::parse(&text, "qm-open.toml").unwrap();
    let e = formica::World::new(&sc, &formica::Overrides::default())
        .err()
        .expect("relays with the light ring was accepted")
        .to_string();
    assert!(e.contains("goal_sensor"), "{e}");
}

#[test]
fn fillers_relay_on_their_way_to_the_object() {
    // fill-transport with relays, the H at N = 30 in the middle map: robots drive to the object
    // first, and none would wander (and relay) before filling is over, by when the object is
    // hidden in the crowd. Fillers that lose the goal behind the obstacle on their way relay,
    // before any robot pushes (in seeds 3 and 6 of 1 to 6 within 4 s; in 1 and 5 none does
    // in 120 s, in 2 and 4 a robot pushes first: with Queiroz and MacRae's angle test, a
    // filler that had the goal and the object on one side does not relay).
    let sc = fill_transport_h("qm-middle.toml", 30);
    for seed in [3, 6] {
        let mut run = start(&sc, seed);
        let mut relayed = None;
        while relayed.is_none() && run.world.time_s < 120.0 {
            run.step();
            let w = &run.world;
            assert!(
                w.robots.iter().all(|r| !r.state.starts_with("push")),
                "seed {seed}: a robot pushes at {:.1} s before any filler relayed",
                w.time_s
            );
            relayed = w.robots.iter().position(|r| r.state == "relay");
        }
        let i = relayed.unwrap_or_else(|| panic!("seed {seed}: no filler relayed in 120 s"));
        let w = &run.world;
        let wall = &w.walls[4];
        let p = |v: Vec2| [f64::from(v.x), f64::from(v.y)];
        assert!(
            crosses(
                &rect(wall.center, wall.size, 0.1),
                p(w.robot_pose(i).position()),
                p(w.goal().unwrap())
            ),
            "seed {seed}: robot {i} relayed with a clear view of the goal"
        );
    }
}

#[test]
fn fill_transport_with_relays_brings_the_h_round_the_corner() {
    // fill-transport with relays, the H on the corner map at N = 20: robots attached in the
    // H's cavities used to push toward where they last saw the goal light, north, across the
    // obstacle, and pinned the H against it (seeds 1 to 15 of 20 timed out, 3 and 4 among
    // them). Pushing toward the goal their camera shows (a relay or the goal) brings it round.
    let sc = fill_transport_h("qm-corner.toml", 20);
    for seed in [3, 4] {
        assert_eq!(outcome(&sc, seed), "Success", "seed {seed}");
    }
}
