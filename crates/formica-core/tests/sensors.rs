//! Sensors read what geometry says.

mod common;
use common::*;
use formica::ops;
use formica::robot::RobotModel;
use formica::sensors::light_blocked;

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

#[test]
fn a_hidden_light_reads_the_ambient_level_not_zero() {
    let sc = scenario(&format!(
        "{LIGHT}{}{}",
        seed_box(0.0, 0.0),
        watcher_with(&[[-1.0, 0.0, 0.0]], "noise = \"realistic\"")
    ));
    let mut run = start(&sc, 1);
    run.world.step();
    let l = &run.world.robots[0].readings.light;
    let mean = l.iter().sum::<f32>() / l.len() as f32;
    assert!(l.iter().all(|v| *v > 0.0), "{l:?}");
    assert!((mean - 0.05).abs() < 0.02, "ambient {mean}: {l:?}");
    assert!(formica::controllers::occlusion::light_contrast(l) < 0.06);
}

#[test]
fn noise_on_each_sensor_has_the_preset_mean_and_spread() {
    // Ten still robots in a row 3 cm (body to wall) below the north wall, facing east: the
    // left sensor (+90 deg) sees the wall, the front light sensor the light, and the
    // positioning sensor their poses. 10^4 ticks give 10^5 samples of each sensor.
    let m = RobotModel::khepera4();
    let y = 1.95 - m.radius - 0.055;
    let poses: Vec<[f32; 3]> = (0..10).map(|i| [-2.0 + 0.3 * i as f32, y, 0.0]).collect();
    let light = format!("[[lights]]\nat = [2.9, {y}]\nheight = 1.0\nintensity = 10.0\n");
    let exact = {
        let sc = scenario(&format!("{light}{}", watcher(&poses)));
        let mut run = start(&sc, 1);
        run.world.step();
        run.world
            .robots
            .iter()
            .map(|r| r.readings.clone())
            .collect::<Vec<_>>()
    };
    let sc = scenario(&format!(
        "{light}{}",
        watcher_with(&poses, "noise = \"realistic\"")
    ));
    let cfg = formica::scenario::SensorOptions::default().resolve(m.kind);
    let nz = cfg.noise;
    let mut run = start(&sc, 3);
    let f = f64::from;
    let rel = |r: f32, fl: f32, x: f64| {
        let (a, b) = (f(r) * x, f(fl));
        (a * a + b * b).sqrt()
    };
    let (mut prox, mut lum, mut dx, mut dth) = (vec![], vec![], vec![], vec![]);
    for _ in 0..10_000 {
        run.world.step();
        for (i, r) in run.world.robots.iter().enumerate() {
            let e = &exact[i];
            prox.push(f64::from(r.readings.proximity[2] - e.proximity[2]));
            // Light: the exact reading plus the ambient level, then multiplicative plus floor;
            // normalised, as each robot sees the light at its own strength.
            let lit = f(e.light[0] + nz.ambient_light);
            let sd = rel(nz.light_noise, nz.light_floor, lit);
            lum.push((f(r.readings.light[0]) - lit) / sd);
            dx.push(f64::from(r.readings.pose.x - poses[i][0]));
            dth.push(f64::from(formica::geometry::wrap_angle(
                r.readings.pose.theta,
            )));
        }
    }
    let v = f64::from(exact[0].proximity[2]);
    assert!(v > 0.3 && v < 0.9, "wall reading {v}");
    for e in &exact {
        assert!(
            e.light[0] > 0.2 && e.light[0] < 0.8,
            "light reading {}",
            e.light[0]
        );
    }
    let within = |name: &str, got: (f64, f64), mean: f64, sd: f64| {
        eprintln!(
            "{name}: mean {:.5} (want {mean:.5}), sd {:.5} (want {sd:.5})",
            got.0, got.1
        );
        assert!(
            (got.0 - mean).abs() <= 0.05 * sd,
            "{name}: mean {} vs {mean}",
            got.0
        );
        assert!(
            (got.1 - sd).abs() <= 0.05 * sd,
            "{name}: sd {} vs {sd}",
            got.1
        );
    };
    // Proximity: multiplicative plus floor, around the exact reading.
    within(
        "proximity",
        common::moments(&prox),
        0.0,
        rel(nz.proximity_noise, nz.proximity_floor, v),
    );
    within("light (normalised)", common::moments(&lum), 0.0, 1.0);
    within("position", common::moments(&dx), 0.0, f(nz.position_noise));
    within("heading", common::moments(&dth), 0.0, f(nz.heading_noise));
}

