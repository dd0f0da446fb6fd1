//! The world: walls, objects, lights and robots built from a scenario, and the one function
//! that holds the tick order ([`World::step`]): act, physics sub-steps, sense, control.

use crate::controller::{
    Actuation, AttachCommand, BatchController, BatchRobot, Controller, ControllerFactory, RobotRng,
};
use crate::geometry::{bounds, compound_shape, part_outlines, Part, Pose, Vec2};
use crate::parallel;
use crate::physics::{AttachId, BodyId, Nearby, Physics, Tag};
use crate::robot::RobotModel;
use crate::scenario::{
    steps_for, Color, Placement, Scenario, ScenarioError, SensorConfig, Substeps, WheelOptions,
};
use crate::sensors::{
    sense, Beacons, Light, Readings, Scratch, SenseContext, SensorLayout, SensorNeeds, Shadows,
};
use rand::{Rng, SeedableRng};
use std::sync::Arc;
use std::time::Instant;

/// A static wall or obstacle: a box, or any shape an object can have.
#[derive(Debug, Clone, PartialEq)]
pub struct Wall {
    /// Centre (the origin of `shape`).
    pub center: Vec2,
    /// Size before rotation: of the box, or of the box round `shape`'s outline.
    pub size: Vec2,
    /// Rotation (rad).
    pub yaw: f32,
    /// Height (m).
    pub height: f32,
    /// Its shape in its own frame (`None`: a box of `size` centred on `center`).
    pub shape: Option<Part>,
}

impl Wall {
    /// A box wall.
    fn boxed(center: Vec2, size: Vec2, height: f32) -> Self {
        Self {
            center,
            size,
            yaw: 0.0,
            height,
            shape: None,
        }
    }

    /// Its outline in the world (discs with 32 sides), counter-clockwise for boxes.
    pub fn outline(&self) -> Vec<Vec2> {
        let pose = Pose::new(self.center.x, self.center.y, self.yaw);
        let local = match &self.shape {
            None => {
                let h = self.size / 2.0;
                vec![
                    Vec2::new(-h.x, -h.y),
                    Vec2::new(h.x, -h.y),
                    Vec2::new(h.x, h.y),
                    Vec2::new(-h.x, h.y),
                ]
            }
            Some(p) => part_outlines(std::slice::from_ref(p), 32)
                .pop()
                .unwrap_or_default(),
        };
        local
            .into_iter()
            .map(|v| pose.world_from_local(v))
            .collect()
    }

    /// Whether the point `p` lies inside its outline.
    pub fn contains(&self, p: Vec2) -> bool {
        rapier2d::parry::utils::point_in_poly2d(p, &self.outline())
    }
}

/// An object in the world.
#[derive(Debug, Clone)]
pub struct Object {
    /// Name for reports.
    pub name: String,
    /// Physics body.
    pub body: BodyId,
    /// Its parts, in the body frame.
    pub parts: Vec<Part>,
    /// Height (m).
    pub height: f32,
    /// Mass (kg).
    pub mass: f32,
    /// Whether it can move.
    pub movable: bool,
    /// Colour.
    pub color: Color,
    /// Its centre of mass at the start.
    pub start: Vec2,
}

impl Object {
    /// Outlines of the parts in the body frame (discs as 24-gons), for drawing and metrics.
    pub fn outlines(&self) -> Vec<Vec<Vec2>> {
        part_outlines(&self.parts, 24)
    }

    /// Its radius (m): the farthest point of its outline from its centre of mass.
    pub fn radius(&self, physics: &Physics) -> f32 {
        let (pose, c) = (physics.pose(self.body), physics.center_of_mass(self.body));
        self.outlines()
            .into_iter()
            .flatten()
            .map(|p| (pose.world_from_local(p) - c).length())
            .fold(0.0, f32::max)
    }
}

/// The objects that carry a beacon: every movable one (the target object when none is).
fn beacon_objects(objects: &[Object], target: Option<usize>) -> impl Iterator<Item = usize> + '_ {
    let any_movable = objects.iter().any(|o| o.movable);
    (0..objects.len()).filter(move |&i| {
        if any_movable {
            objects[i].movable
        } else {
            Some(i) == target
        }
    })
}

/// Per-group settings shared by its robots.
pub struct Group {
    /// Robot model.
    pub model: RobotModel,
    /// The model's name in the registry.
    pub model_name: String,
    /// Sensor layout handed to controllers.
    pub layout: SensorLayout,
    /// Sensor settings (the noise preset with the file's overrides).
    pub sensors: SensorConfig,
    /// Wheel speed errors.
    pub wheels: WheelOptions,
    /// Controller name.
    pub controller: String,
    factory: ControllerFactory,
    /// The group's batch controller, when its controller decides for all its robots at once.
    batch: Option<Box<dyn BatchController>>,
}

impl Group {
    /// Which sensors this group's controllers read.
    pub fn needs(&self) -> SensorNeeds {
        self.factory.needs
    }

    /// Whether one batch controller decides for all the group's robots
    /// ([`ControllerFactory::batched`]).
    pub fn is_batched(&self) -> bool {
        self.batch.is_some()
    }
}

/// A warning about a group's sensors, for `formica check`: the oracle camera (an ablation that
/// no real robot has), or a noise-free run.
pub fn sensor_warning(g: &Group) -> Option<String> {
    use crate::scenario::CameraKind;
    let mut w = Vec::new();
    if g.sensors.camera == CameraKind::Oracle && g.needs().camera {
        w.push(
            "camera = \"oracle\": the camera sees object bodies and distances to their surfaces, \
             which no real colour-blob camera does (an ablation; the default is \"blob\")",
        );
    }
    if g.sensors.preset == crate::noise::NoisePreset::None {
        w.push("noise = \"none\": every reading is exact (no real robot's are)");
    }
    (!w.is_empty()).then(|| w.join("; "))
}

