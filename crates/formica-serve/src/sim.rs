//! The one simulation a server shows: a [`Run`] plus play state, stepped by the server's
//! clock thread and read by request handlers, always behind one mutex.

use formica::experiment::{Run, RunOptions};
use formica::geometry::Vec2;
use formica::ops;
use formica::physics::{Nearby, Tag};
use formica::scenario::Color;
use formica::sensors::light_blocked;
use formica::timeseries::TimeSeries;
use formica::{Overrides, RunResult, Scenario, ScenarioError, World};
use serde::Serialize;
use std::collections::{BTreeMap, VecDeque};

/// Most points of the object's path kept (older points are thinned out, never appended
/// without bound).
pub const PATH_CAP: usize = 2048;
/// Most ticks one `step` request may ask for.
pub const MAX_STEP: u64 = 10_000;
/// Slowest and fastest play speeds (simulated seconds per real second).
pub const SPEED_RANGE: (f64, f64) = (0.05, 200.0);
/// Sensor rays are computed for at most this many robots.
pub const MAX_RAY_ROBOTS: usize = 1000;
/// State histories are kept for at most this many robots (the first ones).
pub const MAX_HISTORY_ROBOTS: usize = 1000;
/// How far back a robot's state history reaches (simulated seconds).
pub const HISTORY_S: f64 = 60.0;
/// Most state changes kept per robot within [`HISTORY_S`].
pub const HISTORY_CAP: usize = 256;
/// Most points of the time series kept (thinned as it grows).
pub const SERIES_CAP: usize = 1024;
/// The time series samples this often at first (simulated seconds).
pub const SERIES_EVERY_S: f64 = 0.5;

/// A stored trial the simulation replays: what the page says about it, and the result the run
/// must end with.
#[derive(Debug, Clone)]
pub struct ReplayInfo {
    /// `trial 17 of smoke.db`.
    pub label: String,
    /// Its seed: only a run with this seed is the trial.
    pub seed: u64,
    /// The stored result.
    pub stored: RunResult,
    /// The store's columns of end-of-run fields: the replay's fields without one (added after
    /// the store was written) are not compared.
    pub columns: std::collections::BTreeSet<String>,
    /// Its parameters, as `(key, value)` to show.
    pub params: Vec<(String, String)>,
}

/// Where robots' controller states changed, within the last [`HISTORY_S`].
#[derive(Debug, Clone, Default)]
struct History {
    /// Per robot: (time, state) of each change, oldest first; the first entry is the state at
    /// the start of the window.
    changes: Vec<VecDeque<(f64, &'static str)>>,
}

impl History {
    fn new(w: &World) -> Self {
        let mut h = History {
            changes: vec![VecDeque::new(); w.robots.len().min(MAX_HISTORY_ROBOTS)],
        };
        h.observe(w);
        h
    }

    fn observe(&mut self, w: &World) {
        let t = w.time_s;
        for (q, r) in self.changes.iter_mut().zip(&w.robots) {
            if q.back().is_none_or(|&(_, s)| s != r.state) {
                q.push_back((t, r.state));
            }
            // Keep one change before the window, which says the state at its start.
            while q.len() > HISTORY_CAP || (q.len() >= 2 && q[1].0 <= t - HISTORY_S) {
                q.pop_front();
            }
        }
    }
}

/// The object's path, thinned to at most [`PATH_CAP`] points: every `stride`-th tick is kept,
/// and the stride doubles each time the buffer fills.
#[derive(Debug, Clone)]
struct BoundedPath {
    pts: Vec<[f32; 2]>,
    stride: u64,
    seen: u64,
}

impl BoundedPath {
    fn new() -> Self {
        Self {
            pts: Vec::with_capacity(PATH_CAP),
            stride: 1,
            seen: 0,
        }
    }

