//! `formica check SCENARIO`: validate a file and describe what it sets up.

use crate::CliError;
use formica::controllers::occlusion;
use formica::experiment::{object_size, Run, RunOptions};
use formica::geometry::Vec2;
use formica::world::World;
use formica::Scenario;
use std::path::PathBuf;

/// Arguments of `formica check`.
#[derive(clap::Args)]
pub struct Args {
    /// Scenario file (TOML).
    pub scenario: PathBuf,
    /// Override any scenario key, as `formica run --set` does (repeatable).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    /// Use this controller for every robot group, as `formica run --controller` does.
    #[arg(long)]
    pub controller: Option<String>,
}

/// Loads the scenario, builds its world (placing robots with the file's seed) and describes it.
pub fn main(a: Args) -> Result<(), CliError> {
    let sc = crate::cmd_run::load_with_controller(&a.scenario, &a.set, a.controller.as_deref())?;
    let run = Run::new(&sc, &RunOptions::default())?;
    let w = &run.world;
    let s = &sc.spec;
    outln!("{}: OK", sc.file);
    outln!("  name: {}", sc.name);
    if let Some(d) = &s.description {
        outln!("  description: {}", d.trim());
    }
    let mut walls = match s.walls.len() {
        1 => "1 extra wall".to_string(),
        n => format!("{n} extra walls"),
    };
    // Walls of other shapes than boxes, by kind.
    let mut kinds: std::collections::BTreeMap<&str, usize> = Default::default();
    for wl in &w.walls {
        let kind = match wl.shape.as_ref().map(|p| &p.shape) {
            None => continue,
            Some(formica::geometry::Primitive::Box(_)) => "box",
            Some(formica::geometry::Primitive::Disc(_)) => "disc",
            Some(formica::geometry::Primitive::Polygon(_)) => "polygon",
            Some(formica::geometry::Primitive::Regular { .. }) => "regular polygon",
        };
        *kinds.entry(kind).or_default() += 1;
    }
    if !kinds.is_empty() {
        let list: Vec<String> = kinds
            .iter()
            .map(|(k, n)| format!("{n} {k}{}", if *n == 1 { "" } else { "s" }))
            .collect();
        walls += &format!(" ({} by `shape`)", list.join(", "));
    }
    outln!(
        "  arena: {} x {} m, {walls}",
        s.arena.size[0],
        s.arena.size[1]
    );
    for (i, l) in s.lights.iter().map(|l| l.get_ref()).enumerate() {
        let goal = if w.goal_light == Some(i) {
            " (goal)"
        } else {
            ""
        };
        outln!(
            "  light {i}: at ({}, {}), height {} m, intensity {}{goal}",
            l.at[0],
            l.at[1],
            l.height,
            l.intensity
        );
    }
    for (i, o) in w.objects.iter().enumerate() {
        let c = w.object_center(i);
        let friction = floor_friction(&sc, w, i);
        // A static object's mass and floor friction play no part: they are not shown.
        let (load, rubs) = if o.movable {
            (
                format!("movable, {} kg", o.mass),
                format!(", floor friction {friction:.2} N"),
            )
        } else {
            ("static (fixed in place)".into(), String::new())
        };
        outln!(
            "  object {i} \"{}\": {load}, {} part(s), centre ({:.3}, {:.3}), height {} m, size {:.3} m{rubs}",
            o.name,
            o.parts.len(),
            c.x,
            c.y,
            o.height,
            object_size(w, i),
        );
        if o.movable {
            let mut pushers: Vec<String> = Vec::new();
            for g in &w.groups {
                let n = (friction / g.model.max_force).floor() as usize + 1;
                let p = format!(
                    "{} {} ({} N each)",
                    n,
                    g.model_name,
                    formica::limits::show(g.model.max_force)
                );
                if !pushers.contains(&p) {
                    pushers.push(p);
                }
            }
            if !pushers.is_empty() {
                outln!(
                    "    needs at least {} pushing together to move",
                    pushers.join(" or ")
                );
            }
        }
        for warning in object_warnings(&sc, w, i) {
            outln!("    warning: {warning}");
        }
    }
    for (g, grp) in w.groups.iter().enumerate() {
        let n = w.robots.iter().filter(|r| r.group == g).count();
        let needs = grp.needs();
        outln!(
            "  robots[{g}]: {n} x {}, controller {}, sensors: proximity={} light={} beacon={} camera={} scan={}, noise {}",
            grp.model_name, grp.controller, needs.proximity, needs.light, needs.beacon, needs.camera,
            needs.scan, grp.sensors.preset.name()
        );
        if !grp.wheels.is_exact() {
            outln!(
                "    wheels: each turns at its command x (1 + b) x (1 + e), b fixed per wheel \
                 (spread {}), e drawn every tick (spread {})",
                grp.wheels.bias,
                grp.wheels.noise
            );
        }
        if let Some((p, true)) = occlusion_params(&sc, w, g) {
            if p.perception == occlusion::Perception::Beacon
                && p.object_reach > occlusion::Params::default().object_reach
            {
                outln!(
                    "    object_reach {:.2} m: sized to the object the beacon tracks (its radius + {} m)",
                    p.object_reach,
                    occlusion::REACH_BEYOND_RADIUS_M
                );
            }
        }
        if let Some(warning) = formica::world::sensor_warning(grp) {
            outln!("    warning: {warning}");
        }
        for warning in group_warnings(&sc, Some(w), g) {
            outln!("    warning: {warning}");
        }
    }
    let steps = match s.run.substeps {
        formica::scenario::Substeps::Auto => format!(
            "1 to {} physics steps/tick (auto: as the speeds need)",
            sc.max_substeps()
        ),
        formica::scenario::Substeps::Fixed(n) => format!("{n} physics steps/tick"),
    };
    outln!(
        "  run: {} ticks/s, {steps}, {} s, seed {}",
        s.run.tick_hz,
        s.run.duration_s,
        s.run.seed
    );
    if let Some(w) = sc.physics_warning() {
        outln!("    warning: {w}");
    }
    if let (None, Some(frac)) = (w.goal(), s.stop.on_filled) {
        outln!(
            "  stop: no goal light; success once every robot is released and {:.0} % of them \
             are attached (stop.on_filled); wall: {}",
            100.0 * frac,
            s.stop.on_wall
        );
    } else if w.goal().is_none() {
        outln!(
            "  stop: no goal light, so no trial succeeds (each ends by the wall rule or at its \
             time limit); wall: {}",
            s.stop.on_wall
        );
    } else if !sc.has_success_rule() {
        outln!(
            "  stop: {}, so no trial succeeds (each ends by the wall rule or at its time \
             limit); wall: {}",
            if s.stop.on_goal {
                "no movable object to carry to the goal"
            } else {
                "stop.on_goal is off"
            },
            s.stop.on_wall
        );
    } else if let (Some(r), Some(t)) = (run.goal_radius(), w.target) {
        outln!(
            "  stop: success when object {t} \"{}\" is within {r:.3} m of the goal; wall: {}",
            w.objects[t].name,
            s.stop.on_wall
        );
        if let Some(warning) = goal_reached_warning(w, r) {
            outln!("    warning: {warning}");
        }
    }
    for warning in goal_warnings(&sc, w)
        .into_iter()
        .chain(arena_warnings(&sc, w))
    {
        outln!("    warning: {warning}");
    }
    Ok(())
}