/// How many times the usual solver iterations the contacts of a swarm of `groups` among
/// `objects` need: `ceil(sqrt(heaviest robot / lightest robot or movable object))`, at most
/// 4, so 1 for robots of one model and objects heavier than them. With the usual ones, a
/// 1.6 kg foot-bot driving a 0.15 kg e-puck into the box sank it 18 mm into the box and 22 mm
/// into other robots, and Khepera IV sank 16 mm into a 50 g box they squeezed; with 4 times as
/// many, under 5 mm (`tests/physics_validation.rs`).
fn solver_factor(groups: &[Group], objects: &[Object]) -> u32 {
    let (lo, hi) = groups
        .iter()
        .map(|g| g.model.mass)
        .fold((f32::INFINITY, 0.0f32), |(lo, hi), m| {
            (lo.min(m), hi.max(m))
        });
    // An object lighter than the robots is squeezed between them as a light robot is.
    let lo = objects
        .iter()
        .filter(|o| o.movable)
        .map(|o| o.mass)
        .fold(lo, f32::min);
    if !(lo > 0.0 && hi > lo) {
        return 1;
    }
    ((hi / lo).sqrt().ceil() as u32).clamp(1, MAX_SOLVER_FACTOR)
}

/// The message a panic carries (`panic!` gives a `String` or a `&str`), if it carries one: for
/// those who catch what [`World::step`] raises (a controller's NaN wheel speed) and report it.
pub fn panic_message(payload: &(dyn std::any::Any + Send)) -> Option<String> {
    payload
        .downcast_ref::<String>()
        .cloned()
        .or_else(|| payload.downcast_ref::<&str>().map(|s| s.to_string()))
}

/// The most `solver_factor` gives.
pub const MAX_SOLVER_FACTOR: u32 = 4;

/// One robot.
pub struct Robot {
    /// Index of its group.
    pub group: usize,
    /// Physics body, once released.
    pub body: Option<BodyId>,
    /// When it enters the arena (s).
    pub release_s: f32,
    /// Start pose.
    pub start: Pose,
    /// Latest readings.
    pub readings: Readings,
    /// What it asked for last.
    pub action: Actuation,
    /// LED colour now.
    pub led: Color,
    /// Attachment: joint and the object it belongs to.
    pub attached: Option<(AttachId, usize)>,
    /// Time it attached (s).
    pub attached_at_s: Option<f32>,
    /// Controller state name.
    pub state: &'static str,
    controller: Box<dyn Controller>,
    rng: RobotRng,
    sense_rng: RobotRng,
    /// Draws of its wheel errors (its own stream: they move no other draw).
    motor_rng: RobotRng,
    /// Each wheel's fixed speed factor (`wheels.bias`; 1 without).
    wheel_factor: [f32; 2],
    /// Left and right wheel speeds (m/s) it turns at this tick: its command, capped at the
    /// model's top speed, with its wheel errors.
    wheels: [f32; 2],
}

impl Robot {
    /// Left and right wheel speeds (m/s) it turns at this tick: its last command, capped at
    /// the model's top speed, with its group's wheel errors (`wheels`).
    pub fn wheel_speeds(&self) -> [f32; 2] {
        self.wheels
    }
}

/// Options that override what a scenario file says.
#[derive(Debug, Clone, Default)]
pub struct Overrides {
    /// Seed (default: the file's `run.seed`).
    pub seed: Option<u64>,
    /// Duration (s).
    pub duration_s: Option<f32>,
    /// Controller for every group.
    pub controller: Option<String>,
}

/// The simulated world.
pub struct World {
    /// Rigid bodies and queries.
    pub physics: Physics,
    /// Walls (the four arena walls first).
    pub walls: Vec<Wall>,
    /// Objects.
    pub objects: Vec<Object>,
    /// Lights.
    pub lights: Vec<Light>,
    /// Index of the goal light.
    pub goal_light: Option<usize>,
    /// Robot groups.
    pub groups: Vec<Group>,
    /// Robots.
    pub robots: Vec<Robot>,
    /// Index of the object whose centre the beacon gives and whose transport is measured.
    pub target: Option<usize>,
    /// Simulated time (s).
    pub time_s: f64,
    /// Ticks done.
    pub tick: u64,
    /// Seconds per tick.
    pub tick_s: f32,
    /// Ticks per second.
    pub tick_hz: f64,
    /// Physics steps in the last tick.
    pub substeps: u32,
    /// Fixed physics steps per tick, or `None` for as many as the speeds need.
    fixed_substeps: Option<u32>,
    /// Smallest robot radius (m), for the automatic sub-steps.
    smallest_radius: f32,
    /// How many times the usual solver iterations a step takes ([`solver_factor`]).
    solver_factor: u32,
    /// Seed in use.
    pub seed: u64,
    /// Arena centre and size.
    pub arena: (Vec2, Vec2),
    near: Vec<Nearby>,
    beacons: Beacons,
    /// Per light, the walls and objects by direction (with many fixtures only).
    shadows: Vec<Shadows>,
    buffers: SenseBuffers,
    /// Sensing's scratch space, one per worker thread.
    scratch: Vec<Scratch>,
    /// Threads for sensing and control (`None`: this thread only).
    pool: Option<Arc<rayon::ThreadPool>>,
    /// Time spent in each part of the tick, when measured ([`World::measure_time`]).
    pub timing: Option<StepTiming>,
    /// Moving lights: index and schedule.
    light_paths: Vec<(usize, crate::scenario::LightSpec)>,
}