    fn push(&mut self, p: Vec2) {
        if self.seen.is_multiple_of(self.stride) {
            if self.pts.len() >= PATH_CAP {
                let mut k = 0;
                self.pts.retain(|_| {
                    k += 1;
                    k % 2 == 1
                });
                self.stride *= 2;
            }
            if self.seen.is_multiple_of(self.stride) {
                self.pts.push([p.x, p.y]);
            }
        }
        self.seen += 1;
    }
}

/// A shared simulation: the run, whether it plays and how fast, and the object's path.
pub struct Sim {
    scenario: Scenario,
    duration_s: Option<f32>,
    run: Run,
    seed: u64,
    generation: u64,
    playing: bool,
    speed: f64,
    owed_ticks: f64,
    path: BoundedPath,
    scene: String,
    near: Vec<Nearby>,
    series: TimeSeries,
    history: History,
    replay: Option<ReplayInfo>,
}

fn pt(v: Vec2) -> [f32; 2] {
    [v.x, v.y]
}

#[derive(Serialize)]
struct ArenaOut {
    center: [f32; 2],
    size: [f32; 2],
}

#[derive(Serialize)]
struct LightOut {
    at: [f32; 2],
    height: f32,
    intensity: f32,
    goal: bool,
}

#[derive(Serialize)]
struct ObjectScene<'a> {
    name: &'a str,
    rgb: [u8; 3],
    movable: bool,
    height: f32,
    /// Outlines in the body frame.
    outlines: Vec<Vec<[f32; 2]>>,
}

#[derive(Serialize)]
struct GroupOut<'a> {
    model: &'a str,
    controller: &'a str,
    radius: f32,
    proximity_angles: &'a [f32],
    proximity_range: f32,
    light_angles: &'a [f32],
}

#[derive(Serialize)]
struct ReplayScene<'a> {
    label: &'a str,
    seed: u64,
    stored_outcome: &'static str,
    stored_time_s: f64,
    stored_ticks: u64,
    params: &'a [(String, String)],
}

#[derive(Serialize)]
struct ReplayState {
    /// Whether this run is the stored trial (its seed).
    active: bool,
    /// Whether it has ended.
    ended: bool,
    /// Once ended: whether it ended exactly as stored.
    matches: Option<bool>,
    /// Once ended: what differs (`field: stored, replayed`).
    differences: Vec<String>,
}

#[derive(Serialize)]
struct SceneOut<'a> {
    generation: u64,
    scenario: &'a str,
    description: Option<&'a str>,
    seed: u64,
    tick_hz: f64,
    duration_s: f32,
    arena: ArenaOut,
    walls: Vec<Vec<[f32; 2]>>,
    lights: Vec<LightOut>,
    goal_radius: Option<f32>,
    objects: Vec<ObjectScene<'a>>,
    groups: Vec<GroupOut<'a>>,
    robots: usize,
    #[serde(skip_serializing_if = "Option::is_none")]
    replay: Option<ReplayScene<'a>>,
}

#[derive(Serialize)]
struct ObjectOut {
    x: f32,
    y: f32,
    theta: f32,
    center: [f32; 2],
}

#[derive(Serialize)]
struct RobotOut {
    x: f32,
    y: f32,
    theta: f32,
    group: usize,
    released: bool,
    led: &'static str,
    rgb: [u8; 3],
    state: &'static str,
    attached: bool,
    /// Distance from the robot's centre to what each proximity ray hits (null: nothing).
    #[serde(skip_serializing_if = "Option::is_none")]
    rays: Option<Vec<Option<f32>>>,
    /// Whether its light sensors see the goal light (nothing hides it and it is in range).
    #[serde(skip_serializing_if = "Option::is_none")]
    sees_goal: Option<bool>,
}

#[derive(Serialize)]
struct StateOut<'a> {
    generation: u64,
    scenario: &'a str,
    seed: u64,
    tick: u64,
    time_s: f64,
    duration_s: f32,
    playing: bool,
    speed: f64,
    outcome: Option<&'static str>,
    released: usize,
    robots_total: usize,
    goal_distance_m: Option<f64>,
    object_path_m: Option<f64>,
    states: BTreeMap<&'static str, usize>,
    /// Where each light is now (a light with a `path` moves).
    lights: Vec<[f32; 2]>,
    objects: Vec<ObjectOut>,
    path: Vec<[f32; 2]>,
    robots: Vec<RobotOut>,
    #[serde(skip_serializing_if = "Option::is_none")]
    zones: Option<Vec<Vec<[f32; 2]>>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    replay: Option<ReplayState>,
}