/// For an `occlusion` group with beacon perception: a warning if the `object_reach` it sets is
/// shorter than the target object's radius plus 0.2 m (by more than a centimetre), the
/// controller's documented rule (pushers near the object's ends would take it for an
/// obstacle). Left out, the reach is sized to the object and never warned about.
fn reach_warning(sc: &Scenario, w: &World, g: usize) -> Option<String> {
    let (p, _) = occlusion_params(sc, w, g)?;
    let t = w.target?;
    let radius = w.object_radius(t);
    // Within a centimetre: the advice is printed to the centimetre, and a reach set to it (or
    // to radius + 0.2 computed in decimal) must not be warned about again.
    let advised = radius + occlusion::REACH_BEYOND_RADIUS_M;
    if p.perception != occlusion::Perception::Beacon || p.object_reach + 0.01 >= advised {
        return None;
    }
    // A robot going round the object keeps its centre its radius and `circle_gap` off the
    // outline: if even the outline's nearest point is too far for that, no robot takes the
    // object for the object anywhere (seed-transport with a 1.0 m box: 0 of 10 delivered).
    let round = object_inner_distance(w, t) + w.groups[g].model.radius + p.circle_gap;
    let effect = if round > p.object_reach {
        "robots going round it stay farther than that from its centre everywhere, take it for \
         an obstacle and never push it: transport fails"
    } else {
        "pushers near its ends will take it for an obstacle"
    };
    Some(format!(
        "object_reach is {} m but the object's radius is {radius:.2} m; {effect} (set \
         robots.{g}.params.object_reach to at least {:.2})",
        p.object_reach, advised
    ))
}