/// Wall-clock time spent in each part of [`World::step`] since timing was switched on.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct StepTiming {
    /// Releases, actions, the sub-step plan and the physics steps (s).
    pub physics_s: f64,
    /// The neighbour index, beacons and every robot's readings (s).
    pub sense_s: f64,
    /// Controllers (s).
    pub control_s: f64,
}

/// Per-tick arrays of robot facts that sensing reads (kept to save allocations).
#[derive(Debug, Default)]
struct SenseBuffers {
    heights: Vec<f32>,
    discs: Vec<(Vec2, f32)>,
    leds: Vec<Color>,
}

/// Worlds with at least this many walls and objects index them by direction from each light.
const SHADOWS_MIN_FIXTURES: usize = 12;

/// Swarms at least this large sense and control on several threads when the caller allows
/// it ([`threads_for`]); below, one tick is too short for the hand-over to pay.
pub const PARALLEL_MIN_ROBOTS: usize = 400;

/// The threads a world of `robots` robots should use when `available` are free for it: one
/// below [`PARALLEL_MIN_ROBOTS`], else all of them.
pub fn threads_for(robots: usize, available: usize) -> usize {
    if robots < PARALLEL_MIN_ROBOTS {
        1
    } else {
        available.max(1)
    }
}

/// Robots handed to a thread at a time when sensing and control run on several threads.
const ROBOTS_PER_CHUNK: usize = 16;

fn splitmix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// A wheel's fixed speed factor: `1 + bias z`, `z` standard normal, never below 0.
fn wheel_factor(bias: f32, rng: &mut RobotRng) -> f32 {
    (1.0 + bias * crate::ops::standard_normal(rng)).max(0.0)
}

/// A portable generator for stream `kind`, member `index`, of run `seed`.
pub fn rng_stream(seed: u64, kind: u64, index: u64) -> RobotRng {
    let a = splitmix(seed ^ splitmix(kind.wrapping_add(0x5151)));
    let b = splitmix(a ^ splitmix(index.wrapping_add(0xA5A5)));
    let c = splitmix(b);
    RobotRng::from_seed(((u128::from(b) << 64) | u128::from(c)).to_le_bytes())
}

