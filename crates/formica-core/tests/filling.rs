//! The `filling` controller's stop rule and the attachment it leads to.

mod common;

use common::{robot_group, scenario, shipped_with, start};
use formica::experiment::Run;
use formica::geometry::Vec2;

/// The seed's U (opening toward -x), static, 0.3 m tall, with the beacon light above it.
const U: &str = r#"
[[lights]]
at = [-0.8, 0.0]
height = 0.9
intensity = 10.0
goal = false

[[objects]]
name = "U"
movable = false
height = 0.3
parts = [
  { box = [0.5, 0.2], at = [-1.0, 0.4] },
  { box = [0.5, 0.2], at = [-1.0, -0.4] },
  { box = [0.2, 1.0], at = [-0.75, 0.0] },
]
"#;

/// A static 0.6 m square box at the origin, 0.3 m tall, with the beacon light above it.
const BOX: &str = r#"
[[lights]]
at = [0.0, 0.0]
height = 0.9
intensity = 10.0
goal = false

[[objects]]
name = "box"
movable = false
height = 0.3
shape = { box = [0.6, 0.6] }
"#;

fn filling_robots(poses: &[[f32; 3]], params: &str) -> String {
    robot_group("filling", params, poses)
}

/// Red, still, unattached robots: moving neighbours as the camera sees them.
fn red_neighbours(poses: &[[f32; 3]]) -> String {
    robot_group("constant", "left = 0.0, right = 0.0, led = \"red\"", poses)
}

fn run_for(run: &mut Run, seconds: f64) {
    while run.world.time_s < seconds && run.step().is_none() {}
}

#[test]
fn a_robot_in_a_cavity_corner_stops_and_attaches() {
    // Inner corner of the U at (-0.85, 0.3); the robot starts 3 cm off both walls, facing
    // the base wall.
    let body = format!("{U}{}", filling_robots(&[[-0.95, 0.2, 20.0]], ""));
    let sc = scenario(&body);
    let mut run = start(&sc, 1);
    run_for(&mut run, 30.0);
    let r = &run.world.robots[0];
    assert!(r.attached.is_some(), "state {}", r.state);
    assert_eq!(r.state, "stopped");
    assert_eq!(r.led, formica::scenario::Color::Blue);
}

/// How far from the spot that touches both walls of the U's inner corner a filler attaches
/// (with `params`) after following the inner face of the top arm east from `x`.
fn settles_from(x: f32, params: &str) -> f32 {
    // Inner corner of the U at (-0.85, 0.3); the robot 3 cm below the arm, the arm on its left.
    let body = format!("{U}{}", filling_robots(&[[x, 0.2, 0.0]], params));
    let mut run = start(&scenario(&body), 1);
    run_for(&mut run, 40.0);
    let r = &run.world.robots[0];
    assert!(r.attached.is_some(), "state {}", r.state);
    let p = run.world.robot_pose(0).position();
    let radius = formica::robot::RobotModel::khepera4().radius;
    let apex = formica::geometry::Vec2::new(-0.85 - radius, 0.3 - radius);
    (p - apex).length()
}

#[test]
fn a_filler_settles_in_the_apex_of_a_corner_not_where_it_first_feels_it() {
    // The stop test passes with the corner's far wall about 10 cm ahead; creeping toward what
    // the ring sees but does not touch takes the robot into the apex.
    let off = settles_from(-1.15, "");
    // The Khepera IV's ring reads 1 at any gap under 4 cm, so "touching" means within about
    // 4 cm of each wall: up to 0.057 m from the apex spot.
    assert!(off < 0.055, "attached {off:.3} m from the corner's apex");
    // Creeping toward the summed readings (the wall beside it dominates) stops it short.
    let off_old = settles_from(-1.15, "creep_into_gaps = false");
    assert!(
        off_old > off + 0.02,
        "old creep {off_old:.3} m, new {off:.3} m"
    );
}