/// What a state request asks to include besides the basics.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct StateQuery {
    /// Proximity rays and goal-light visibility per robot.
    pub rays: bool,
    /// The zone where the object hides the goal light.
    pub zones: bool,
}

impl Sim {
    /// A paused simulation of `scenario` at tick 0.
    pub fn new(
        scenario: Scenario,
        seed: Option<u64>,
        duration_s: Option<f32>,
    ) -> Result<Sim, ScenarioError> {
        let seed = seed.unwrap_or(scenario.spec.run.seed);
        let run = Self::build(&scenario, seed, duration_s)?;
        let series = TimeSeries::new(&run.world, SERIES_EVERY_S, SERIES_CAP);
        let history = History::new(&run.world);
        let mut sim = Sim {
            scenario,
            duration_s,
            run,
            seed,
            generation: 1,
            playing: false,
            speed: 1.0,
            owed_ticks: 0.0,
            path: BoundedPath::new(),
            scene: String::new(),
            near: Vec::new(),
            series,
            history,
            replay: None,
        };
        sim.reset_derived();
        Ok(sim)
    }

    /// Marks the run with `info.seed` as the replay of a stored trial: the scene says which,
    /// and the state, once it ends, whether it ended as stored.
    pub fn set_replay(&mut self, info: ReplayInfo) {
        self.replay = Some(info);
        self.scene = self.scene_json_now();
    }

    fn build(sc: &Scenario, seed: u64, duration_s: Option<f32>) -> Result<Run, ScenarioError> {
        let opts = RunOptions {
            overrides: Overrides {
                seed: Some(seed),
                duration_s,
                controller: None,
            },
            record: false,
            robot_every: 1,
            // Large swarms sense and control on every core (the same results).
            threads: formica::world::threads_for(
                sc.robot_count(),
                std::thread::available_parallelism().map_or(1, |n| n.get()),
            ),
        };
        Run::new(sc, &opts)
    }

    fn reset_derived(&mut self) {
        self.path = BoundedPath::new();
        if let Some(t) = self.run.world.target {
            self.path.push(self.run.world.object_center(t));
        }
        self.owed_ticks = 0.0;
        self.series = TimeSeries::new(&self.run.world, SERIES_EVERY_S, SERIES_CAP);
        self.history = History::new(&self.run.world);
        self.scene = self.scene_json_now();
    }

    /// Starts over with `seed` (default: the next seed). Keeps playing if it was.
    pub fn restart(&mut self, seed: Option<u64>) -> Result<(), ScenarioError> {
        // The next seed, back to 0 after the largest a scenario takes (so that any run shown
        // can be run again with `formica run --seed`).
        let seed = seed.unwrap_or(if self.seed >= formica::limits::MAX_SEED {
            0
        } else {
            self.seed + 1
        });
        self.run = Self::build(&self.scenario, seed, self.duration_s)?;
        self.seed = seed;
        self.generation += 1;
        self.reset_derived();
        Ok(())
    }

    /// Advances up to `n` ticks (fewer if the run ends); returns how many ran.
    pub fn step(&mut self, n: u64) -> u64 {
        self.step_within(n, None)
    }

    /// As [`Sim::step`], but stops once `budget` of wall time has gone (after the tick that
    /// passes it), so that a large step of a large swarm does not hold the simulation thread
    /// past what a client waits for.
    pub fn step_within(&mut self, n: u64, budget: Option<std::time::Duration>) -> u64 {
        let t0 = std::time::Instant::now();
        let mut done = 0;
        while done < n
            && self.run.outcome().is_none()
            && budget.is_none_or(|b| done == 0 || t0.elapsed() < b)
        {
            let ended = self.run.step().is_some();
            let w = &self.run.world;
            if let Some(t) = w.target {
                self.path.push(w.object_center(t));
            }
            self.series.observe(w);
            if ended {
                self.series.sample(w);
            }
            self.history.observe(w);
            done += 1;
        }
        done
    }