impl World {
    /// Builds the world a scenario describes, for one seed. Controllers and robot models come
    /// from the scenario's [`Registry`](crate::Registry).
    pub fn new(sc: &Scenario, ov: &Overrides) -> Result<World, ScenarioError> {
        let spec = &sc.spec;
        let seed = ov.seed.unwrap_or(spec.run.seed);
        let tick_s = 1.0 / spec.run.tick_hz;
        let substeps = sc.max_substeps();
        let bodies = sc.robot_count()
            + spec
                .objects
                .iter()
                .map(|o| o.get_ref().parts.len().max(1))
                .sum::<usize>()
            + spec.walls.len()
            + 4;
        let mut physics = Physics::with_capacity(tick_s / substeps as f32, bodies);
        let smallest_radius = sc.speed_and_radius().map_or(0.0, |(_, r)| r);

        // Arena walls, centred on the border of the usable area.
        let c = Vec2::new(spec.arena.center[0], spec.arena.center[1]);
        let (w, h) = (spec.arena.size[0], spec.arena.size[1]);
        let t = spec.arena.wall_thickness;
        let wh = spec.arena.wall_height;
        let mut walls = vec![
            Wall::boxed(c + Vec2::new(w / 2.0, 0.0), Vec2::new(t, h + t), wh),
            Wall::boxed(c - Vec2::new(w / 2.0, 0.0), Vec2::new(t, h + t), wh),
            Wall::boxed(c + Vec2::new(0.0, h / 2.0), Vec2::new(w + t, t), wh),
            Wall::boxed(c - Vec2::new(0.0, h / 2.0), Vec2::new(w + t, t), wh),
        ];
        // Bodies in file order, the arena's four first (their order is the engine's).
        for (i, wl) in walls.iter().enumerate() {
            physics.add_wall(wl.center, wl.size, wl.yaw, i);
        }
        for (k, wsp) in spec.walls.iter().enumerate() {
            let ws = wsp.get_ref();
            let center = Vec2::new(ws.at[0], ws.at[1]);
            let yaw = ws.yaw_deg.to_radians();
            let i = walls.len();
            match sc.wall_part(k)? {
                None => {
                    let size = ws.size.unwrap_or_default();
                    physics.add_wall(center, Vec2::new(size[0], size[1]), yaw, i);
                    walls.push(Wall {
                        center,
                        size: Vec2::new(size[0], size[1]),
                        yaw,
                        height: ws.height,
                        shape: None,
                    });
                }
                Some(part) => {
                    let span = ws.shape.as_ref().map_or(wsp.span(), |s| s.span());
                    let shape = compound_shape(std::slice::from_ref(&part))
                        .map_err(|e| sc.error_at(span, format!("walls[{k}].shape: {}", e.0)))?;
                    physics.add_wall_shape(shape, Pose::new(center.x, center.y, yaw), i);
                    let (lo, hi) = bounds(&part_outlines(std::slice::from_ref(&part), 32).concat());
                    walls.push(Wall {
                        center,
                        size: (hi - lo).max(Vec2::ZERO),
                        yaw,
                        height: ws.height,
                        shape: Some(part),
                    });
                }
            }
        }
        let outer = Vec2::new(w + t, h + t) / 2.0;
        physics.set_index_area(c - outer, c + outer);

        let mut objects = Vec::new();
        for (i, o) in spec.objects.iter().enumerate() {
            let parts = sc.object_parts(i)?;
            let shape = compound_shape(&parts).map_err(|e| sc.error_at(o.span(), e.0))?;
            let os = o.get_ref();
            let pose = Pose::new(os.at[0], os.at[1], os.yaw_deg.to_radians());
            object_fits(sc, i, &shape, pose, &physics, c, Vec2::new(w, h))?;
            let body = physics.add_object(
                shape,
                crate::geometry::overlap_moments(&parts),
                pose,
                os.mass,
                os.movable,
                os.floor_mu,
                i,
            );
            objects.push(Object {
                name: os.name.clone().unwrap_or_else(|| format!("object{i}")),
                body,
                parts,
                height: os.height,
                mass: os.mass,
                movable: os.movable,
                color: os.color,
                start: physics.center_of_mass(body),
            });
        }
        let target = objects
            .iter()
            .position(|o| o.movable)
            .or(if objects.is_empty() { None } else { Some(0) });
        let beacon_radius = beacon_objects(&objects, target)
            .map(|i| objects[i].radius(&physics))
            .reduce(f32::max);

        let lights = spec
            .lights
            .iter()
            .map(|l| l.get_ref())
            .map(|l| Light {
                position: Vec2::new(l.at[0], l.at[1]),
                height: l.height,
                intensity: l.intensity,
                color: l.color,
            })
            .collect();
        let light_paths = spec
            .lights
            .iter()
            .enumerate()
            .filter(|(_, l)| !l.get_ref().path.is_empty())
            .map(|(i, l)| (i, l.get_ref().clone()))
            .collect();

        // Robot groups and placement.
        let mut groups = Vec::new();
        let mut robots: Vec<Robot> = Vec::with_capacity(sc.robot_count());
        let mut place_rng = rng_stream(seed, 0, 0);
        let largest_radius = spec
            .robots
            .iter()
            .filter_map(|g| sc.registry().robot_model(g.get_ref().model.get_ref()))
            .map(|m| m.radius)
            .fold(0.0, f32::max);
        let mut placed = Placed::new(largest_radius);
        for (g, grp_s) in spec.robots.iter().enumerate() {
            let grp = grp_s.get_ref();
            let registry = sc.registry();
            let model_name = grp.model.get_ref().clone();
            let model = registry.robot_model(&model_name).cloned().ok_or_else(|| {
                let m = registry.unknown_model(&model_name);
                sc.error_at(grp.model.span(), format!("robots[{g}].model: {m}"))
            })?;
            let sensors = grp.sensors.resolve(model.kind);
            let layout = SensorLayout {
                beacon_radius,
                tick_s,
                ..SensorLayout::of(&model, &sensors)
            };
            let name = ov
                .controller
                .clone()
                .unwrap_or_else(|| grp.controller.get_ref().clone());
            let factory = registry
                .build_controller(&name, grp.params.as_ref().map(|p| p.get_ref()), &layout)
                .map_err(|m| {
                    // At the params (the file's line, or the `--set` that wrote them): they are
                    // what the controller refused, whichever controller it is.
                    let span = match &grp.params {
                        Some(p) => p.span(),
                        None => grp.controller.span(),
                    };
                    // Another controller than the file's keeps the file's params, which may
                    // be for the file's controller only: say so, and what to do.
                    let hint = match sc.params_written_for(g) {
                        Some(file_controller) if file_controller != name => format!(
                            " (robots[{g}].params were written for `{file_controller}`, the \
                             file's controller, and are kept with another: set them for \
                             `{name}`, `--set 'robots.{g}.params={{}}'` for its defaults)"
                        ),
                        _ => String::new(),
                    };
                    sc.error_at(span, format!("robots[{g}] controller `{name}`: {m}{hint}"))
                })?;
            let count = sc.group_count(g);
            let poses = place_group(
                sc,
                g,
                count,
                &model,
                &physics,
                &mut place_rng,
                &mut placed,
                c,
                Vec2::new(w, h),
            )?;
            for (k, pose) in poses.into_iter().enumerate() {
                let idx = robots.len();
                let mut motor_rng = rng_stream(seed, 3, idx as u64);
                let wheel_factor = if grp.wheels.bias > 0.0 {
                    [(); 2].map(|()| wheel_factor(grp.wheels.bias, &mut motor_rng))
                } else {
                    [1.0; 2]
                };
                robots.push(Robot {
                    group: g,
                    body: None,
                    release_s: grp.release.start_s + grp.release.interval_s * k as f32,
                    start: pose,
                    readings: Readings::default(),
                    action: Actuation::default(),
                    led: Color::Off,
                    attached: None,
                    attached_at_s: None,
                    state: "waiting",
                    controller: factory.make(),
                    rng: rng_stream(seed, 1, idx as u64),
                    sense_rng: rng_stream(seed, 2, idx as u64),
                    motor_rng,
                    wheel_factor,
                    wheels: [0.0; 2],
                });
            }
            groups.push(Group {
                model,
                model_name,
                layout,
                sensors,
                wheels: grp.wheels,
                controller: name,
                batch: factory.make_batch(),
                factory,
            });
        }
        let solver_factor = solver_factor(&groups, &objects);

        let mut world = World {
            physics,
            walls,
            objects,
            lights,
            goal_light: sc.goal_light(),
            groups,
            robots,
            target,
            time_s: 0.0,
            tick: 0,
            tick_s,
            tick_hz: f64::from(spec.run.tick_hz),
            substeps: 0,
            fixed_substeps: match spec.run.substeps {
                Substeps::Fixed(n) => Some(n),
                Substeps::Auto => None,
            },
            smallest_radius,
            solver_factor,
            seed,
            arena: (c, Vec2::new(w, h)),
            near: Vec::new(),
            beacons: Beacons::default(),
            shadows: Vec::new(),
            buffers: SenseBuffers::default(),
            scratch: Vec::new(),
            pool: None,
            timing: None,
            light_paths,
        };
        world.release();
        Ok(world)
    }