#[test]
fn robots_fill_the_corner_of_the_seeds_l_with_three_discs_wholly_inside() {
    // The seed's L (analysis 3) with the noise preset: its cavity holds 4 discs in a lattice;
    // robots that settle one by one put 3 wholly inside (creeping into the summed readings
    // left them short of the corner: 2).
    let sc = common::shipped("seed-fill-l.toml");
    for seed in 1..=3 {
        let mut run = start(&sc, seed);
        run.run_to_end();
        let res = run.result();
        assert_eq!(res.cavity_capacity, Some(4));
        assert!(
            res.cavity_robots >= Some(3),
            "seed {seed}: {:?}",
            res.cavity_robots
        );
        assert_eq!(res.false_stops, Some(0), "seed {seed}");
        // `cavity_centres`, counted again by plain geometry: attached robots whose centre lies
        // inside the hull and outside both of the L's parts. It counts every robot wholly
        // inside, and the robots astride the cavity's mouth too.
        let w = &run.world;
        let hull = formica::metrics::object_hull(w, 0);
        let parts = w.object_outlines(0);
        let centred = (0..w.robots.len())
            .filter(|i| w.robots[*i].attached.is_some())
            .map(|i| w.robot_pose(i).position())
            .filter(|p| inside_polygon(*p, &hull) && !parts.iter().any(|r| inside_polygon(*p, r)))
            .count();
        assert_eq!(res.extra["cavity_centres"], centred, "seed {seed}");
        assert!(centred >= res.cavity_robots.unwrap(), "seed {seed}");
    }
}

#[test]
fn a_robot_beside_a_flat_wall_does_not_stop() {
    // Beside the box's east face, then free to follow its (convex) outline for two minutes.
    let body = format!("{BOX}{}", filling_robots(&[[0.38, 0.0, 90.0]], ""));
    let sc = scenario(&body);
    for seed in 1..=3 {
        let mut run = start(&sc, seed);
        run_for(&mut run, 120.0);
        assert!(run.world.robots[0].attached.is_none(), "seed {seed}");
    }
}

#[test]
fn a_robot_among_neighbours_only_does_not_stop() {
    // Boxed in by three still red robots (behind, left and right), far from the object.
    let me = [1.5, 1.0, 0.0];
    let others = [[1.35, 1.0, 0.0], [1.5, 1.15, 0.0], [1.5, 0.85, 0.0]];
    let body = format!(
        "{BOX}{}{}",
        filling_robots(&[me], ""),
        red_neighbours(&others)
    );
    let sc = scenario(&body);
    let mut run = start(&sc, 1);
    // For 15 s, three times the check (`hold_s`, 4.5 s) it would need to attach: it never
    // starts one, and never attaches (the box is 1.1 m away).
    for _ in 0..150 {
        run.step();
        assert_ne!(
            run.world.robots[0].state, "check",
            "at {} s",
            run.world.time_s
        );
        assert!(run.world.robots[0].attached.is_none());
    }
}

#[test]
fn neighbours_against_a_wall_fool_the_seed_rule_but_not_the_fixed_one() {
    // A robot beside the box's flat east face, a red neighbour just ahead and one just behind:
    // wall plus neighbours light 4 or more sensors.
    let me = [0.375, 0.0, 90.0];
    let others = [[0.375, 0.145, 90.0], [0.375, -0.145, 90.0]];
    let seed_rule = "filter_neighbours = false, require_object = false";
    let fooled = |params: &str| {
        let body = format!(
            "{BOX}{}{}",
            filling_robots(&[me], params),
            red_neighbours(&others)
        );
        let sc = scenario(&body);
        let mut run = start(&sc, 1);
        run_for(&mut run, 10.0);
        run.world.robots[0].attached.is_some()
    };
    assert!(fooled(seed_rule), "the seed's rule should stop here");
    assert!(!fooled(""), "the fixed rule should not stop here");
}

