//! Experiment hooks (like ARGoS loop functions): per-tick metrics, stop rules and the result of
//! a run. [`run`] drives one world from its first tick to its outcome.
//!
//! Every run gets the loop functions of its scenario's [`Registry`]: the built-in
//! [`TransportHooks`] (`transport`) and [`FillHooks`](crate::metrics::FillHooks) (`fill`), then
//! any a user registered. A loop function adds its own end-of-run fields to
//! [`RunResult::extra`]:
//!
//! ```
//! use formica::{LoopFunctions, Registry, RunResult, World};
//!
//! /// Counts the ticks on which some robot touched something.
//! struct Contacts(u64);
//!
//! impl LoopFunctions for Contacts {
//!     fn post_step(&mut self, world: &World) {
//!         let touching = world.robots.iter().any(|r| r.readings.proximity.iter().any(|&p| p >= 1.0));
//!         self.0 += u64::from(touching);
//!     }
//!     fn finish(&self, _world: &World, result: &mut RunResult) {
//!         result.extra.insert("contact_ticks".into(), self.0.into());
//!     }
//! }
//!
//! let mut registry = Registry::builtin();
//! registry.loop_functions("contacts", |_scenario, _world| Some(Box::new(Contacts(0))))?;
//! let text = "[arena]\nsize = [1.0, 1.0]\n[[robots]]\ncontroller = \"random-walk\"\n\
//!             placement = { poses = [[0.0, 0.0, 0.0]] }\n[run]\nduration_s = 30\n";
//! let scenario = registry.parse(text, "box.toml")?;
//! let (result, _) = formica::run(&scenario, &Default::default())?;
//! assert!(result.extra["contact_ticks"].as_u64().is_some());
//! let line = serde_json::to_string(&result)?;
//! assert!(line.contains("\"contact_ticks\":"));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use crate::controller::FlatReadings;
use crate::geometry::Vec2;
use crate::physics::Tag;
use crate::registry::{Registry, RegistryError};
use crate::scenario::{Scenario, ScenarioError};
use crate::world::{Overrides, World};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Version of what results mean. Two builds of Formica with the same results format give the
/// same result, bit for bit, for the same scenario and seed; any change that can move a result
/// (physics, sensing, controllers, metrics, random streams, scenario defaults) or change what a
/// result field means bumps it, with an entry in `CHANGELOG.md`. `formica sweep` refuses to add
/// trials to a store written with another results format.
pub const RESULTS_FORMAT: u32 = 34;

/// How a run ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum Outcome {
    /// The object reached the goal (or the filling target was met).
    Success,
    /// The object touched a wall.
    Wall,
    /// The time limit passed (also the outcome of a run still going on).
    #[default]
    Timeout,
}

impl Outcome {
    /// Lower-case name, as in JSON.
    pub fn name(self) -> &'static str {
        match self {
            Outcome::Success => "success",
            Outcome::Wall => "wall",
            Outcome::Timeout => "timeout",
        }
    }
}