    /// One control tick: release robots that are due, act, physics sub-steps, sense, control.
    /// Robots start still: their controllers first run at the end of the first tick, once the
    /// physics has built its query tree.
    ///
    /// # Panics
    /// When a controller gave a robot a wheel speed that is NaN (a bug in the controller; the
    /// message names it, the robot and the time).
    pub fn step(&mut self) {
        self.step_with(|_| {});
    }

    /// [`World::step`], calling `each` after every physics step of the tick (to watch contacts
    /// between ticks).
    pub fn step_with(&mut self, mut each: impl FnMut(&World)) {
        let t0 = self.timing.map(|_| Instant::now());
        self.release();
        self.act();
        let n = self.plan_substeps();
        for _ in 0..n {
            self.physics_step();
            each(self);
        }
        self.tick += 1;
        self.time_s = self.tick as f64 / self.tick_hz;
        let t1 = t0.map(|_| Instant::now());
        self.move_lights();
        self.sense();
        let t2 = t0.map(|_| Instant::now());
        self.control();
        if let (Some(tm), Some(t0), Some(t1), Some(t2)) = (self.timing.as_mut(), t0, t1, t2) {
            tm.physics_s += (t1 - t0).as_secs_f64();
            tm.sense_s += (t2 - t1).as_secs_f64();
            tm.control_s += t2.elapsed().as_secs_f64();
        }
    }

    /// Starts (or restarts from zero) measuring the time spent in each part of the tick, in
    /// [`World::timing`].
    pub fn measure_time(&mut self) {
        self.timing = Some(StepTiming::default());
    }