/// An `occlusion` group's parameters as its robots use them (`object_reach`, left out, sized to
/// the object the beacon tracks), and whether `object_reach` was left out.
fn occlusion_params(sc: &Scenario, w: &World, g: usize) -> Option<(occlusion::Params, bool)> {
    if w.groups[g].controller != "occlusion" {
        return None;
    }
    let params = group_params(sc, g);
    let p = occlusion::params_for(params.as_ref(), &w.groups[g].layout).ok()?;
    Some((p, occlusion::reach_left_out(params.as_ref())))
}

/// Smallest distance from object `i`'s centre to its outline (m): to the nearest point of its
/// edges, not only its corners.
fn object_inner_distance(w: &World, i: usize) -> f32 {
    let c = w.object_center(i);
    let to_segment = |a: Vec2, b: Vec2| {
        let ab = b - a;
        let t = ((c - a).dot(ab) / ab.dot(ab).max(1e-12)).clamp(0.0, 1.0);
        (a + ab * t - c).length()
    };
    w.object_outlines(i)
        .iter()
        .flat_map(|o| (0..o.len()).map(move |k| (o[k], o[(k + 1) % o.len()])))
        .map(|(a, b)| to_segment(a, b))
        .fold(f32::INFINITY, f32::min)
}

/// A warning if the target object starts within `radius` of the goal: every run of the file
/// would succeed on its first tick, with nothing transported.
fn goal_reached_warning(w: &World, radius: f32) -> Option<String> {
    let (t, goal) = (w.target?, w.goal()?);
    let d = (w.object_center(t) - goal).length();
    (d <= radius && w.objects[t].movable).then(|| {
        format!(
            "object {t} \"{}\" starts {d:.2} m from the goal, within the success radius \
             ({radius:.2} m): every run succeeds at once, with nothing moved (move the goal \
             light or the object, or set stop.goal_radius)",
            w.objects[t].name
        )
    })
}

/// Warnings `formica run` and `formica sweep` print too, for the world `w` built from `sc`:
/// set-ups under which a run cannot do what it is meant to (robots that look for a goal colour
/// no light shows, or cannot see the object and a goal at once).
pub(crate) fn run_warnings(sc: &Scenario, w: &World) -> Vec<String> {
    (0..w.objects.len())
        .flat_map(|i| object_warnings(sc, w, i))
        .chain((0..sc.spec.robots.len()).flat_map(|g| group_warnings(sc, Some(w), g)))
        .chain(goal_warnings(sc, w))
        .chain(arena_warnings(sc, w))
        .collect()
}

/// Warnings about the scenario as a whole that `check` prints after the goal's, and `run` and
/// `sweep` print too: `stop.goal_radius` of 0 and walls outside the arena.
fn arena_warnings(sc: &Scenario, w: &World) -> Vec<String> {
    goal_radius_warning(sc)
        .into_iter()
        .chain(stray_wall_warnings(w))
        .collect()
}

/// A warning for each wall of the file that lies wholly outside the arena, where no robot or
/// object can meet it (a typing slip in its `at`, most likely).
fn stray_wall_warnings(w: &World) -> Vec<String> {
    let (centre, size) = w.arena;
    w.walls
        .iter()
        .enumerate()
        .skip(4)
        .filter(|(_, wl)| {
            // Its bounding circle: a wall outside the arena box by more than that is outside.
            let r = wl.size.length() / 2.0;
            ((wl.center - centre).abs() - size / 2.0)
                .cmpgt(Vec2::splat(r))
                .any()
        })
        .map(|(k, wl)| {
            format!(
                "{} at ({}, {}) lies wholly outside the arena: no robot or object can meet it",
                wall_name(k),
                wl.center.x,
                wl.center.y
            )
        })
        .collect()
}

/// Whether `controller` (a built-in's name) carries the target object to the goal light.
fn is_transport(controller: &str) -> bool {
    matches!(controller, "occlusion" | "fill-transport")
}

/// Whether a robot group runs a controller that carries the target object to the goal.
fn transports(sc: &Scenario) -> bool {
    sc.spec
        .robots
        .iter()
        .any(|g| is_transport(g.get_ref().controller.get_ref()))
}

/// The goal light's floor point, if object `i` is the movable target carried to it: the
/// object the goal warnings are about.
fn goal_of_target(w: &World, i: usize) -> Option<Vec2> {
    (w.target == Some(i) && w.objects[i].movable)
        .then(|| w.goal())
        .flatten()
}