#[test]
fn attached_robots_move_with_the_object() {
    // A movable 0.5 m box (light, little friction); one robot attaches to its north face, two
    // push it eastward from the west; the attached one must ride along.
    let body = r#"
[[objects]]
at = [0.0, 0.0]
shape = { box = [0.5, 0.5] }
mass = 2.0
height = 0.3
floor_mu = 0.05

[[robots]]
controller = "constant"
params = { left = 0.0, right = 0.0, attach = true, led = "blue" }
placement = { poses = [[0.0, 0.33, 0.0]] }

[[robots]]
controller = "constant"
params = { left = 0.1, right = 0.1 }
placement = { poses = [[-0.33, 0.1, 0.0], [-0.33, -0.1, 0.0]] }
"#;
    let sc = scenario(body);
    let mut run = start(&sc, 1);
    run_for(&mut run, 0.5);
    assert!(run.world.robots[0].attached.is_some(), "did not attach");
    let obj0 = run.world.object_center(0);
    // In the object's frame: the braking robot turns the box as it is dragged.
    let rel0 = run
        .world
        .object_pose(0)
        .local_from_world(run.world.robot_pose(0).position());
    run_for(&mut run, 8.0);
    let obj1 = run.world.object_center(0);
    let moved = (obj1 - obj0).length();
    assert!(moved > 0.2, "box moved only {moved} m");
    let rel1 = run
        .world
        .object_pose(0)
        .local_from_world(run.world.robot_pose(0).position());
    assert!(
        (rel1 - rel0).length() < 0.01,
        "attached robot slid by {} m",
        (rel1 - rel0).length()
    );
}

/// A static U whose cavity is `width` wide (y) and 0.4 m deep (x), closed at +x; its hull is
/// the 0.5 x (width + 0.2) m rectangle around it.
fn u_of_width(width: f32) -> String {
    let arm_y = width / 2.0 + 0.05;
    format!(
        r#"
[[objects]]
movable = false
parts = [
  {{ box = [0.1, {h}], at = [0.2, 0.0] }},
  {{ box = [0.4, 0.1], at = [-0.05, {arm_y}] }},
  {{ box = [0.4, 0.1], at = [-0.05, -{arm_y}] }},
]
"#,
        h = width + 0.2
    )
}

fn capacity_of(body: &str) -> usize {
    let sc = scenario(&format!(
        "{body}{}",
        robot_group("constant", "left = 0.0", &[[2.0, 1.0, 0.0]])
    ));
    let run = start(&sc, 1);
    formica::metrics::cavity_capacity(&run.world, 0, 0.0704)
}

#[test]
fn cavity_capacity_counts_the_discs_that_fit() {
    // 0.3 x 0.4 m: disc centres range over 0.159 x 0.259 m; a hexagonal packing puts rows of
    // 2, 1 and 2 along the depth (5), a square one only 2 x 2; 6 do not fit.
    assert_eq!(capacity_of(&u_of_width(0.3)), 5);
    // Narrower than a robot (0.1408 m): nothing fits.
    assert_eq!(capacity_of(&u_of_width(0.13)), 0);
    // A convex object has no cavity.
    assert_eq!(
        capacity_of("[[objects]]\nmovable = false\nshape = { box = [0.5, 0.5] }\n"),
        0
    );
    // The seed's U: 0.6 x 0.4 m, disc centres over 0.459 x 0.259 m: hexagonal rows of 4, 3
    // and 4 along the base (0.244 m of depth), 11; 12 would need a fourth row or rows of 4.
    let u = r#"
[[objects]]
movable = false
parts = [
  { box = [0.5, 0.2], at = [-1.0, 0.4] },
  { box = [0.5, 0.2], at = [-1.0, -0.4] },
  { box = [0.2, 1.0], at = [-0.75, 0.0] },
]
"#;
    assert_eq!(capacity_of(u), 11);
    // One polygon with a notch 0.22 m wide and 0.2 m deep: centres range over 0.079 x 0.059 m,
    // so one disc fits, not two.
    let notched = r#"
[[objects]]
movable = false
shape = { polygon = [[-0.3, -0.3], [0.3, -0.3], [0.3, -0.11], [0.1, -0.11], [0.1, 0.11], [0.3, 0.11], [0.3, 0.3], [-0.3, 0.3]] }
"#;
    assert_eq!(capacity_of(notched), 1);
    // A five-point star (points 0.5 m, notches 0.22 m from its centre): one disc fits in each
    // notch, with 12 to 14 mm to spare, and no lattice puts one in all five (they read 3, and
    // 5 robots attached in them in every run of an audit).
    let star = r#"
[[objects]]
movable = false
shape = { polygon = [[0.0, 0.5], [-0.1293, 0.178], [-0.4755, 0.1545], [-0.2092, -0.068], [-0.2939, -0.4045], [0.0, -0.22], [0.2939, -0.4045], [0.2092, -0.068], [0.4755, 0.1545], [0.1293, 0.178]] }
"#;
    assert_eq!(capacity_of(star), 5);
}