    /// Called by the clock: owes `real_s * speed * tick_hz` more ticks while playing, and runs
    /// owed ticks until `budget` has passed. Debt the simulation cannot catch up is dropped,
    /// so a slow world plays slower rather than queueing work.
    pub fn advance(&mut self, real_s: f64, budget: std::time::Duration) -> u64 {
        if !self.playing || self.run.outcome().is_some() {
            self.owed_ticks = 0.0;
            return 0;
        }
        self.owed_ticks += real_s * self.speed * self.run.world.tick_hz;
        let start = std::time::Instant::now();
        let mut done = 0;
        while self.owed_ticks >= 1.0 && start.elapsed() < budget {
            if self.step(1) == 0 {
                break;
            }
            self.owed_ticks -= 1.0;
            done += 1;
        }
        self.owed_ticks = self.owed_ticks.min(1.0);
        if self.run.outcome().is_some() {
            self.playing = false;
        }
        done
    }

    /// Plays or pauses.
    pub fn set_playing(&mut self, playing: bool) {
        self.playing = playing && self.run.outcome().is_none();
        self.owed_ticks = 0.0;
    }

    /// Sets the play speed (simulated seconds per real second), within [`SPEED_RANGE`].
    pub fn set_speed(&mut self, speed: f64) -> Result<(), String> {
        let (lo, hi) = SPEED_RANGE;
        if !(speed >= lo && speed <= hi) {
            return Err(format!("speed must be between {lo} and {hi}, got {speed}"));
        }
        self.speed = speed;
        Ok(())
    }

    /// Whether it plays.
    pub fn playing(&self) -> bool {
        self.playing
    }

    /// Ticks done.
    pub fn tick(&self) -> u64 {
        self.run.world.tick
    }

    /// Seed in use.
    pub fn seed(&self) -> u64 {
        self.seed
    }

    /// How many restarts (plus one) this simulation has had.
    pub fn generation(&self) -> u64 {
        self.generation
    }

    /// Points of the object's path held (at most [`PATH_CAP`]).
    pub fn path_points(&self) -> usize {
        self.path.pts.len()
    }

    /// The world.
    pub fn world(&self) -> &World {
        &self.run.world
    }

    fn duration(&self) -> f32 {
        self.duration_s.unwrap_or(self.scenario.spec.run.duration_s)
    }

    /// The static scene (arena, walls, lights, object outlines, robot groups) as JSON.
    pub fn scene_json(&self) -> &str {
        &self.scene
    }

    fn scene_json_now(&self) -> String {
        let w = &self.run.world;
        let walls = w
            .walls
            .iter()
            .map(|wl| wl.outline().into_iter().map(pt).collect())
            .collect();
        let out = SceneOut {
            generation: self.generation,
            scenario: &self.scenario.name,
            description: self.scenario.spec.description.as_deref(),
            seed: self.seed,
            tick_hz: w.tick_hz,
            duration_s: self.duration(),
            arena: ArenaOut {
                center: pt(w.arena.0),
                size: pt(w.arena.1),
            },
            walls,
            lights: w
                .lights
                .iter()
                .enumerate()
                .map(|(i, l)| LightOut {
                    at: pt(l.position),
                    height: l.height,
                    intensity: l.intensity,
                    goal: w.goal_light == Some(i),
                })
                .collect(),
            goal_radius: self.run.goal_radius(),
            objects: w
                .objects
                .iter()
                .map(|o| ObjectScene {
                    name: &o.name,
                    rgb: o.color.rgb(),
                    movable: o.movable,
                    height: o.height,
                    outlines: o
                        .outlines()
                        .into_iter()
                        .map(|ol| ol.into_iter().map(pt).collect())
                        .collect(),
                })
                .collect(),
            groups: w
                .groups
                .iter()
                .map(|g| GroupOut {
                    model: &g.model_name,
                    controller: &g.controller,
                    radius: g.model.radius,
                    proximity_angles: &g.model.proximity_angles,
                    proximity_range: g.model.proximity_range,
                    light_angles: &g.model.light_angles,
                })
                .collect(),
            robots: w.robots.len(),
            replay: self.replay.as_ref().map(|r| ReplayScene {
                label: &r.label,
                seed: r.seed,
                stored_outcome: r.stored.outcome.name(),
                stored_time_s: r.stored.sim_time_s,
                stored_ticks: r.stored.ticks,
                params: &r.params,
            }),
        };
        serde_json::to_string(&out).unwrap_or_else(|e| format!("{{\"error\":\"{e}\"}}"))
    }