/// Whether `p` lies outside the arena's inner box.
fn outside_arena(w: &World, p: Vec2) -> bool {
    let (centre, size) = w.arena;
    (p - centre).abs().cmpgt(size / 2.0).any()
}

/// A wall's name in messages: the arena's four, then `walls[k]`.
fn wall_name(k: usize) -> String {
    if k < 4 {
        "an arena wall".to_string()
    } else {
        format!("walls[{}]", k - 4)
    }
}

/// Warnings about the goal that `check`, `run` and `sweep` print (each found with an audit's
/// scenario that failed every run without a word):
/// - the goal light stands inside a wall at least as tall as it: the wall hides it from every
///   robot (10 of 10 runs pushed the box away);
/// - several objects are movable: each carries a beacon and robots push whichever they find,
///   but success measures the target alone;
/// - a moving goal light's path leads outside the arena.
fn goal_warnings(sc: &Scenario, w: &World) -> Vec<String> {
    let mut out = Vec::new();
    let (Some(gi), Some(goal)) = (w.goal_light, w.goal()) else {
        return out;
    };
    let light_h = w.lights[gi].height;
    let path = sc
        .spec
        .lights
        .get(gi)
        .map_or(&[][..], |l| &l.get_ref().path[..]);
    if let Some((k, p)) = path
        .iter()
        .enumerate()
        .find(|(_, p)| outside_arena(w, Vec2::new(p[0], p[1])))
    {
        out.push(format!(
            "the goal light's path leads outside the arena (lights.{gi}.path[{k}]: ({}, {}) at \
             {} s): the arena's walls shade it there, and the object cannot follow it",
            p[0], p[1], p[2]
        ));
    }
    for (k, wall) in w.walls.iter().enumerate() {
        if wall.height >= light_h && wall.contains(goal) {
            out.push(format!(
                "the goal light (lights.{gi}, {light_h} m high) stands inside {}, {} m tall: \
                 the wall hides it from every robot, so transport cannot work (move the light \
                 off the wall, or raise it above the wall)",
                wall_name(k),
                wall.height
            ));
        }
    }
    let movable: Vec<usize> = (0..w.objects.len())
        .filter(|&i| w.objects[i].movable)
        .collect();
    if let (true, [_, _, ..], Some(t)) = (transports(sc), movable.as_slice(), w.target) {
        let names: Vec<String> = movable
            .iter()
            .map(|&i| format!("{i} \"{}\"", w.objects[i].name))
            .collect();
        out.push(format!(
            "objects {} are movable: each carries a beacon and robots push whichever they \
             find, but success measures object {t} \"{}\" alone (set movable = false on \
             objects meant as obstacles)",
            names.join(", "),
            w.objects[t].name
        ));
    }
    out
}

/// The warnings about object `i` that `check` prints under the object and `run` and `sweep`
/// print before they run: parts that do not hold together, and, for the target of a goal,
/// a goal out of its reach or a swarm too weak to move it.
fn object_warnings(sc: &Scenario, w: &World, i: usize) -> Vec<String> {
    [
        pieces_warning(w, i),
        goal_out_of_reach_warning(sc, w, i).or_else(|| goal_cut_off_warning(w, i)),
        too_heavy_warning(sc, w, i),
        too_light_warning(w, i),
        wall_gap_warning(sc, w, i),
    ]
    .into_iter()
    .flatten()
    .collect()
}

/// A warning if movable object `i`'s parts do not all touch: the pieces move as one rigid body, as if
/// joined by something no sensor sees, and robots meet the gaps between them (two 0.3 m
/// boxes 0.5 m apart as one object: `occlusion` 0 of 10, the beacon's centre of mass between
/// them).
fn pieces_warning(w: &World, i: usize) -> Option<String> {
    let o = &w.objects[i];
    if !o.movable {
        return None;
    }
    let pieces = formica::geometry::part_pieces(&o.parts, 1e-3);
    (pieces.len() > 1).then(|| {
        let list: Vec<String> = pieces
            .iter()
            .map(|p| {
                let parts: Vec<String> = p.iter().map(|k| k.to_string()).collect();
                format!("[{}]", parts.join(", "))
            })
            .collect();
        format!(
            "object {i} \"{}\": its parts do not all touch; they form {} separate pieces \
             (parts {}), which move as one rigid body, joined by nothing a robot can sense \
             (join the parts, or make each piece an object of its own)",
            o.name,
            pieces.len(),
            list.join(" ")
        )
    })
}