#[test]
fn cavity_capacity_finds_pockets_smaller_than_its_grid() {
    // A six-point star drawn at random (`python3 experiments/random-cases.py 9`, shape 3):
    // one disc fits wholly inside each of its six pockets, with room for its centre of a few
    // millimetres, which the packing's grid (a quarter radius, 17.6 mm) missed in three of
    // them: capacity 3, while fillers got 5 or 6 robots wholly inside in 8 runs of 10.
    let body = "[[objects]]\nmovable = false\nyaw_deg = 71.3\nshape = { polygon = [[0.409, \
                0.038], [0.171, 0.077], [0.186, 0.366], [0.011, 0.188], [-0.23, 0.34], [-0.16, \
                0.1], [-0.409, -0.032], [-0.169, -0.082], [-0.175, -0.371], [0.0, -0.188], \
                [0.21, -0.352], [0.164, -0.093]] }\n";
    let sc = scenario(&format!(
        "{body}{}",
        robot_group("constant", "left = 0.0", &[[2.0, 1.0, 0.0]])
    ));
    let run = start(&sc, 1);
    let (world, r) = (&run.world, 0.0704);
    // By the definition, on a 0.5 mm grid round each pocket's deepest point (the star's inner
    // vertices, turned as the object): every centre that fits, grouped by pocket.
    let hull = formica::metrics::object_hull(world, 0);
    let inner = world.object_outlines(0)[0]
        .iter()
        .copied()
        .enumerate()
        .filter(|(i, _)| i % 2 == 1)
        .map(|(_, v)| v)
        .collect::<Vec<_>>();
    assert_eq!(inner.len(), 6);
    let mut rooms = Vec::new();
    for apex in inner {
        let mut room: Vec<Vec2> = Vec::new();
        for iy in -240..=240 {
            for ix in -240..=240 {
                let p = apex + Vec2::new(ix as f32, iy as f32) * 5e-4;
                if formica::metrics::disc_in_cavity(world, 0, &hull, p, r) {
                    room.push(p);
                }
            }
        }
        rooms.push(room);
    }
    // A disc fits in each pocket, and never two: every pocket's room is narrower than a disc.
    for (k, room) in rooms.iter().enumerate() {
        assert!(!room.is_empty(), "pocket {k}: no room");
        let across = room
            .iter()
            .flat_map(|a| room.iter().map(move |b| (*a - *b).length()))
            .fold(0.0f32, f32::max);
        assert!(across < 2.0 * r, "pocket {k}: room {across} m across");
    }
    assert_eq!(formica::metrics::cavity_capacity(world, 0, r), 6);
}