/// The result of one run: the JSON line `formica run --json` prints.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct RunResult {
    /// Scenario name.
    pub scenario: String,
    /// Seed.
    pub seed: u64,
    /// How it ended.
    pub outcome: Outcome,
    /// Simulated seconds.
    pub sim_time_s: f64,
    /// Control ticks.
    pub ticks: u64,
    /// Number of robots.
    pub robots: usize,
    /// Controller(s) used, comma-separated by group.
    pub controller: String,
    /// Final distance from the object's centre to the goal (m); null without goal or object.
    pub goal_distance_m: Option<f64>,
    /// Length of the object's path (m); null without a target object.
    pub object_path_m: Option<f64>,
    /// Shortest way from start to end (straight, or round obstacles) / path length (0 when the
    /// object never moved); null without a target object.
    pub path_efficiency: Option<f64>,
    /// Robots attached to the object at the end.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub object_robots: Option<usize>,
    /// Time at which the last robot attached (s).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fill_time_s: Option<f64>,
    /// Area of object / area of its convex hull, at the start.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub convexity_before: Option<f64>,
    /// Area of object plus attached robots / area of their convex hull, at the end.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub convexity_after: Option<f64>,
    /// Fraction of the area between the object and its hull covered by attached robots.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cavity_filled: Option<f64>,
    /// Robot discs that fit in the cavity (the region between the object and its hull).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cavity_capacity: Option<usize>,
    /// Attached robots lying wholly in the cavity, by the test the capacity packs its discs with
    /// ([`crate::metrics::disc_in_cavity`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cavity_robots: Option<usize>,
    /// Attached robots outside the object's hull (their centre beyond it by over half a radius).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub false_stops: Option<usize>,
    /// Wall-clock seconds the run took (the only field that is not deterministic).
    pub wall_time_s: f64,
    /// End-of-run fields added by loop functions, flattened into the JSON line (after the
    /// fields above) and stored as one result-store column each. A key that is one of
    /// [`RunResult::RESERVED`] is renamed `LOOP.KEY` after the loop functions that wrote it.
    #[serde(flatten, default)]
    pub extra: BTreeMap<String, serde_json::Value>,
}

impl RunResult {
    /// Names [`RunResult::extra`] keys cannot take: the fields of the JSON line, the provenance
    /// fields every JSON line and store row of `formica` carries (`formica_version`,
    /// `git_commit`, `scenario_sha256`, `platform`), and the result store's own columns
    /// (`trial`, `params`, `scenario_name`) and case key (`label`).
    pub const RESERVED: &'static [&'static str] = &[
        "scenario",
        "seed",
        "outcome",
        "sim_time_s",
        "ticks",
        "robots",
        "controller",
        "goal_distance_m",
        "object_path_m",
        "path_efficiency",
        "object_robots",
        "fill_time_s",
        "convexity_before",
        "convexity_after",
        "cavity_filled",
        "cavity_capacity",
        "cavity_robots",
        "false_stops",
        "wall_time_s",
        "formica_version",
        "git_commit",
        "scenario_sha256",
        "platform",
        "trial",
        "params",
        "scenario_name",
        "label",
    ];

    /// Renames the `extra` keys that are reserved (or empty) to `owner.KEY`.
    fn rename_reserved_extra(&mut self, owner: &str) {
        let clash: Vec<String> = self
            .extra
            .keys()
            .filter(|k| k.is_empty() || Self::RESERVED.contains(&k.as_str()))
            .cloned()
            .collect();
        for k in clash {
            if let Some(v) = self.extra.remove(&k) {
                let renamed = if k.is_empty() {
                    owner.to_string()
                } else {
                    format!("{owner}.{k}")
                };
                self.extra.insert(renamed, v);
            }
        }
    }
}

/// An end-of-run field ([`RunResult::extra`]) as a result store keeps it and reads it back:
/// numbers as they are (integers that fit an `i64` as integers, others as floats), booleans as
/// 0 / 1, strings as they are, lists and tables as their JSON text, and `null` as no field at all.
pub fn extra_as_stored(v: &serde_json::Value) -> Option<serde_json::Value> {
    use serde_json::Value as J;
    match v {
        J::Null => None,
        J::Bool(b) => Some(i64::from(*b).into()),
        J::Number(n) => match (n.as_i64(), n.as_f64()) {
            (Some(i), _) => Some(i.into()),
            (None, Some(f)) => serde_json::Number::from_f64(f).map(J::Number),
            (None, None) => Some(J::String(n.to_string())),
        },
        J::String(s) => Some(J::String(s.clone())),
        other => Some(J::String(other.to_string())),
    }
}