/// For the target of the goal: a warning if the goal lies farther than the success radius
/// from every place the object's centre can reach inside the arena (no trial can succeed),
/// or, short of that, outside the arena.
fn goal_out_of_reach_warning(sc: &Scenario, w: &World, i: usize) -> Option<String> {
    let goal = goal_of_target(w, i)?;
    let radius = formica::experiment::goal_radius(sc, w)?;
    let (centre, size) = w.arena;
    let outside = outside_arena(w, goal);
    let half = (size / 2.0 - Vec2::splat(object_inner_distance(w, i))).max(Vec2::ZERO);
    let nearest = goal.clamp(centre - half, centre + half);
    let d = (goal - nearest).length();
    if d <= radius {
        return outside.then(|| {
            format!(
                "the goal light at ({}, {}) lies outside the arena: its walls shade it from \
                 robots and object wherever they are lower than the light's line of sight",
                goal.x, goal.y
            )
        });
    }
    Some(format!(
        "the goal light at ({}, {}) is {d:.2} m from the nearest place inside the arena \
             that object {i}'s centre can reach, farther than the success radius ({radius:.2} \
             m): no trial can succeed (move the light into the arena, or set stop.goal_radius)",
        goal.x, goal.y
    ))
}

/// For the target of the goal: a warning if walls and fixed objects leave its centre no way to
/// the goal, even turned to its narrowest ([`formica::experiment::object_can_pass`]): a wall
/// across the arena, or gaps narrower than the object.
fn goal_cut_off_warning(w: &World, i: usize) -> Option<String> {
    let goal = goal_of_target(w, i)?;
    let from = w.object_center(i);
    (!formica::experiment::object_can_pass(w, i, from, goal)).then(|| {
        format!(
            "walls (or fixed objects) leave object {i} \"{}\" no way to the goal light, \
                 even turned to its narrowest: no trial can succeed (widen the gaps, or move \
                 the light or the object)",
            w.objects[i].name
        )
    })
}

/// For the target of the goal, with the wall rule on: a warning if it starts nearer a wall
/// than the widest robot is wide (but not touching it), so that no robot can pass between
/// them and a touch fails the trial (an audit's concave object 0.12 m from a wall: 0 of 10).
fn wall_gap_warning(sc: &Scenario, w: &World, i: usize) -> Option<String> {
    goal_of_target(w, i).filter(|_| sc.spec.stop.on_wall)?;
    let (width, model) = w
        .groups
        .iter()
        .map(|g| (2.0 * g.model.radius, g.model_name.as_str()))
        .max_by(|a, b| a.0.total_cmp(&b.0))?;
    let object = w.object_outlines(i);
    let (gap, k) = w
        .walls
        .iter()
        .enumerate()
        .map(|(k, wall)| {
            (
                formica::geometry::outlines_gap(&object, &[wall.outline()]),
                k,
            )
        })
        .min_by(|a, b| a.0.total_cmp(&b.0))?;
    (gap > 1e-3 && gap < width).then(|| {
        format!(
            "object {i} \"{}\" starts {gap:.2} m from {}, less than a {model} is wide \
             ({width:.2} m): no robot can pass between them, and with stop.on_wall a touch \
             fails the trial (move the object, or set stop.on_wall = false)",
            w.objects[i].name,
            wall_name(k)
        )
    })
}

/// A warning if movable object `i` is so much lighter than the heaviest robot that more solver
/// iterations than the physics gives ([`formica::world::MAX_SOLVER_FACTOR`] times the usual)
/// would be needed: robots squeezing it sink into it (Khepera IV into a 20 g box: 11 mm).
fn too_light_warning(w: &World, i: usize) -> Option<String> {
    let o = &w.objects[i];
    let max = formica::world::MAX_SOLVER_FACTOR as f32;
    let g = w
        .groups
        .iter()
        .max_by(|a, b| a.model.mass.total_cmp(&b.model.mass))?;
    (o.movable && g.model.mass > max * max * o.mass).then(|| {
        format!(
            "object {i} \"{}\" weighs {} kg, {:.0} times less than a {} ({} kg): robots \
             squeezing it may sink up to a centimetre into it (contacts hold to within 5 mm up \
             to {:.0} times; make it at least {:.2} kg)",
            o.name,
            o.mass,
            g.model.mass / o.mass,
            g.model_name,
            g.model.mass,
            max * max,
            g.model.mass / (max * max)
        )
    })
}

/// Object `i`'s floor friction (N): the force it takes to slide it, `floor_mu m g` (the
/// world holds one object per `[[objects]]` entry, in order).
fn floor_friction(sc: &Scenario, w: &World, i: usize) -> f32 {
    sc.spec.objects[i].get_ref().floor_mu * w.objects[i].mass * formica::physics::GRAVITY
}