#[test]
fn readings_are_clamped_where_the_hardware_saturates() {
    // Touching the wall: the exact reading is 1; noise never pushes it above.
    let m = RobotModel::khepera4();
    let sc = scenario(&watcher_with(
        &[[2.95 - m.radius - 0.01, 0.0, 0.0]],
        "noise = \"realistic\", proximity_noise = 0.5",
    ));
    let mut run = start(&sc, 1);
    for _ in 0..200 {
        run.world.step();
        let p = &run.world.robots[0].readings.proximity;
        assert!(p.iter().all(|v| (0.0..=1.0).contains(v)), "{p:?}");
    }
}

/// Robots whose controller reads the camera and the scan, LEDs lit in `led`.
fn camera_watchers(poses: &[[f32; 3]], led: &str) -> String {
    format!(
        "{}sensors = {{ noise = \"none\" }}\n",
        robot_group(
            "constant",
            &format!("left = 0.0, right = 0.0, led = \"{led}\", camera = true, scan = true"),
            poses,
        )
    )
}

/// Two steps: LEDs light up when the first decisions are acted on.
fn two_steps(sc: &formica::Scenario) -> formica::experiment::Run {
    let mut run = start(sc, 1);
    run.world.step();
    run.world.step();
    run
}

#[test]
fn the_blob_camera_sees_leds_in_sight_and_not_behind_the_box() {
    // Robot 0 faces east at (-1, 0). Robot 1 is north of it, in view; robot 2 sits behind the
    // 0.5 m tall box, hidden from robot 0.
    let sc = scenario(&format!(
        "{}{}",
        seed_box(0.0, 0.0),
        camera_watchers(
            &[[-1.0, 0.0, 0.0], [-1.0, 0.8, 0.0], [0.6, 0.0, 0.0]],
            "red"
        )
    ));
    let run = two_steps(&sc);
    let blobs = &run.world.robots[0].readings.blobs;
    assert_eq!(blobs.len(), 1, "only the LED in view: {blobs:?}");
    assert_eq!(blobs[0].color, formica::scenario::Color::Red);
    assert!((blobs[0].bearing - std::f32::consts::FRAC_PI_2).abs() < 0.01);
    // The distance is to the LED (the robot's centre).
    assert!(
        (blobs[0].distance - 0.8).abs() < 0.01,
        "{}",
        blobs[0].distance
    );
    // Robot 2, behind the box, sees neither (both lines of sight cross the box).
    let seen_by_2 = &run.world.robots[2].readings.blobs;
    assert!(seen_by_2.is_empty(), "seen through the box: {seen_by_2:?}");
    // With the box removed, robot 0 sees robot 2 as well.
    let sc = scenario(&camera_watchers(
        &[[-1.0, 0.0, 0.0], [-1.0, 0.8, 0.0], [0.4, 0.0, 0.0]],
        "red",
    ));
    let run = two_steps(&sc);
    assert_eq!(run.world.robots[0].readings.blobs.len(), 2);
}

#[test]
fn the_blob_camera_sees_no_object_bodies_but_the_oracle_does() {
    let body = |camera: &str| {
        format!(
            "{}{}sensors = {{ noise = \"none\", camera = \"{camera}\" }}\n",
            seed_box(0.0, 0.0),
            robot_group(
                "constant",
                "left = 0.0, right = 0.0, led = \"red\", camera = true",
                &[[-1.0, 0.0, 0.0]],
            )
        )
    };
    let run = two_steps(&scenario(&body("blob")));
    assert!(run.world.robots[0].readings.blobs.is_empty());
    let run = two_steps(&scenario(&body("oracle")));
    let b = &run.world.robots[0].readings.blobs;
    assert_eq!(b.len(), 1, "{b:?}");
    assert_eq!(b[0].color, formica::scenario::Color::Green);
    assert!((b[0].distance - 0.75).abs() < 0.01 && b[0].bearing.abs() < 0.01);
}

#[test]
fn the_colour_scan_shows_the_object_colour_where_the_object_is() {
    // Facing east at (-1, 0), the 0.5 m box spans bearings within atan(0.25 / 0.75) = 18.4 deg
    // of straight ahead; a red robot stands due north 0.5 m away, a wall 2 m to the south.
    let sc = scenario(&format!(
        "{}{}{}",
        seed_box(0.0, 0.0),
        camera_watchers(&[[-1.0, 0.0, 0.0]], "red"),
        camera_watchers(&[[-1.0, 0.5, 0.0]], "blue"),
    ));
    let run = two_steps(&sc);
    let r = &run.world.robots[0].readings;
    let layout = &run.world.groups[0].layout;
    assert_eq!(r.scan_color.len(), 36);
    for ((c, d), a) in r
        .scan_color
        .iter()
        .zip(&r.scan_range)
        .zip(&layout.scan_angles)
    {
        use formica::scenario::Color;
        let deg = a.to_degrees();
        if deg.abs() < 17.0 {
            assert_eq!(*c, Color::Green, "bin at {deg} deg");
            assert!(*d >= 0.74 && *d <= 0.82, "bin at {deg} deg: {d}");
        } else if deg.abs() > 20.0 && (deg - 90.0).abs() > 10.0 {
            assert_ne!(*c, Color::Green, "bin at {deg} deg");
        }
        if (deg - 90.0).abs() < 1.0 {
            assert_eq!(*c, Color::Blue, "the neighbour's LED");
            assert!((d - (0.5 - 0.0704)).abs() < 0.02, "{d}");
        }
    }
}