/// How result `b` differs from `a`, field by field, leaving out the wall-clock time: one
/// `field: a, b` line per difference, none when a replay reproduced a stored result. Every
/// field counts, the end-of-run fields of loop functions too; those compare as a result store
/// keeps them ([`extra_as_stored`]), so a fresh result matches its stored copy.
pub fn result_differences(a: &RunResult, b: &RunResult) -> Vec<String> {
    let json = |r: &RunResult| {
        let mut r = r.clone();
        r.extra = r
            .extra
            .iter()
            .filter_map(|(k, v)| extra_as_stored(v).map(|v| (k.clone(), v)))
            .collect();
        match serde_json::to_value(&r) {
            Ok(serde_json::Value::Object(mut m)) => {
                m.remove("wall_time_s");
                m
            }
            _ => serde_json::Map::new(),
        }
    };
    let (a, b) = (json(a), json(b));
    let mut keys: Vec<&String> = a.keys().chain(b.keys()).collect();
    keys.sort();
    keys.dedup();
    let show = |v: Option<&serde_json::Value>| v.map_or_else(|| "none".into(), |v| v.to_string());
    keys.into_iter()
        .filter(|k| a.get(*k) != b.get(*k))
        .map(|k| format!("{k}: {}, {}", show(a.get(k)), show(b.get(k))))
        .collect()
}

/// `got`'s end-of-run fields that a store with end-of-run `columns` cannot hold, and that
/// `stored` therefore lacks: fields added to the results after the store was written.
pub fn unstored_fields(
    stored: &RunResult,
    got: &RunResult,
    columns: &std::collections::BTreeSet<String>,
) -> Vec<String> {
    got.extra
        .keys()
        .filter(|k| !columns.contains(*k) && !stored.extra.contains_key(*k))
        .cloned()
        .collect()
}

/// [`result_differences`] for the replay `got` of a stored trial, leaving out the fields the
/// store could not hold ([`unstored_fields`]).
pub fn replay_differences(
    stored: &RunResult,
    got: &RunResult,
    columns: &std::collections::BTreeSet<String>,
) -> Vec<String> {
    let mut got = got.clone();
    for k in unstored_fields(stored, &got, columns) {
        got.extra.remove(&k);
    }
    result_differences(stored, &got)
}

/// One recorded sample of a trajectory.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Sample {
    /// Simulated time (s).
    pub t: f64,
    /// Which robot (`None`: the object).
    pub id: Option<u32>,
    /// x (m).
    pub x: f32,
    /// y (m).
    pub y: f32,
    /// Heading (rad).
    pub theta: f32,
}

/// Trajectories recorded during a run.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Trajectories {
    /// Target object's centre of mass and heading, every tick.
    pub object: Vec<Sample>,
    /// Every released robot's pose, every `robot_every` ticks.
    pub robots: Vec<Sample>,
}

/// Hooks called around each tick, like ARGoS loop functions. Register a builder of them with
/// [`Registry::loop_functions`].
pub trait LoopFunctions: Send {
    /// After each tick.
    fn post_step(&mut self, _world: &World) {}
    /// Whether the run is over, and how.
    fn is_finished(&self, _world: &World) -> Option<Outcome> {
        None
    }
    /// Fills in metrics at the end: fields of the result, or its [`RunResult::extra`] map.
    fn finish(&self, _world: &World, _result: &mut RunResult) {}
}

/// Registers the built-in loop functions: `transport`, then `fill`. Their stop rules are the
/// scenario's `stop` table ([`Scenario::has_success_rule`] reads it instead of them).
pub fn register(registry: &mut Registry) -> Result<(), RegistryError> {
    registry
        .loop_functions("transport", |sc, world| {
            Some(Box::new(TransportHooks::new(sc, world)))
        })?
        .loop_functions("fill", |sc, world| {
            Some(Box::new(crate::metrics::FillHooks::new(sc, world)))
        })?;
    Ok(())
}

/// The goal radius of the success rule (m): the scenario's `stop.goal_radius`, else (Queiroz &
/// MacRae) half the goal size plus half the target object's size, plus 5 cm; `None` without a
/// goal light.
pub fn goal_radius(sc: &Scenario, world: &World) -> Option<f32> {
    world.goal()?;
    let stop = &sc.spec.stop;
    stop.goal_radius.or_else(|| {
        world.target.map(|t| {
            let size = object_size(world, t);
            (stop.goal_size + size) / 2.0 + 0.05
        })
    })
}