    /// The state now (time, outcome, object, path, robots) as JSON.
    pub fn state_json(&mut self, q: StateQuery) -> String {
        let result = self.run.result();
        let w = &self.run.world;
        let mut states: BTreeMap<&'static str, usize> = BTreeMap::new();
        let mut robots = Vec::with_capacity(w.robots.len());
        for (i, r) in w.robots.iter().enumerate() {
            *states.entry(r.state).or_default() += 1;
            let pose = w.robot_pose(i);
            let released = r.body.is_some();
            let detail = q.rays && released && i < MAX_RAY_ROBOTS;
            let rgb = match r.led {
                Color::Off => [200, 200, 205],
                c => c.rgb(),
            };
            robots.push(RobotOut {
                x: pose.x,
                y: pose.y,
                theta: pose.theta,
                group: r.group,
                released,
                led: r.led.name(),
                rgb,
                state: r.state,
                attached: r.attached.is_some(),
                rays: detail.then(|| proximity_rays(w, i, &mut self.near)),
                sees_goal: detail.then(|| sees_goal(w, i, &mut self.near)),
            });
        }
        let mut path = self.path.pts.clone();
        if let Some(t) = w.target {
            let c = pt(w.object_center(t));
            if path.last() != Some(&c) {
                path.push(c);
            }
        }
        let zones = q.zones.then(|| {
            formica_render::occlusion_zones(w, formica_render::light_sensor_height(w))
                .into_iter()
                .map(|z| z.into_iter().map(pt).collect())
                .collect()
        });
        let out = StateOut {
            generation: self.generation,
            scenario: &self.scenario.name,
            seed: self.seed,
            tick: w.tick,
            time_s: w.time_s,
            duration_s: self.duration(),
            playing: self.playing,
            speed: self.speed,
            outcome: self.run.outcome().map(|o| o.name()),
            released: w.released(),
            robots_total: w.robots.len(),
            goal_distance_m: result.goal_distance_m,
            object_path_m: result.object_path_m,
            states,
            lights: w.lights.iter().map(|l| pt(l.position)).collect(),
            objects: (0..w.objects.len())
                .map(|i| {
                    let p = w.object_pose(i);
                    ObjectOut {
                        x: p.x,
                        y: p.y,
                        theta: p.theta,
                        center: pt(w.object_center(i)),
                    }
                })
                .collect(),
            path,
            robots,
            zones,
            replay: self.replay.as_ref().map(|r| {
                let active = r.seed == self.seed;
                let ended = self.run.outcome().is_some();
                let differences = if active && ended {
                    formica::experiment::replay_differences(&r.stored, &result, &r.columns)
                } else {
                    Vec::new()
                };
                ReplayState {
                    active,
                    ended,
                    matches: (active && ended).then_some(differences.is_empty()),
                    differences,
                }
            }),
        };
        serde_json::to_string(&out).unwrap_or_else(|e| format!("{{\"error\":\"{e}\"}}"))
    }

    /// The time series so far (goal distance, object speed, robots per state) as JSON, ending
    /// with the state now.
    pub fn series_json(&self) -> String {
        let mut series = self.series.clone();
        series.sample(&self.run.world);
        let mut v = series.to_json();
        if let Some(m) = v.as_object_mut() {
            m.insert("generation".into(), self.generation.into());
        }
        v.to_string()
    }