    /// Senses and controls on `threads` threads: the caller's and `threads - 1` of a pool (1:
    /// on the caller's thread only), and solves the objects' floor friction on them. Results
    /// are bit-identical for any number: each robot's readings and decision depend only on the
    /// shared state and its own generators, each object's friction step only on that object;
    /// rapier's step stays on the caller's thread.
    pub fn set_threads(&mut self, threads: usize) -> Result<(), String> {
        if threads <= 1 {
            self.pool = None;
            return Ok(());
        }
        if self.threads() == threads {
            return Ok(());
        }
        // The calling thread is one of the `threads`.
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads - 1)
            .thread_name(|i| format!("formica-world-{i}"))
            .build()
            .map_err(|e| format!("cannot start {threads} threads: {e}"))?;
        self.pool = Some(Arc::new(pool));
        Ok(())
    }

    /// Threads sensing and control run on.
    pub fn threads(&self) -> usize {
        parallel::workers(self.pool.as_deref())
    }

    /// Chooses this tick's physics steps (fixed, or enough for the fastest body or wheel
    /// command; see [`Substeps::Auto`]) and sets the step up for them.
    fn plan_substeps(&mut self) -> u32 {
        let commanded = self
            .robots
            .iter()
            .filter(|r| r.body.is_some())
            .map(|r| {
                // A disc turning about its centre sweeps nothing: its centre's speed counts.
                let [l, rt] = r.wheels;
                (0.5 * (l + rt)).abs()
            })
            .fold(0.0, f32::max);
        let speed = commanded.max(self.physics.fastest_speed());
        let n = self.fixed_substeps.unwrap_or_else(|| {
            if self.smallest_radius > 0.0 {
                steps_for(speed, self.smallest_radius, self.tick_hz as f32)
            } else {
                1
            }
        });
        let dt = self.tick_s / n as f32;
        if n != self.substeps {
            self.substeps = n;
            self.physics.set_dt(dt);
            // About eight solver sub-steps per tick, at least two per physics step (four,
            // rapier's default, with one step per tick).
            self.physics.set_solver_iterations(
                (8u32.div_ceil(n).clamp(2, 4) * self.solver_factor) as usize,
            );
        }
        // Two bodies close in by up to twice the most one moves per step (no body outruns the
        // fastest body or command): contacts must be found before they touch.
        self.physics.set_contact_prediction(2.5 * speed * dt);
        n
    }

    /// One physics step: every released robot drives at its last commanded wheel speeds, then
    /// the bodies move.
    fn physics_step(&mut self) {
        for r in &self.robots {
            if let Some(body) = r.body {
                let model = &self.groups[r.group].model;
                self.physics.drive(
                    body,
                    model,
                    r.wheels[0],
                    r.wheels[1],
                    r.attached.is_some(),
                    r.action.coast,
                );
            }
        }
        self.physics.step_on(self.pool.as_deref());
    }

    /// Applies last tick's decisions: the wheel speeds each robot turns at this tick (its
    /// command, capped, with its wheel errors), LEDs and attach/detach.
    fn act(&mut self) {
        for i in 0..self.robots.len() {
            let Some(body) = self.robots[i].body else {
                continue;
            };
            let action = self.robots[i].action;
            let r = &mut self.robots[i];
            let grp = &self.groups[r.group];
            let top = grp.model.max_speed;
            // A controller's bug, said where it happens: a NaN wheel speed left the robot
            // standing for the rest of the run, as if it chose to. (An infinite one is capped
            // at the top speed, as every speed above it is.)
            assert!(
                !action.left.is_nan() && !action.right.is_nan(),
                "controller `{}` gave robot {i} the wheel speeds ({}, {}) at {:.1} s: wheel \
                 speeds must be numbers (m/s), not NaN",
                grp.controller,
                action.left,
                action.right,
                self.time_s
            );
            let mut wheels = [action.left, action.right];
            for (k, v) in wheels.iter_mut().enumerate() {
                *v = v.clamp(-top, top) * r.wheel_factor[k];
                if grp.wheels.noise > 0.0 && !action.coast {
                    *v *= 1.0 + grp.wheels.noise * crate::ops::standard_normal(&mut r.motor_rng);
                }
            }
            r.wheels = wheels;
            self.robots[i].led = action.led;
            match action.attach {
                AttachCommand::Keep => {}
                AttachCommand::Detach => {
                    if let Some((joint, _)) = self.robots[i].attached.take() {
                        self.physics.detach(joint);
                        self.robots[i].attached_at_s = None;
                    }
                }
                AttachCommand::Attach => {
                    if self.robots[i].attached.is_none() {
                        if let Some(obj) = self.touching_object(i, body) {
                            let joint = self.physics.attach(body, self.objects[obj].body);
                            self.robots[i].attached = Some((joint, obj));
                            self.robots[i].attached_at_s = Some(self.time_s as f32);
                        }
                    }
                }
            }
        }
    }

    /// The object robot `i` touches directly, or through a robot already attached to it.
    fn touching_object(&mut self, i: usize, body: BodyId) -> Option<usize> {
        let model = &self.groups[self.robots[i].group].model;
        let reach = 0.02;
        let center = self.physics.pose(body).position();
        self.physics
            .nearby(center, model.radius + reach + 0.05, &mut self.near);
        let mut best: Option<(f32, usize)> = None;
        for n in &self.near {
            let (other, obj) = match n.tag {
                Tag::Object(j) => (self.objects[j].body, j),
                Tag::Robot(k) if k != i => match (self.robots[k].body, self.robots[k].attached) {
                    (Some(b), Some((_, j))) => (b, j),
                    _ => continue,
                },
                _ => continue,
            };
            let d = self.physics.distance(body, other);
            if d <= reach && best.is_none_or(|(bd, _)| d < bd) {
                best = Some((d, obj));
            }
        }
        best.map(|(_, j)| j)
    }

    /// Adds robots whose release time has come, once their start spot is free.
    fn release(&mut self) {
        let now = self.time_s as f32 + 1e-6;

        for i in 0..self.robots.len() {
            let r = &self.robots[i];
            if r.body.is_some() || r.release_s > now {
                continue;
            }
            let model = &self.groups[r.group].model;
            let p = r.start.position();
            if self.time_s > 0.0 {
                // Another robot, or an object pushed over the spot since the start (its box in
                // the index may be a tick old: hence the wider query), keeps it waiting.
                self.physics.nearby(p, model.radius + 0.1, &mut self.near);
                let blocked = self.near.iter().any(|n| match n.tag {
                    Tag::Robot(k) => self.robots[k].body.is_some_and(|b| {
                        (self.physics.pose(b).position() - p).length() < 2.0 * model.radius + 0.005
                    }),
                    Tag::Object(_) => self.physics.disc_hits(n, p, model.radius + 0.005),
                    _ => false,
                });
                if blocked {
                    continue;
                }
            }
            let body = self.physics.add_robot(model, r.start, i);
            self.robots[i].body = Some(body);
            self.robots[i].state = "released";
        }
    }

    /// Puts moving lights where their schedule has them now.
    fn move_lights(&mut self) {
        let t = self.time_s as f32;
        for (i, spec) in &self.light_paths {
            let [x, y] = spec.position_at(t);
            if let Some(l) = self.lights.get_mut(*i) {
                l.position = Vec2::new(x, y);
            }
        }
    }

    /// Computes every released robot's readings (in parallel over robots with a thread pool;
    /// each robot reads only shared state and writes only its own readings and noise generator,
    /// with its worker's scratch space, cleared before use, so the result does not depend on
    /// the number of threads).
    fn sense(&mut self) {
        self.physics.rebuild_index();
        // With many walls and objects, each light's occlusion test asks only those in the
        // robot's direction (the same exact test: results do not change).
        let fixtures = self.physics.fixtures().len();
        if fixtures >= SHADOWS_MIN_FIXTURES {
            self.shadows
                .resize_with(self.lights.len(), Shadows::default);
            let physics = &self.physics;
            for (sh, l) in self.shadows.iter_mut().zip(&self.lights) {
                sh.build(l.position, (0..fixtures).map(|i| physics.fixture_box(i)));
            }
        } else {
            self.shadows.clear();
        }
        let physics = &self.physics;
        self.beacons.set(
            beacon_objects(&self.objects, self.target)
                .map(|i| physics.center_of_mass(self.objects[i].body)),
        );
        let objects = &self.objects;
        let walls = &self.walls;
        let robots = &mut self.robots;
        let groups = &self.groups;
        let buf = &mut self.buffers;
        buf.heights.clear();
        buf.discs.clear();
        buf.leds.clear();
        for r in robots.iter() {
            let model = &groups[r.group].model;
            let c = r
                .body
                .map_or(r.start.position(), |b| physics.pose(b).position());
            buf.heights.push(model.height);
            buf.discs.push((c, model.radius));
            buf.leds.push(r.led);
        }
        let (heights, leds) = (&buf.heights, &buf.leds);
        let height = |t: Tag| match t {
            Tag::Wall(i) => walls[i].height,
            Tag::Object(i) => objects[i].height,
            Tag::Robot(i) => heights[i],
        };
        let color = |t: Tag| match t {
            Tag::Wall(_) => Color::Grey,
            Tag::Object(i) => objects[i].color,
            Tag::Robot(i) => leds[i],
        };
        let ctx = SenseContext {
            physics,
            lights: &self.lights,
            height: &height,
            color: &color,
            robots: &buf.discs,
            beacons: &self.beacons,
            robot_height: groups.iter().map(|g| g.model.height).fold(0.0, f32::max),
            shadows: &self.shadows,
        };
        let specs: Vec<(&RobotModel, SensorNeeds, &SensorConfig)> = groups
            .iter()
            .map(|g| (&g.model, g.factory.needs, &g.sensors))
            .collect();
        let time = self.time_s as f32;
        self.scratch
            .resize_with(parallel::workers(self.pool.as_deref()), Scratch::default);
        parallel::for_each_with(
            self.pool.as_deref(),
            robots,
            ROBOTS_PER_CHUNK,
            &mut self.scratch,
            |i, r, scratch| {
                let Some(body) = r.body else { return };
                let (model, needs, cfg) = specs[r.group];
                let pose = physics.pose(body);
                r.readings.time_s = time;
                r.readings.attached = r.attached.is_some();
                sense(
                    &ctx,
                    model,
                    needs,
                    cfg,
                    Tag::Robot(i),
                    pose,
                    scratch,
                    &mut r.sense_rng,
                    &mut r.readings,
                );
            },
        );
    }

    /// Runs every released robot's controller, then each group's batch controller.
    fn control(&mut self) {
        let groups = &mut self.groups;
        let batched: Vec<bool> = groups.iter().map(|g| g.batch.is_some()).collect();
        parallel::for_each(
            self.pool.as_deref(),
            &mut self.robots,
            ROBOTS_PER_CHUNK,
            |_, r| {
                if r.body.is_none() || batched[r.group] {
                    return;
                }
                r.action = r.controller.step(&r.readings, &mut r.rng);
                r.state = r.controller.state();
            },
        );
        for (g, group) in groups.iter_mut().enumerate() {
            let Some(batch) = group.batch.as_mut() else {
                continue;
            };
            let mut members: Vec<BatchRobot<'_>> = self
                .robots
                .iter_mut()
                .enumerate()
                .filter(|(_, r)| r.group == g && r.body.is_some())
                .map(|(index, r)| BatchRobot {
                    index,
                    readings: &r.readings,
                    rng: &mut r.rng,
                    action: r.action,
                    state: r.state,
                })
                .collect();
            batch.step(&mut members);
            let decided: Vec<(usize, Actuation, &'static str)> = members
                .iter()
                .map(|m| (m.index, m.action, m.state))
                .collect();
            drop(members);
            for (i, action, state) in decided {
                self.robots[i].action = action;
                self.robots[i].state = state;
            }
        }
    }

    /// Pose of robot `i` (its start pose if not yet released).
    pub fn robot_pose(&self, i: usize) -> Pose {
        self.robots[i]
            .body
            .map_or(self.robots[i].start, |b| self.physics.pose(b))
    }

    /// Model of robot `i`.
    pub fn robot_model(&self, i: usize) -> &RobotModel {
        &self.groups[self.robots[i].group].model
    }

    /// Radius of object `i` (m): the farthest point of its outline from its centre of mass.
    pub fn object_radius(&self, i: usize) -> f32 {
        self.objects[i].radius(&self.physics)
    }

    /// Pose of object `i`'s body.
    pub fn object_pose(&self, i: usize) -> Pose {
        self.physics.pose(self.objects[i].body)
    }

    /// Outlines of object `i`'s parts in the world frame (discs as 24-gons).
    pub fn object_outlines(&self, i: usize) -> Vec<Vec<Vec2>> {
        let pose = self.object_pose(i);
        let mut outlines = self.objects[i].outlines();
        for p in outlines.iter_mut().flatten() {
            *p = pose.world_from_local(*p);
        }
        outlines
    }

    /// Centre of mass of object `i`.
    pub fn object_center(&self, i: usize) -> Vec2 {
        self.physics.center_of_mass(self.objects[i].body)
    }

    /// Floor point of the goal light.
    pub fn goal(&self) -> Option<Vec2> {
        self.goal_light.map(|g| self.lights[g].position)
    }

    /// Number of robots released so far.
    pub fn released(&self) -> usize {
        self.robots.iter().filter(|r| r.body.is_some()).count()
    }
}