/// The standard transport metrics and stop rules: path length, goal distance, goal / wall.
pub struct TransportHooks {
    goal_radius: Option<f32>,
    on_goal: bool,
    on_wall: bool,
    last: Option<Vec2>,
    path_m: f64,
}

impl TransportHooks {
    /// Hooks for a world built from `sc`.
    pub fn new(sc: &Scenario, world: &World) -> Self {
        let stop = &sc.spec.stop;
        Self {
            goal_radius: goal_radius(sc, world),
            on_goal: stop.on_goal,
            on_wall: stop.on_wall,
            last: world.target.map(|t| world.object_center(t)),
            path_m: 0.0,
        }
    }

    /// The goal radius in use (m).
    pub fn goal_radius(&self) -> Option<f32> {
        self.goal_radius
    }
}

/// Object size for the goal radius (Queiroz & MacRae): a lone disc's diameter, otherwise the
/// diagonal of the bounding box of its outline.
pub fn object_size(world: &World, i: usize) -> f32 {
    let o = &world.objects[i];
    if let [p] = o.parts.as_slice() {
        if let crate::geometry::Primitive::Disc(r) = p.shape {
            return 2.0 * r;
        }
    }
    let pts: Vec<Vec2> = o.outlines().into_iter().flatten().collect();
    let (lo, hi) = crate::geometry::bounds(&pts);
    (hi - lo).length()
}

impl LoopFunctions for TransportHooks {
    fn post_step(&mut self, world: &World) {
        if let (Some(t), Some(last)) = (world.target, self.last) {
            let now = world.object_center(t);
            self.path_m += f64::from((now - last).length());
            self.last = Some(now);
        }
    }

    fn is_finished(&self, world: &World) -> Option<Outcome> {
        let t = world.target?;
        if !world.objects[t].movable {
            return None;
        }
        if self.on_goal {
            if let (Some(goal), Some(r)) = (world.goal(), self.goal_radius) {
                if (world.object_center(t) - goal).length() <= r {
                    return Some(Outcome::Success);
                }
            }
        }
        if self.on_wall
            && world
                .physics
                .touches(world.objects[t].body, |tag| matches!(tag, Tag::Wall(_)))
        {
            return Some(Outcome::Wall);
        }
        None
    }

    fn finish(&self, world: &World, r: &mut RunResult) {
        if let Some(t) = world.target {
            let now = world.object_center(t);
            r.goal_distance_m = world.goal().map(|g| f64::from((now - g).length()));
            r.object_path_m = Some(self.path_m);
            let start = world.objects[t].start;
            let disp = f64::from((now - start).length());
            // Around obstacles, the shortest path on a visibility graph (no extra walls and no
            // fixed objects: the straight distance, as before).
            let fixed = world.objects.iter().any(|o| !o.movable);
            let optimal = if world.walls.len() > 4 || fixed {
                optimal_path(world, t, start, now).max(disp)
            } else {
                disp
            };
            r.path_efficiency = Some(if self.path_m > 1e-9 {
                (optimal / self.path_m).min(1.0)
            } else {
                0.0
            });
        }
    }
}

/// Length (m) of the shortest path of object `t`'s centre from `from` to `to` around the
/// walls inside the arena (not the four arena walls) and the objects that cannot be pushed
/// (`movable = false`), each grown by the object's half-width
/// (half the smaller side of its outline's bounding box), turning only where the grown object
/// fits inside the arena ([`visibility::shortest_path`](crate::visibility::shortest_path)).
pub fn optimal_path(world: &World, t: usize, from: Vec2, to: Vec2) -> f64 {
    let pts: Vec<Vec2> = world.objects[t].outlines().into_iter().flatten().collect();
    let (lo, hi) = crate::geometry::bounds(&pts);
    let r = f64::from(((hi - lo).x.min((hi - lo).y) / 2.0).max(0.0));
    let (obstacles, bounds) = grown_obstacles(world, t, r);
    crate::visibility::shortest_path(xy(from), xy(to), &obstacles, bounds)
}