    /// What robot `i` senses and does now, and its state history, as JSON; `None` if there is
    /// no such robot.
    pub fn robot_json(&mut self, i: usize) -> Option<String> {
        let w = &self.run.world;
        let r = w.robots.get(i)?;
        let g = &w.groups[r.group];
        let rd = &r.readings;
        let pose = w.robot_pose(i);
        let history: Vec<serde_json::Value> = self
            .history
            .changes
            .get(i)
            .map(|q| {
                q.iter()
                    .map(|(t, s)| serde_json::json!({ "t_s": t, "state": s }))
                    .collect()
            })
            .unwrap_or_default();
        let blobs: Vec<serde_json::Value> = rd
            .blobs
            .iter()
            .map(|b| {
                serde_json::json!({
                    "bearing": b.bearing,
                    "distance": b.distance,
                    "color": b.color.name(),
                    "rgb": b.color.rgb(),
                })
            })
            .collect();
        let released = r.body.is_some();
        let rays = (released && i < MAX_RAY_ROBOTS).then(|| proximity_rays(w, i, &mut self.near));
        let v = serde_json::json!({
            "generation": self.generation,
            "robot": i,
            "tick": w.tick,
            "time_s": w.time_s,
            "group": r.group,
            "controller": g.controller,
            "model": g.model.kind,
            "state": r.state,
            "led": r.led.name(),
            "released": released,
            "attached": r.attached.is_some(),
            "pose": [pose.x, pose.y, pose.theta],
            "wheels": [r.action.left, r.action.right],
            "max_speed": g.model.max_speed,
            "proximity_angles": g.model.proximity_angles,
            "light_angles": g.model.light_angles,
            "readings": {
                "proximity": rd.proximity,
                "light": rd.light,
                "beacon": rd.beacon.map(pt),
                "blobs": blobs,
                "attached": rd.attached,
            },
            "rays": rays,
            "history_s": HISTORY_S,
            "history": history,
        });
        Some(v.to_string())
    }
}

fn tag_height(w: &World, tag: Tag) -> f32 {
    match tag {
        Tag::Wall(i) => w.walls.get(i).map_or(0.0, |x| x.height),
        Tag::Object(i) => w.objects.get(i).map_or(0.0, |x| x.height),
        Tag::Robot(i) => w
            .robots
            .get(i)
            .map_or(0.0, |r| w.groups[r.group].model.height),
    }
}

/// Where robot `i`'s proximity rays end: distance from its centre to the first thing hit
/// within its range, as its sensors cast them.
fn proximity_rays(w: &World, i: usize, near: &mut Vec<Nearby>) -> Vec<Option<f32>> {
    let model = w.robot_model(i);
    let pose = w.robot_pose(i);
    let center = pose.position();
    let reach = model.radius + model.proximity_range;
    w.physics.nearby(center, reach + 0.01, near);
    model
        .proximity_angles
        .iter()
        .map(|a| {
            let th = pose.theta + a;
            let dir = ops::unit(th);
            w.physics
                .cast_local(near, Some(Tag::Robot(i)), center, dir, reach)
                .map(|(_, t)| t)
        })
        .collect()
}

/// Whether robot `i`'s light sensors see the goal light: in range and not hidden (the rule of
/// [`light_blocked`] against every body the line of sight enters).
fn sees_goal(w: &World, i: usize, near: &mut Vec<Nearby>) -> bool {
    let Some(light) = w.goal_light.and_then(|g| w.lights.get(g)) else {
        return false;
    };
    let model = w.robot_model(i);
    let center = w.robot_pose(i).position();
    let to = light.position - center;
    let dist = to.length();
    let dh = light.height - model.light_height;
    let value =
        formica::robot::RobotModel::light_value((dist * dist + dh * dh).sqrt(), light.intensity);
    if value <= 0.0 {
        return false;
    }
    if dist < 1e-6 {
        return true;
    }
    let dir = to / dist;
    w.physics
        .nearby(center + dir * (dist / 2.0), dist / 2.0 + 0.5, near);
    let me = Tag::Robot(i);
    !near.iter().any(|n| {
        n.tag != me
            && w.physics
                .cast_local(std::slice::from_ref(n), None, center, dir, dist)
                .is_some_and(|(_, t)| {
                    light_blocked(
                        model.light_height,
                        light.height,
                        dist,
                        t,
                        tag_height(w, n.tag),
                    )
                })
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn path_stays_bounded_and_keeps_its_ends() {
        let mut p = BoundedPath::new();
        for k in 0..100_000u32 {
            p.push(Vec2::new(k as f32, 0.0));
            assert!(p.pts.len() <= PATH_CAP);
        }
        assert_eq!(p.pts[0], [0.0, 0.0]);
        let last = p.pts[p.pts.len() - 1][0];
        assert!(last > 90_000.0, "last kept point {last}");
        // Kept points are evenly spaced.
        let d = p.pts[1][0] - p.pts[0][0];
        assert!(p.pts.windows(2).all(|w| w[1][0] - w[0][0] == d));
    }
}