/// For the target of the goal: a warning if every robot of the scenario pushing at once
/// gives no more than the object's floor friction (it cannot move).
fn too_heavy_warning(sc: &Scenario, w: &World, i: usize) -> Option<String> {
    goal_of_target(w, i)?;
    let o = &w.objects[i];
    let friction = floor_friction(sc, w, i);
    // A fold from +0, not `sum` (whose empty sum is -0.0, printed "-0.00 N").
    let all = (0..w.robots.len())
        .map(|r| w.robot_model(r).max_force)
        .fold(0.0f32, |a, f| a + f);
    (all <= friction).then(|| {
        format!(
            "object {i} \"{}\" needs more than {friction:.2} N to move (floor friction), but \
             all {} robots pushing at once give at most {all:.2} N: it cannot move, and no \
             trial can succeed (add robots, or lower its mass or floor_mu)",
            o.name,
            w.robots.len()
        )
    })
}

/// The warnings about robot group `g` that `check` prints under the group and `run` and
/// `sweep` print before they run. Without a world, only those that need none.
fn group_warnings(sc: &Scenario, w: Option<&World>, g: usize) -> Vec<String> {
    [
        w.and_then(|w| reach_warning(sc, w, g)),
        goal_color_warning(sc, g),
        no_goal_warning(sc, g),
        w.and_then(|w| camera_range_warning(sc, w, g)),
        led_clash_warning(sc, g),
        w.and_then(|w| beacon_light_warning(sc, w, g)),
        release_warning(sc, g),
    ]
    .into_iter()
    .flatten()
    .chain(w.map(|w| light_warnings(sc, w, g)).unwrap_or_default())
    .collect()
}

/// A warning when group `g`'s release schedule lets some of its robots in only after the run
/// has ended: they never enter, yet count in the result's `robots`.
fn release_warning(sc: &Scenario, g: usize) -> Option<String> {
    let r = &sc.spec.robots[g].get_ref().release;
    let (n, end) = (sc.group_count(g), sc.spec.run.duration_s);
    let entering = if r.start_s >= end {
        0
    } else if r.interval_s > 0.0 {
        // Releases at start_s + k interval_s, k = 0, 1, ...: those before the end.
        (((end - r.start_s) / r.interval_s).ceil() as usize).min(n)
    } else {
        n
    };
    (entering < n).then(|| {
        format!(
            "robots.{g}: release starts at {} s, one robot every {} s, but the run ends at {end} s: \
             {entering} of its {n} robots enter (the rest never do, yet count in `robots`)",
            r.start_s, r.interval_s
        )
    })
}

/// A warning when `stop.goal_radius` is 0: the object's centre would have to reach the goal's
/// exact point, so no trial succeeds.
fn goal_radius_warning(sc: &Scenario) -> Option<String> {
    (transports(sc) && sc.spec.stop.goal_radius == Some(0.0)).then(|| {
        "stop.goal_radius is 0: the object's centre would have to reach the goal's exact point, \
         so no trial can succeed (leave it out for the default, sized to the goal and the object)"
            .to_string()
    })
}

/// For a `filling` group, which steers to the light its ring sees and starts to follow an edge
/// only where it touches one: a warning when a light stands over open floor farther from every
/// object than the robots sense (their radius plus proximity range). A robot that reaches the
/// spot below it without touching the object circles there for the rest of the run: with
/// seed-fill-u's light 0.35 m east of the U (`formica run scenarios/seed-fill-u.toml --seeds
/// 1..10 --set 'lights.0.at=[-0.3,0.0]'`), Khepera IV attach 1.6 robots on average, against
/// 9.8 with the light over the U, and e-pucks (`--set 'robots.0.model="e-puck"'`) none.
fn beacon_light_warning(sc: &Scenario, w: &World, g: usize) -> Option<String> {
    if sc.spec.robots[g].get_ref().controller.get_ref() != "filling" || w.objects.is_empty() {
        return None;
    }
    let model = &w.groups[g].model;
    let sensed = model.radius + model.proximity_range;
    let (k, light, gap) = w
        .lights
        .iter()
        .enumerate()
        .filter(|(k, _)| Some(*k) != w.goal_light)
        .map(|(k, l)| {
            let gap = w
                .objects
                .iter()
                .map(|o| w.physics.distance_to(o.body, l.position))
                .fold(f32::INFINITY, f32::min);
            (k, l, gap)
        })
        .find(|(_, _, gap)| *gap > sensed)?;
    Some(format!(
        "lights.{k} stands over open floor at ({:.2}, {:.2}), {gap:.2} m from the nearest object: \
         the group's {} sense {sensed:.2} m from their centre, so a robot that reaches the spot \
         below the light without touching an object circles there (`filling` steers to the light \
         and follows edges it touches); put the light over the object",
        light.position.x, light.position.y, w.groups[g].model_name
    ))
}