/// Whether the walls and fixed objects leave object `t`'s centre a way from `from` to `to`
/// with the object turned to its narrowest (grown by half the least width of its convex hull,
/// so an L can go through a gap diagonally): false for a goal cut off by a wall, or behind
/// gaps narrower than the object.
pub fn object_can_pass(world: &World, t: usize, from: Vec2, to: Vec2) -> bool {
    let pts: Vec<Vec2> = world.objects[t].outlines().into_iter().flatten().collect();
    let r = f64::from(crate::geometry::least_width(&pts) / 2.0);
    let (obstacles, bounds) = grown_obstacles(world, t, r);
    crate::visibility::path_length(xy(from), xy(to), &obstacles, bounds).is_some()
}

fn xy(v: Vec2) -> [f64; 2] {
    [f64::from(v.x), f64::from(v.y)]
}

/// Convex polygons in the plane, and a box (min, max corners).
type Obstacles = (Vec<Vec<[f64; 2]>>, ([f64; 2], [f64; 2]));

/// The obstacles to object `t`'s centre ([`optimal_path`]), grown by `r`, and the box its
/// turns stay in.
fn grown_obstacles(world: &World, t: usize, r: f64) -> Obstacles {
    let mut obstacles: Vec<Vec<[f64; 2]>> = Vec::new();
    for w in &world.walls[4..] {
        let (s, c) = crate::ops::sin_cos(w.yaw);
        let (s, c) = (f64::from(s), f64::from(c));
        let place = |[x, y]: [f64; 2]| {
            [
                f64::from(w.center.x) + c * x - s * y,
                f64::from(w.center.y) + s * x + c * y,
            ]
        };
        match &w.shape {
            None => {
                let hx = f64::from(w.size.x) / 2.0 + r;
                let hy = f64::from(w.size.y) / 2.0 + r;
                obstacles.push(
                    [[-hx, -hy], [hx, -hy], [hx, hy], [-hx, hy]]
                        .into_iter()
                        .map(place)
                        .collect(),
                );
            }
            Some(part) => {
                for piece in crate::geometry::convex_pieces(part, 16) {
                    let pts: Vec<[f64; 2]> = piece
                        .iter()
                        .map(|p| [f64::from(p.x), f64::from(p.y)])
                        .collect();
                    obstacles.push(grown(&pts, r).into_iter().map(place).collect());
                }
            }
        }
    }
    // Objects nothing can push are obstacles too (where they stand; movable ones can be
    // pushed aside, and are not).
    for (k, o) in world.objects.iter().enumerate() {
        if k == t || o.movable {
            continue;
        }
        let pose = world.object_pose(k);
        for part in &o.parts {
            for piece in crate::geometry::convex_pieces(part, 16) {
                let pts: Vec<[f64; 2]> = piece
                    .iter()
                    .map(|p| pose.world_from_local(*p))
                    .map(|p| [f64::from(p.x), f64::from(p.y)])
                    .collect();
                obstacles.push(grown(&pts, r));
            }
        }
    }
    let (c, size) = world.arena;
    // The arena walls are centred on the border: the floor ends half a thickness inside it.
    let inset = f64::from(world.walls[0].size.x) / 2.0 + r;
    let half = [
        f64::from(size.x) / 2.0 - inset,
        f64::from(size.y) / 2.0 - inset,
    ];
    let bounds = (
        [f64::from(c.x) - half[0], f64::from(c.y) - half[1]],
        [f64::from(c.x) + half[0], f64::from(c.y) + half[1]],
    );
    (obstacles, bounds)
}