#[test]
fn cavity_capacity_counts_only_room_a_robot_can_reach() {
    // A bottle: a 0.6 x 0.6 m room behind a mouth `mouth` m wide in a 0.1 m thick wall, open
    // at +x. The room alone holds 16 discs of 0.0704 m (centres over 0.459 m each way: a
    // square lattice of 4 x 4; a hexagonal one has room for rows of 4 and 3 only).
    let bottle = |mouth: f32| {
        let m = mouth / 2.0;
        format!(
            r#"
[[objects]]
movable = false
shape = {{ polygon = [[-0.4, -0.4], [0.4, -0.4], [0.4, -{m}], [0.3, -{m}], [0.3, -0.3], [-0.3, -0.3], [-0.3, 0.3], [0.3, 0.3], [0.3, {m}], [0.4, {m}], [0.4, 0.4], [-0.4, 0.4]] }}
"#
        )
    };
    // Mouths narrower than a robot (0.1408 m) by more than the 7 mm allowance: nothing.
    assert_eq!(capacity_of(&bottle(0.12)), 0);
    assert_eq!(capacity_of(&bottle(0.05)), 0);
    // Wide enough: the room fills, as it did before reach was asked.
    let open = capacity_of(&bottle(0.16));
    assert_eq!(open, 16, "{open}");
    assert_eq!(open, capacity_of(&bottle(0.2)));
    // A closed square frame of four bars holds nothing; open one side by 0.2 m and it does.
    let frame = |gap: f32| {
        let g = gap / 2.0;
        let side = 0.5 - g;
        let at = g + side / 2.0;
        format!(
            r#"
[[objects]]
movable = false
parts = [
  {{ box = [0.1, 1.0], at = [-0.45, 0.0] }},
  {{ box = [1.0, 0.1], at = [0.0, 0.45] }},
  {{ box = [1.0, 0.1], at = [0.0, -0.45] }},
  {{ box = [0.1, {side}], at = [0.45, {at}] }},
  {{ box = [0.1, {side}], at = [0.45, -{at}] }},
]
"#
        )
    };
    assert_eq!(capacity_of(&frame(0.0)), 0);
    let open = capacity_of(&frame(0.2));
    // The 0.8 m square inside holds 6 hexagonal rows of 5 (30), one more in the opening.
    assert!(open >= 30, "{open}");
}

#[test]
fn deepest_first_packing_keeps_discs_apart_and_inside() {
    // In a 1 x 0.3 m rectangle every disc of 0.07 m fits where its centre is 0.07 m from the
    // sides: one row along the middle, 1 + floor(0.86 / 0.14) = 7 discs.
    let hull = [
        Vec2::new(0.0, 0.0),
        Vec2::new(1.0, 0.0),
        Vec2::new(1.0, 0.3),
        Vec2::new(0.0, 0.3),
    ];
    let n = formica::metrics::pack_deepest_first(&hull, 0.07, |_| f32::INFINITY, |_| true);
    // Deepest first fills the middle line first (depth 0.15), then what is left beside it: on
    // a grid of 0.0175 m, at least 6 and never more than the 7 that fit.
    assert!((6..=7).contains(&n), "{n}");
    // Nothing fits where `fits` refuses everything.
    assert_eq!(
        formica::metrics::pack_deepest_first(&hull, 0.07, |_| f32::NEG_INFINITY, |_| false),
        0
    );
}

#[test]
fn lattice_packing_examines_a_bounded_number_of_points() {
    // A 20 m square: every rotation, offset and edge of the small objects' packing would test
    // some 13 million lattice points against the object; the trials thin out to stay within
    // `MAX_PACKING_WORK` points in all, and still find the discs a lattice holds.
    let hull = [
        Vec2::new(-10.0, -10.0),
        Vec2::new(10.0, -10.0),
        Vec2::new(10.0, 10.0),
        Vec2::new(-10.0, 10.0),
    ];
    let edges: Vec<(Vec2, Vec2)> = (0..4).map(|i| (hull[i], hull[(i + 1) % 4])).collect();
    let tested = std::cell::Cell::new(0usize);
    let inside = |p: Vec2| p.x.abs() <= 9.93 && p.y.abs() <= 9.93;
    let n = formica::metrics::pack_discs(&hull, 0.07, &edges, |p| {
        tested.set(tested.get() + 1);
        inside(p)
    });
    assert!(
        tested.get() <= formica::metrics::MAX_PACKING_WORK,
        "{} points tested",
        tested.get()
    );
    // Centres range over 19.86 m each way: a square lattice of spacing 0.14 m along an edge
    // holds 142 x 142; a hexagonal one more.
    assert!(n >= 142 * 142, "{n}");
}