/// For a group running a transport controller that reads its light ring (`occlusion`,
/// `fill-transport`): warnings about what its light sensors see at the target object's start
/// (each measured with an audit's scenario: `occlusion` delivered 0 to 4 of 10 there):
/// - an object no taller than the light sensors hides the goal from no robot;
/// - the goal light reads under 0.1 there, the contrast the two take for lit by default
///   (`lit_contrast`), so that robots by the object cannot tell where it hides the goal;
/// - another light reaches the object: the ring sees every light, and a robot on the goal's
///   side then reads a light too.
fn light_warnings(sc: &Scenario, w: &World, g: usize) -> Vec<String> {
    let controller = sc.spec.robots[g].get_ref().controller.get_ref();
    let mut out = Vec::new();
    let (Some(t), Some(goal)) = (w.target, w.goal_light) else {
        return out;
    };
    let group = &w.groups[g];
    if !is_transport(controller) || !group.needs().light {
        return out;
    }
    let sensor_h = group.model.light_height;
    let object = &w.objects[t];
    if object.height <= sensor_h {
        out.push(format!(
            "object {t} \"{}\" is {} m tall, no taller than the light sensors of robots.{g} \
             ({sensor_h} m): it hides the goal from no robot, and {controller} pushes only where \
             the object hides it",
            object.name, object.height
        ));
    }
    let at = w.object_center(t);
    let value = |l: &formica::sensors::Light| {
        let d = (l.position - at).length();
        let h = l.height - sensor_h;
        formica::robot::RobotModel::light_value((d * d + h * h).sqrt(), l.intensity)
    };
    let v = value(&w.lights[goal]);
    if v < 0.1 {
        out.push(format!(
            "the goal light reads {v:.3} at object {t}'s start, under 0.1, the contrast \
             {controller} takes for lit by default: robots by the object cannot tell where it \
             hides the goal (raise lights.{goal}.intensity or move the light nearer)"
        ));
    }
    for (k, l) in w.lights.iter().enumerate() {
        let v = value(l);
        if k != goal && v > 0.0 {
            out.push(format!(
                "light {k} is not the goal but reads {v:.3} at object {t}'s start: light \
                 sensors see every light, and {controller} takes the object to hide the goal \
                 only where it is dark from every light (move light {k} farther than 2.5 x its \
                 intensity from the object, or remove it)"
            ));
        }
    }
    out
}

/// For a group that fills (`filling`, `fill-transport`): a warning if another group runs
/// `occlusion` with its default `circle_led`, blue while its robots circle the object:
/// fillers take a blue LED for an attached robot and stop beside it
/// (`scenarios/mixed-swarm-u.toml` with blue: 7 of 10 delivered, 3 to 9 false stops a run;
/// with magenta, 10 and none).
fn led_clash_warning(sc: &Scenario, g: usize) -> Option<String> {
    let controller = |k: usize| sc.spec.robots[k].get_ref().controller.get_ref().clone();
    let mine = controller(g);
    if !matches!(mine.as_str(), "filling" | "fill-transport") {
        return None;
    }
    let blue = |h: usize| {
        formica::controller::parse_params_with_defaults::<occlusion::Params>(
            group_params(sc, h).as_ref(),
        )
        .is_ok_and(|p| p.circle_led == formica::scenario::Color::Blue)
    };
    let h =
        (0..sc.spec.robots.len()).find(|&h| h != g && controller(h) == "occlusion" && blue(h))?;
    Some(format!(
        "robots.{h} runs occlusion, whose robots light blue while they circle the object, and \
         robots.{g}'s {mine} takes a blue LED for a robot attached to the object: its robots \
         will stop beside circling ones, outside the object's cavities (set \
         robots.{h}.params.circle_led = \"magenta\")"
    ))
}

/// [`run_warnings`] for a scenario whose world is not built yet: builds it with the file's
/// seed. (A world that cannot be built is left to the run, which reports it with its seed;
/// the warnings that need no world are given all the same.)
pub(crate) fn warnings_before_run(sc: &Scenario) -> Vec<String> {
    match Run::new(sc, &RunOptions::default()) {
        Ok(run) => run_warnings(sc, &run.world),
        Err(_) => (0..sc.spec.robots.len())
            .flat_map(|g| group_warnings(sc, None, g))
            .collect(),
    }
}