#[test]
fn no_reading_tells_a_robot_from_the_object_but_its_colour() {
    // A robot showing the object's own colour looks, to the scan and the camera, like
    // anything else of that colour: readings carry no identity. Only bearing, distance and
    // colour exist (this pattern stops compiling if a field is added to `Blob`).
    let formica::sensors::Blob {
        bearing: _,
        distance: _,
        color: _,
    } = formica::sensors::Blob {
        bearing: 0.0,
        distance: 1.0,
        color: formica::scenario::Color::Green,
    };
    let sc = scenario(&format!(
        "{}{}",
        camera_watchers(&[[-1.0, 0.0, 0.0]], "red"),
        camera_watchers(&[[-0.5, 0.0, 0.0]], "green"),
    ));
    let run = two_steps(&sc);
    let r = &run.world.robots[0].readings;
    assert_eq!(r.scan_color[0], formica::scenario::Color::Green);
    assert_eq!(r.blobs[0].color, formica::scenario::Color::Green);
}

#[test]
fn the_beacon_has_a_range_and_noise() {
    // Occlusion robots (beacon perception) 1.0 and 2.5 m from the box's centre; range 2 m.
    let body = format!(
        "{}{}sensors = {{ noise = \"none\", beacon_range = 2.0, beacon_noise = 0.02 }}\n",
        seed_box(0.0, 0.0),
        robot_group(
            "occlusion",
            "approach_speed = 0.001, search_speed = 0.001",
            &[[-1.0, 0.0, 0.0], [-2.5, 0.0, 0.0]]
        )
    );
    let sc = scenario(&body);
    let mut run = start(&sc, 1);
    let mut xs = Vec::new();
    for _ in 0..2000 {
        run.world.step();
        let near = run.world.robots[0].readings.beacon;
        assert!(
            run.world.robots[1].readings.beacon.is_none(),
            "beyond range"
        );
        let c = run.world.object_center(0);
        let b = near.unwrap_or_else(|| panic!("no beacon within range"));
        xs.push(f64::from(b.x - c.x));
    }
    let (mean, sd) = common::moments(&xs);
    assert!(
        mean.abs() < 0.002 && (sd - 0.02).abs() < 0.002,
        "{mean} {sd}"
    );
}

#[test]
fn check_warns_about_the_oracle_camera_and_exact_sensors() {
    let group = |sensors: &str| {
        format!(
            "{}sensors = {{ {sensors} }}\n",
            robot_group("constant", "camera = true", &[[0.0, 0.0, 0.0]])
        )
    };
    let warn = |sensors: &str| {
        let run = start(&scenario(&group(sensors)), 1);
        formica::world::sensor_warning(&run.world.groups[0])
    };
    let w = warn("camera = \"oracle\"").unwrap_or_default();
    assert!(w.contains("oracle"), "{w}");
    let w = warn("noise = \"none\"").unwrap_or_default();
    assert!(w.contains("exact"), "{w}");
    assert_eq!(warn("noise = \"realistic\""), None);
}