/// Checks that object `i` (its collision shape at `pose`) starts inside the arena (centre
/// `arena_c`, size `arena`) and overlaps no wall.
fn object_fits(
    sc: &Scenario,
    i: usize,
    shape: &rapier2d::parry::shape::SharedShape,
    pose: Pose,
    physics: &Physics,
    arena_c: Vec2,
    arena: Vec2,
) -> Result<(), ScenarioError> {
    let o = &sc.spec.objects[i];
    let name = o
        .get_ref()
        .name
        .as_ref()
        .map_or(String::new(), |n| format!(" (\"{n}\")"));
    let iso = rapier2d::math::Pose::new(pose.position(), pose.theta);
    let bb = shape.compute_aabb(&iso);
    let (lo, hi) = (arena_c - arena / 2.0, arena_c + arena / 2.0);
    if !(bb.mins.x >= lo.x && bb.mins.y >= lo.y && bb.maxs.x <= hi.x && bb.maxs.y <= hi.y) {
        return Err(sc.error_at(
            o.span(),
            format!(
                "objects[{i}]{name}: reaches outside the arena: it spans ({:.3}, {:.3}) to \
                 ({:.3}, {:.3}), the arena ({:.3}, {:.3}) to ({:.3}, {:.3})",
                bb.mins.x, bb.mins.y, bb.maxs.x, bb.maxs.y, lo.x, lo.y, hi.x, hi.y
            ),
        ));
    }
    if let Some(Tag::Wall(j)) = physics.shape_overlaps(shape, iso) {
        let wall = match j.checked_sub(4) {
            Some(k) => format!("walls[{k}]"),
            None => "an arena wall".into(),
        };
        return Err(sc.error_at(
            o.span(),
            format!("objects[{i}]{name}: starts inside {wall}"),
        ));
    }
    // Objects that start overlapping are thrown apart by the contact solver before any robot
    // moves; touching is allowed.
    if let Some(j) = physics.object_overlaps(shape, iso, 0.001) {
        return Err(sc.error_at(
            o.span(),
            format!(
                "objects[{i}]{name}: starts overlapping objects[{j}]; move one of them (objects \
                 may touch)"
            ),
        ));
    }
    Ok(())
}