#[test]
fn a_robot_outside_the_u_does_not_stop_against_its_back() {
    // Against the outside of the U's back wall (the seed's false stop), with a red neighbour
    // ahead and one behind so that 4 sensors fire: the object does not surround the robot.
    let me = [-0.575, 0.0, 90.0];
    let others = [[-0.575, 0.145, 90.0], [-0.575, -0.145, 90.0]];
    let body = format!(
        "{U}{}{}",
        filling_robots(&[me], "filter_neighbours = false"),
        red_neighbours(&others)
    );
    let mut run = start(&scenario(&body), 1);
    run_for(&mut run, 10.0);
    assert!(run.world.robots[0].attached.is_none());
    // The seed's rule stops there.
    let body = format!(
        "{U}{}{}",
        filling_robots(&[me], "filter_neighbours = false, require_object = false"),
        red_neighbours(&others)
    );
    let mut run = start(&scenario(&body), 1);
    run_for(&mut run, 10.0);
    assert!(run.world.robots[0].attached.is_some());
}

/// Distance from `p` to the segment `a`-`b`.
fn segment_distance(
    p: formica::geometry::Vec2,
    a: formica::geometry::Vec2,
    b: formica::geometry::Vec2,
) -> f32 {
    let e = b - a;
    let t = ((p - a).dot(e) / e.dot(e)).clamp(0.0, 1.0);
    (p - (a + e * t)).length()
}

/// Whether `p` lies inside the simple polygon `ring` (even-odd rule).
fn inside_polygon(p: formica::geometry::Vec2, ring: &[formica::geometry::Vec2]) -> bool {
    let mut inside = false;
    for i in 0..ring.len() {
        let (a, b) = (ring[i], ring[(i + 1) % ring.len()]);
        if (a.y > p.y) != (b.y > p.y) && p.x < a.x + (p.y - a.y) / (b.y - a.y) * (b.x - a.x) {
            inside = !inside;
        }
    }
    inside
}

#[test]
fn every_disc_the_capacity_counts_clears_the_object_at_any_turn() {
    // The notched polygon turned through 48 headings and moved off the origin: each disc the
    // packing counts lies outside the polygon and at least a radius (less the slack) from each
    // of its edges, by plain geometry rather than the physics engine's queries.
    let r = 0.0704;
    for k in 0..48 {
        let yaw = 7.5 * k as f32;
        let body = format!(
            "[[objects]]\nmovable = false\nat = [0.37, -0.21]\nyaw_deg = {yaw}\nshape = {{ polygon = [[-0.3, -0.3], [0.3, -0.3], [0.3, -0.11], [0.1, -0.11], [0.1, 0.11], [0.3, 0.11], [0.3, 0.3], [-0.3, 0.3]] }}\n"
        );
        let sc = scenario(&format!(
            "{body}{}",
            robot_group("constant", "left = 0.0", &[[2.0, 1.0, 0.0]])
        ));
        let run = start(&sc, 1);
        let w = &run.world;
        let hull = formica::metrics::object_hull(w, 0);
        let ring = w.object_outlines(0)[0].clone();
        let mut edges = Vec::new();
        for ring in w.object_outlines(0).iter().chain(std::iter::once(&hull)) {
            for i in 0..ring.len() {
                edges.push((ring[i], ring[(i + 1) % ring.len()]));
            }
        }
        let counted = std::cell::RefCell::new(Vec::new());
        let n = formica::metrics::pack_discs(&hull, r, &edges, |p| {
            let fits = formica::metrics::disc_in_cavity(w, 0, &hull, p, r);
            if fits {
                counted.borrow_mut().push(p);
            }
            fits
        });
        assert_eq!(n, 1, "yaw {yaw}: {n} discs in a notch that holds one");
        for p in counted.into_inner() {
            assert!(
                !inside_polygon(p, &ring),
                "yaw {yaw}: {p:?} inside the object"
            );
            let clear = (0..ring.len())
                .map(|i| segment_distance(p, ring[i], ring[(i + 1) % ring.len()]))
                .fold(f32::INFINITY, f32::min);
            let slack = formica::metrics::CAVITY_SLACK_M;
            assert!(
                clear >= r - slack - 1e-4,
                "yaw {yaw}: {p:?} {clear} from the object"
            );
        }
    }
}