/// The counter-clockwise convex polygon `pts` grown by `r`: each edge moved out by `r`, the
/// corners where the moved edges meet (so that it holds every point within `r` of `pts`; a
/// corner sharper than about 11 degrees is cut off at 10 r).
fn grown(pts: &[[f64; 2]], r: f64) -> Vec<[f64; 2]> {
    let n = pts.len();
    let normal = |a: [f64; 2], b: [f64; 2]| {
        let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
        let len = (dx * dx + dy * dy).sqrt().max(1e-12);
        [dy / len, -dx / len]
    };
    (0..n)
        .map(|i| {
            let p = pts[i];
            let n1 = normal(pts[(i + n - 1) % n], p);
            let n2 = normal(p, pts[(i + 1) % n]);
            let k = r / (1.0 + n1[0] * n2[0] + n1[1] * n2[1]).max(0.02);
            [p[0] + k * (n1[0] + n2[0]), p[1] + k * (n1[1] + n2[1])]
        })
        .collect()
}

/// Options of one run.
#[derive(Debug, Clone, Default)]
pub struct RunOptions {
    /// Overrides of the scenario.
    pub overrides: Overrides,
    /// Record trajectories.
    pub record: bool,
    /// With `record`: keep robot poses every this many ticks (object: every tick).
    pub robot_every: u64,
    /// Threads for sensing and control within the world (0 or 1: the caller's thread only).
    /// Results are bit-identical for any number; [`crate::world::threads_for`] says how many
    /// pay for a swarm size.
    pub threads: usize,
}

/// A run in progress: a world, its hooks and its clock. [`run`] drives one to the end; a viewer
/// steps it tick by tick.
pub struct Run {
    /// The world.
    pub world: World,
    hooks: Vec<(String, Box<dyn LoopFunctions>)>,
    max_ticks: u64,
    traj: Option<Trajectories>,
    robot_every: u64,
    outcome: Option<Outcome>,
    goal_radius: Option<f32>,
    name: String,
    started: std::time::Instant,
}

impl Run {
    /// Builds the world and the loop functions of the scenario's registry (the built-ins:
    /// transport and filling metrics).
    pub fn new(sc: &Scenario, opts: &RunOptions) -> Result<Run, ScenarioError> {
        let started = std::time::Instant::now();
        let mut world = World::new(sc, &opts.overrides)?;
        // Without threads (none can be started) the world runs on this one: the same results.
        let _ = world.set_threads(opts.threads);
        let goal_radius = goal_radius(sc, &world);
        let hooks = sc.registry().build_loop_functions(sc, &world);
        let duration = opts.overrides.duration_s.unwrap_or(sc.spec.run.duration_s);
        let max_ticks = (f64::from(duration) / f64::from(world.tick_s)).round() as u64;
        let mut traj = opts.record.then(Trajectories::default);
        if let Some(tr) = traj.as_mut() {
            record(&world, tr, true);
        }
        Ok(Run {
            world,
            hooks,
            max_ticks,
            traj,
            robot_every: opts.robot_every.max(1),
            outcome: None,
            goal_radius,
            name: sc.name.clone(),
            started,
        })
    }

    /// The outcome, once the run is over.
    pub fn outcome(&self) -> Option<Outcome> {
        self.outcome
    }

    /// How long the run lasts at most (s): the world's clock after its last tick.
    pub fn duration_s(&self) -> f32 {
        (self.max_ticks as f64 / self.world.tick_hz) as f32
    }

    /// Lower and upper bounds of the readings vectors ([`FlatReadings`]) of group `group`'s
    /// robots over this run ([`FlatReadings::bounds`]); `None` without such a group.
    pub fn reading_bounds(&self, group: usize) -> Option<(Vec<f32>, Vec<f32>)> {
        let g = self.world.groups.get(group)?;
        Some(FlatReadings::of(&g.layout).bounds(
            self.world.arena,
            &g.sensors.noise,
            self.duration_s(),
        ))
    }

    /// The goal radius of the success rule (m).
    pub fn goal_radius(&self) -> Option<f32> {
        self.goal_radius
    }