/// For a group running a transport controller (`occlusion`, `fill-transport`): a warning if
/// no light is the goal (every light sets `goal = false`, or there is none), since then no
/// trial can succeed. (A group that sees the goal with its camera gets
/// [`goal_color_warning`]'s instead.)
fn no_goal_warning(sc: &Scenario, g: usize) -> Option<String> {
    let controller = sc.spec.robots[g].get_ref().controller.get_ref();
    let transports = is_transport(controller) && goal_camera_params(sc, g).is_none();
    (transports && sc.goal_light().is_none()).then(|| {
        format!(
            "robots.{g} runs {controller}, which carries the object to the goal light, but no \
             light is the goal: no trial can succeed (set goal = true on one light)"
        )
    })
}

/// Group `g`'s controller parameters, as the file (and `--set`) give them.
fn group_params(sc: &Scenario, g: usize) -> Option<toml::Table> {
    sc.spec.robots[g]
        .get_ref()
        .params
        .as_ref()
        .map(|p| p.get_ref().clone())
}

/// For an `occlusion` or `fill-transport` group that sees the goal with its camera (`relays =
/// true` or `goal_sensor = "camera"`): a warning if the goal light does not show in
/// `relay.goal_color`, since then no robot ever sees the goal (relays never form, and every
/// robot takes the goal for hidden).
fn goal_color_warning(sc: &Scenario, g: usize) -> Option<String> {
    let p = goal_camera_params(sc, g)?;
    let want = p.relay.goal_color;
    let Some(i) = sc.goal_light() else {
        return Some("the camera looks for the goal, but there is no goal light".into());
    };
    let light = sc.spec.lights[i].get_ref();
    let shows = match light.color {
        formica::scenario::Color::Off => "has no colour".to_string(),
        c => format!("is {}", c.name()),
    };
    (light.color != want).then(|| {
        format!(
            "robots.{g} sees the goal with its camera (relays or goal_sensor = \"camera\") in \
             {}, but the goal light {shows}: no robot will ever see the goal (set \
             lights.{i}.color = \"{}\")",
            want.name(),
            want.name()
        )
    })
}

/// The pushing parameters of group `g` if it runs `occlusion` or `fill-transport` and sees the
/// goal with its camera (`relays = true` or `goal_sensor = "camera"`).
fn goal_camera_params(sc: &Scenario, g: usize) -> Option<formica::controllers::occlusion::Params> {
    use formica::controller::parse_params_with_defaults;
    use formica::controllers::{fill_transport, occlusion};
    let params = group_params(sc, g);
    let p: occlusion::Params = match sc.spec.robots[g].get_ref().controller.get_ref().as_str() {
        "occlusion" => parse_params_with_defaults(params.as_ref()).ok()?,
        "fill-transport" => parse_params_with_defaults::<fill_transport::Params>(params.as_ref())
            .ok()?
            .pusher(),
        _ => return None,
    };
    p.goal_camera().then_some(p)
}

/// For a group that sees the goal with its camera and approaches the object only with a goal
/// in sight (`relay.gate_memory_s` unset or 0, as Queiroz and MacRae): a warning if the camera
/// or the colour scan reaches less far than the goal is from the target object's start. A
/// robot then seldom or never sees the object and a goal at once, and no robot starts
/// (`scenarios/qm-open.toml` with the default 1.5 m camera and 1.0 m scan: 0 of 10).
fn camera_range_warning(sc: &Scenario, w: &World, g: usize) -> Option<String> {
    let p = goal_camera_params(sc, g)?;
    if p.relay.gate_memory_s.unwrap_or(0.0) > 0.0 {
        return None;
    }
    let d = (w.object_center(w.target?) - w.goal()?).length();
    let s = &w.groups.get(g)?.sensors;
    let reach = s.camera_range.min(s.scan_range);
    (reach < d).then(|| {
        format!(
            "robots.{g} approaches the object only with the object (colour scan, {} m) and a \
             goal (camera, {} m) in sight at once, but the goal is {d:.2} m from the object: \
             robots may never start (Queiroz and MacRae's cameras reach 100 m; set \
             robots.{g}.sensors.camera_range and scan_range to at least {:.1}, or \
             robots.{g}.params.relay.gate_memory_s to let a goal seen earlier do)",
            s.scan_range,
            s.camera_range,
            (d * 10.0).ceil() / 10.0
        )
    })
}