#[test]
fn followers_turn_into_a_notch_a_robot_and_a_half_wide() {
    // A notched rectangle drawn at random (`python3 experiments/random-cases.py 10`, shape 2):
    // one notch 0.206 m wide and 0.185 m deep, turned away from where the robots arrive, so
    // that they reach it only by following the edge. With `follow_gain` 2 the followers rounding
    // its mouth swung wide, met the far side and followed it out: in 8 of seeds 1-10 (2 and 3
    // among them) no robot ever attached. With 3 one settles wholly inside in all ten.
    let notched = "[{ polygon = [[-0.295, -0.333], [-0.083, -0.333], [-0.083, -0.148], \
                   [0.123, -0.148], [0.123, -0.333], [0.295, -0.333], [0.295, 0.333], \
                   [-0.295, 0.333]], yaw_deg = 25.9, at = [-0.8, 0.0] }]";
    let sc = shipped_with("seed-fill-u.toml", &[("objects.0.parts", notched)]);
    for seed in [2, 3] {
        let mut run = start(&sc, seed);
        run.run_to_end();
        let r = run.result();
        assert_eq!(r.cavity_capacity, Some(1));
        assert_eq!(r.cavity_robots, Some(1), "seed {seed}");
        assert_eq!(r.false_stops, Some(0), "seed {seed}");
    }
}

#[test]
fn fillers_settle_wholly_inside_the_pockets_of_a_star() {
    // A six-point star drawn at random (`experiments/random-seed8.toml`, shape 1) in the seed's
    // static set-up: one disc fits wholly inside each of its six pockets. With a 1.5 s check
    // the ten fillers attached six in the pockets but every one 1.5 to 2 cm short of the hull
    // (the ring reads 1.0 at any gap under 4 cm), so none counted (0 of 60 over seeds 1-10);
    // creeping for the 4.5 s check takes them in (56 of 60).
    let star = "[{ at = [-0.8, 0.0], yaw_deg = 223.3, polygon = [[0.373, 0.025], [0.122, 0.058], \
                [0.204, 0.314], [0.013, 0.135], [-0.172, 0.332], [-0.116, 0.07], [-0.373, -0.03], \
                [-0.119, -0.065], [-0.212, -0.309], [-0.007, -0.135], [0.218, -0.304], \
                [0.111, -0.078]] }]";
    let sc = shipped_with("seed-fill-u.toml", &[("objects.0.parts", star)]);
    let (mut inside, mut capacity) = (0, 0);
    for seed in [1, 2] {
        let mut run = start(&sc, seed);
        run.run_to_end();
        let r = run.result();
        assert_eq!(r.false_stops, Some(0), "seed {seed}");
        inside += r.cavity_robots.unwrap_or(0);
        capacity += r.cavity_capacity.unwrap_or(0);
    }
    assert_eq!(capacity, 12);
    assert!(
        inside >= 9,
        "{inside} of {capacity} wholly inside the pockets"
    );
}