/// Robots placed so far, hashed on a grid of cells one largest robot diameter wide: checking a
/// new spot against them costs the same whatever their number.
struct Placed {
    cell: f32,
    cells: std::collections::HashMap<(i32, i32), Vec<(Vec2, f32)>>,
}

impl Placed {
    fn new(largest_radius: f32) -> Self {
        Self {
            cell: (2.0 * largest_radius).max(1e-3),
            cells: std::collections::HashMap::new(),
        }
    }

    fn key(&self, p: Vec2) -> (i32, i32) {
        // Saturating casts: positions are bounded by the scenario limits anyway.
        (
            (p.x / self.cell).floor() as i32,
            (p.y / self.cell).floor() as i32,
        )
    }

    /// Whether a disc at `p` of radius `r` (at most the largest) overlaps a placed one.
    fn overlaps(&self, p: Vec2, r: f32) -> bool {
        let (kx, ky) = self.key(p);
        (-1..=1).any(|dy| {
            (-1..=1).any(|dx| {
                self.cells
                    .get(&(kx.saturating_add(dx), ky.saturating_add(dy)))
                    .is_some_and(|v| v.iter().any(|(q, rq)| (*q - p).length() < r + rq))
            })
        })
    }

    fn push(&mut self, p: Vec2, r: f32) {
        self.cells.entry(self.key(p)).or_default().push((p, r));
    }
}

/// Start poses for group `g`, checked against walls, objects, the arena and each other.
#[expect(
    clippy::too_many_arguments,
    reason = "one call site, inside World::new"
)]
fn place_group(
    sc: &Scenario,
    g: usize,
    count: usize,
    model: &RobotModel,
    physics: &Physics,
    rng: &mut RobotRng,
    placed: &mut Placed,
    arena_c: Vec2,
    arena: Vec2,
) -> Result<Vec<Pose>, ScenarioError> {
    let grp = sc.spec.robots[g].get_ref();
    let span = grp.placement.span();
    let r = model.radius;
    let inside = |p: Vec2| {
        let d = p - arena_c;
        d.x.abs() < arena.x / 2.0 - r && d.y.abs() < arena.y / 2.0 - r
    };
    let free = |p: Vec2, placed: &Placed| -> Result<(), String> {
        if let Some(tag) = physics.disc_overlaps(p, r) {
            return Err(match tag {
                Tag::Wall(_) => "is inside a wall".into(),
                Tag::Object(j) => format!("overlaps objects[{j}]"),
                Tag::Robot(_) => "overlaps a robot".into(),
            });
        }
        if !inside(p) {
            return Err("is outside the arena".into());
        }
        if placed.overlaps(p, r) {
            return Err("overlaps another robot".into());
        }
        Ok(())
    };
    // `count` is bounded by the scenario limits.
    let mut out = Vec::with_capacity(count);
    match grp.placement.get_ref() {
        Placement::Random {
            min,
            max,
            heading_deg,
        } => {
            for k in 0..count {
                let mut ok = None;
                for _ in 0..10_000 {
                    let p = Vec2::new(
                        rng.random_range(min[0]..max[0]),
                        rng.random_range(min[1]..max[1]),
                    );
                    if free(p, placed).is_ok() {
                        ok = Some(p);
                        break;
                    }
                }
                let Some(p) = ok else {
                    return Err(sc.error_at(
                        span.clone(),
                        format!("robots[{g}]: no free spot for robot {} of {count} in the random region after 10000 tries; enlarge the region or place fewer robots", k + 1),
                    ));
                };
                let theta = match heading_deg {
                    Some(d) => d.to_radians(),
                    None => rng.random_range(-std::f32::consts::PI..std::f32::consts::PI),
                };
                placed.push(p, r);
                out.push(Pose::new(p.x, p.y, theta));
            }
        }
        Placement::Grid {
            center,
            spacing,
            columns,
            heading_deg,
        } => {
            let cols = columns
                .unwrap_or_else(|| (count as f32).sqrt().ceil() as usize)
                .max(1);
            let rows = count.div_ceil(cols);
            for k in 0..count {
                let (cx, ry) = (k % cols, k / cols);
                let p = Vec2::new(
                    center[0] + (cx as f32 - (cols as f32 - 1.0) / 2.0) * spacing,
                    center[1] + (ry as f32 - (rows as f32 - 1.0) / 2.0) * spacing,
                );
                free(p, placed).map_err(|m| {
                    sc.error_at(
                        span.clone(),
                        format!(
                            "robots[{g}]: robot {} of {count} on the grid, at ({:.3}, {:.3}), {m}",
                            k + 1,
                            p.x,
                            p.y
                        ),
                    )
                })?;
                placed.push(p, r);
                out.push(Pose::new(p.x, p.y, heading_deg.to_radians()));
            }
        }
        Placement::Poses(poses) => {
            for (k, q) in poses.iter().enumerate() {
                let p = Vec2::new(q[0], q[1]);
                free(p, placed).map_err(|m| {
                    sc.error_at(
                        span.clone(),
                        format!("robots[{g}]: poses[{k}] at ({}, {}) {m}", q[0], q[1]),
                    )
                })?;
                placed.push(p, r);
                out.push(Pose::new(p.x, p.y, q[2].to_radians()));
            }
        }
    }
    Ok(out)
}