#[test]
fn every_reading_vector_lies_within_the_bounds_the_layout_gives() {
    // An arena away from the origin (unreleased robots read zeros), robots released one by one
    // that go for the box, and noise well above the preset's.
    let text = format!(
        "[arena]\nsize = [2.0, 1.5]\ncenter = [3.0, 2.0]\n\
         [[lights]]\nat = [3.9, 2.0]\nheight = 0.5\nintensity = 10.0\n\
         {}\
         [[robots]]\ncount = 6\ncontroller = \"occlusion\"\n\
         placement = {{ grid = {{ center = [2.25, 2.0], spacing = 0.2, columns = 1, heading_deg = 0.0 }} }}\n\
         release = {{ interval_s = 2.0 }}\n\
         sensors = {{ noise = \"realistic\", position_noise = 0.05, beacon_noise = 0.05, heading_noise = 1.0, light_noise = 0.5, proximity_noise = 0.5 }}\n\
         [run]\nduration_s = 30\n",
        seed_box(2.8, 2.0)
    );
    let sc = formica::Scenario::parse(&text, "bounds.toml").unwrap_or_else(|e| panic!("{e}"));
    let mut run = start(&sc, 3);
    let flat = formica::controller::FlatReadings::of(&run.world.groups[0].layout);
    let (low, high) = run.reading_bounds(0).expect("one group");
    assert_eq!((low.len(), high.len()), (flat.len(), flat.len()));
    assert!(run.reading_bounds(1).is_none());
    let names = flat.names();
    let mut v = vec![0.0; flat.len()];
    let mut ticks = 0;
    while run.step().is_none() {
        ticks += 1;
        for r in &run.world.robots {
            flat.write(&r.readings, &mut v).unwrap();
            for (k, x) in v.iter().enumerate() {
                assert!(
                    (low[k]..=high[k]).contains(x),
                    "tick {ticks}: {} = {x} outside [{}, {}]",
                    names[k],
                    low[k],
                    high[k]
                );
            }
        }
    }
    assert_eq!(
        (ticks, run.outcome()),
        (299, Some(formica::Outcome::Timeout))
    );
    // The bounds are those of this arena and this noise, not just wide.
    let at = |n: &str| names.iter().position(|m| m == n).unwrap();
    let reach = 1.0 + formica::controller::BODY_SLACK_M + formica::noise::MAX_NORMAL * 0.05;
    assert!(
        (high[at("x")] - (3.0 + reach)).abs() < 1e-5,
        "{}",
        high[at("x")]
    );
    assert_eq!(low[at("x")], 0.0);
    assert_eq!(high[at("time_s")], 30.0);
    assert_eq!(high[at("theta")], std::f32::consts::PI);
}

#[test]
fn the_colour_scan_equals_a_ray_cast_at_every_nearby_body() {
    // A crowd round a concave object and by the walls: the scan, which casts each body only in
    // the bins its box spans and robots before walls and objects, reads what casting every bin's
    // ray at every body within range reads (nearest first, the lower index among equals).
    use formica::physics::Tag;
    use formica::scenario::Color;
    let object = "[[objects]]\nmovable = false\nheight = 0.3\ncolor = \"green\"\nparts = [\n  { box = [0.5, 0.2], at = [0.0, 0.4] },\n  { box = [0.5, 0.2], at = [0.0, -0.4] },\n  { box = [0.2, 1.0], at = [0.25, 0.0], yaw_deg = 0.0 },\n]\n";
    let mut poses = Vec::new();
    for k in 0..36 {
        let a = k as f32 * 0.53;
        let r = 0.74 + 0.16 * (k % 5) as f32;
        let p = ops::unit(a) * r;
        poses.push([p.x, p.y, a * 1.7]);
    }
    // In the cavity, and pressed to the east and north walls.
    poses.extend([
        [-0.05, 0.0, 0.3],
        [-0.1, 0.18, 2.0],
        [2.87, 1.0, 0.5],
        [1.5, 1.87, 4.0],
    ]);
    let group = robot_group(
        "constant",
        "left = 0.0, right = 0.0, led = \"red\", scan = true",
        &poses,
    );
    let sc = scenario(&format!(
        "{object}{group}sensors = {{ noise = \"none\", scan_step = 0.0, scan_bins = 90, scan_range = 1.5 }}\n"
    ));
    let run = two_steps(&sc);
    let w = &run.world;
    let physics = &w.physics;
    let (bins, range) = (90usize, 1.5f32);
    let width = std::f32::consts::TAU / bins as f32;
    let mut near = Vec::new();
    let mut seen = [0usize; 3];
    for (i, r) in w.robots.iter().enumerate() {
        let pose = physics.pose(r.body.expect("released"));
        let center = pose.position();
        physics.nearby(center, range, &mut near);
        for b in 0..bins {
            let dir = ops::unit(pose.theta + width * b as f32);
            let mut best: Option<(f32, Tag)> = None;
            for n in near.iter().filter(|n| n.tag != Tag::Robot(i)) {
                if let Some(t) = physics.ray_entry(n, center, dir, range) {
                    if best.is_none_or(|(d, _)| t < d) {
                        best = Some((t, n.tag));
                    }
                }
            }
            let (color, dist) = (r.readings.scan_color[b], r.readings.scan_range[b]);
            let (want_color, want_dist) = match best {
                None => (Color::Off, range),
                Some((t, Tag::Wall(_))) => (Color::Grey, t.min(range)),
                Some((t, Tag::Object(_))) => (Color::Green, t.min(range)),
                Some((t, Tag::Robot(_))) => (Color::Red, t.min(range)),
            };
            assert_eq!((color, dist), (want_color, want_dist), "robot {i}, bin {b}");
            if let Some((_, tag)) = best {
                seen[match tag {
                    Tag::Wall(_) => 0,
                    Tag::Object(_) => 1,
                    Tag::Robot(_) => 2,
                }] += 1;
            }
        }
    }
    // The scene tests all three kinds.
    assert!(seen.iter().all(|&n| n > 50), "{seen:?}");
}