    /// Advances one tick unless the run is over; returns the outcome once it is.
    pub fn step(&mut self) -> Option<Outcome> {
        if self.outcome.is_some() {
            return self.outcome;
        }
        self.world.step();
        for (_, h) in self.hooks.iter_mut() {
            h.post_step(&self.world);
        }
        if let Some(tr) = self.traj.as_mut() {
            record(
                &self.world,
                tr,
                self.world.tick.is_multiple_of(self.robot_every),
            );
        }
        self.outcome = self
            .hooks
            .iter()
            .find_map(|(_, h)| h.is_finished(&self.world));
        if self.outcome.is_none() && self.world.tick >= self.max_ticks {
            self.outcome = Some(Outcome::Timeout);
        }
        self.outcome
    }

    /// Steps until the run is over.
    pub fn run_to_end(&mut self) -> Outcome {
        loop {
            if let Some(o) = self.step() {
                return o;
            }
        }
    }

    /// The result so far (the outcome reads `timeout` while the run goes on).
    pub fn result(&self) -> RunResult {
        let world = &self.world;
        let mut result = RunResult {
            scenario: self.name.clone(),
            seed: world.seed,
            outcome: self.outcome.unwrap_or(Outcome::Timeout),
            sim_time_s: world.time_s,
            ticks: world.tick,
            robots: world.robots.len(),
            controller: controller_names(world),
            ..RunResult::default()
        };
        for (name, h) in &self.hooks {
            h.finish(world, &mut result);
            result.rename_reserved_extra(name);
        }
        result.wall_time_s = self.started.elapsed().as_secs_f64();
        result
    }

    /// The recorded trajectories, if recording.
    pub fn trajectories(&self) -> Option<&Trajectories> {
        self.traj.as_ref()
    }
}

/// Runs a scenario to its end. Returns the result and, if asked, the trajectories.
pub fn run(
    sc: &Scenario,
    opts: &RunOptions,
) -> Result<(RunResult, Option<Trajectories>), ScenarioError> {
    let mut r = Run::new(sc, opts)?;
    r.run_to_end();
    let result = r.result();
    Ok((result, r.traj))
}

fn controller_names(world: &World) -> String {
    let mut names: Vec<&str> = world.groups.iter().map(|g| g.controller.as_str()).collect();
    names.dedup();
    names.join(",")
}

fn record(world: &World, tr: &mut Trajectories, robots: bool) {
    let t = world.time_s;
    if let Some(i) = world.target {
        let c = world.object_center(i);
        let p = world.object_pose(i);
        tr.object.push(Sample {
            t,
            id: None,
            x: c.x,
            y: c.y,
            theta: p.theta,
        });
    }
    if robots {
        for (k, r) in world.robots.iter().enumerate() {
            if r.body.is_some() {
                let p = world.robot_pose(k);
                tr.robots.push(Sample {
                    t,
                    id: Some(k as u32),
                    x: p.x,
                    y: p.y,
                    theta: p.theta,
                });
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn differences_cover_end_of_run_fields_as_a_store_keeps_them() {
        let fresh = RunResult {
            seed: 3,
            wall_time_s: 1.0,
            extra: [
                ("never".to_string(), serde_json::Value::Null),
                ("flag".to_string(), true.into()),
                ("list".to_string(), serde_json::json!([1, 2])),
                ("fraction".to_string(), 0.25.into()),
            ]
            .into_iter()
            .collect(),
            ..RunResult::default()
        };
        // What a result store reads back: no null field, 0 / 1, JSON text.
        let stored = RunResult {
            wall_time_s: 2.0,
            extra: fresh
                .extra
                .iter()
                .filter_map(|(k, v)| extra_as_stored(v).map(|v| (k.clone(), v)))
                .collect(),
            ..fresh.clone()
        };
        assert_eq!(stored.extra["flag"], 1);
        assert_eq!(stored.extra["list"], "[1,2]");
        assert!(!stored.extra.contains_key("never"));
        assert!(result_differences(&stored, &fresh).is_empty());
        // Every other change to an end-of-run field is one.
        let mut moved = fresh.clone();
        moved.extra.insert("fraction".into(), 0.5.into());
        moved.extra.insert("new".into(), 1.into());
        assert_eq!(
            result_differences(&stored, &moved),
            ["fraction: 0.25, 0.5", "new: none, 1"]
        );
    }
}
