//! Rigid-body physics: the only module that talks to rapier2d.
//!
//! Top-down 2D, no gravity. Two kinds of floor contact are modelled, both as a joint to a static
//! ground body whose velocity motors rapier solves together with the contacts, so that friction
//! holds a body still against whatever pushes it (stiction) instead of being added afterwards:
//!
//! - **Floor friction** of movable objects: Coulomb friction under uniform pressure over the
//!   object's actual footprint, sampled at about a hundred points when it is created (see
//!   `physics/friction.rs`). This is the exact limit surface of the footprint, not the ellipsoid of
//!   quasi-static pushing (Goyal, Ruina & Papadopoulos 1991; Lynch & Mason 1996), which has the
//!   right `f_max = mu m g` and `tau_max = mu m g mean|r - c|` but the wrong curvature near pure
//!   translation: with it a 0.5 m box pushed 5 cm off centre turned 35 % too slowly. A sliding
//!   object is resisted with `mu m g` opposite its velocity when it only translates, and with
//!   less force and a torque as it turns.
//! - **Traction** of a robot's wheels: the body is pulled toward the commanded velocity (forward,
//!   no sideways slip, turn rate) with at most the model's drive force in any direction (one
//!   friction circle shared by forward and sideways) and at most its drive torque.
//!
//! rapier caps each motor axis on its own, which alone gives a box-shaped limit. So before every
//! step each joint is set from one implicit Coulomb step against the true limit set: from the
//! wrench everything else applied to the body in the last step (its change of momentum minus the
//! joint's impulse), predict its twist at the end of this step without the joint. If the wrench
//! that brings it to its target (rest, or the commanded velocity) lies inside the limit set, the
//! body sticks: the caps are a box around that wrench reaching the limit set along each axis (for
//! an object, the ellipsoid through the limit set's largest force and torque), so the solver
//! holds it. Otherwise it slips with the maximally dissipative wrench (for objects the
//! minimiser of a convex problem in the three twist components, solved by Newton's method; for
//! wheels the drive force along the slip): the joint frame is turned to the slip and the caps
//! set to the wrench's components. The approximation is the one-step lag of the other bodies'
//! wrench: a steady push is resolved exactly, a changing one a step late, and a quasi-static push
//! against stiff friction (friction that would stop the object in far less than a step) turns it
//! too slowly by an amount that grows with the step (a few per cent at 25 ms, 15-30 % at
//! 100 ms). The motors only ever resist motion, so friction never accelerates a body.
//!
//! Robots touching nothing skip the joint: they get the same capped velocity change directly,
//! which is what the joint would do without contacts and costs far less. Robots attached to an
//! object keep their wheels on the floor through the joint (locked wheels): commanding zero wheel
//! speed, they brake with up to their drive force in any direction and the torque of that force
//! at the wheels ([`RobotModel::brake_torque`]), which is part of the pseudo object's resistance.
//!
//! Contacts: rapier's contact recycling (which keeps contact points for up to 5 cm of motion and
//! made robots snag on corners they passed 1 cm away) is off; "touching" means a contact within
//! [`TOUCH`], since rapier also makes contacts for bodies that are still apart (how far ahead is
//! [`Physics::set_contact_prediction`]). With the world's automatic sub-steps no body moves more
//! than a third of the smallest robot radius per step, so robots do not pass through each other;
//! rapier's continuous collision detection keeps fast bodies out of walls.

mod friction;

use crate::geometry::{Pose, Vec2};
use crate::parallel;
use crate::robot::RobotModel;
use friction::{hold_box, Footprint, Twist};
use rapier2d::math::Rotation;
use rapier2d::parry;
use rapier2d::parry::query::DefaultQueryDispatcher;
use rapier2d::prelude::*;

/// Standard gravity, for floor friction (m/s^2).
pub const GRAVITY: f32 = 9.81;
/// Contact friction coefficients (combined by product, as ARGoS does).
pub const ROBOT_FRICTION: f32 = 0.7;
/// Contact friction of objects.
pub const OBJECT_FRICTION: f32 = 0.7;
/// Contact friction of walls.
pub const WALL_FRICTION: f32 = 0.1;

/// Damping of the floor velocity motors: large, so that below the caps the body reaches the
/// motor's target within the step (a stiff velocity constraint), and above them slips.
const MOTOR_DAMPING: f32 = 1.0e9;

/// Two surfaces closer than this touch (m): rapier's contacts also cover bodies still apart.
pub const TOUCH: f32 = 0.001;

/// Solver sub-steps rapier runs inside each physics step by default.
const DEFAULT_SOLVER_ITERATIONS: usize = 4;

/// What a collider belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Tag {
    /// An arena wall or a static obstacle (index into the world's walls).
    Wall(usize),
    /// An object (index into the world's objects).
    Object(usize),
    /// A robot (index into the world's robots).
    Robot(usize),
}

impl Tag {
    fn encode(self) -> u128 {
        match self {
            Tag::Wall(i) => (1u128 << 64) | i as u128,
            Tag::Object(i) => (2u128 << 64) | i as u128,
            Tag::Robot(i) => (3u128 << 64) | i as u128,
        }
    }
    fn decode(v: u128) -> Tag {
        let i = (v & u64::MAX as u128) as usize;
        match v >> 64 {
            1 => Tag::Wall(i),
            2 => Tag::Object(i),
            _ => Tag::Robot(i),
        }
    }
}

/// A handle to one body in the physics world.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BodyId {
    body: RigidBodyHandle,
    collider: ColliderHandle,
    /// Index into [`Physics::drives`] (robots only).
    drive: Option<u32>,
}

/// A collider near a query point, for cheap local ray casts.
#[derive(Debug, Clone, Copy)]
pub struct Nearby {
    /// What it belongs to.
    pub tag: Tag,
    collider: ColliderHandle,
    /// Where it was at the last index rebuild, to skip ray casts that surely miss.
    bound: Bound,
}

/// What a [`Nearby`] knows of its collider's place at the last index rebuild.
#[derive(Debug, Clone, Copy)]
enum Bound {
    /// Nothing.
    Unknown,
    /// A robot: centre and radius.
    Disc(Vec2, f32),
    /// A wall or object: its bounding box.
    Box(Vec2, Vec2),
}

/// A fixed joint holding a robot to a body.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct AttachId(ImpulseJointHandle);

/// A joint to the ground standing for a body's contact with the floor, and what the next step
/// needs to know of the last one.
#[derive(Debug, Clone, Copy)]
struct FloorJoint {
    body: RigidBodyHandle,
    joint: ImpulseJointHandle,
    mass: f32,
    inertia: f32,
    /// The body's twist when the last step started (after any direct velocity change).
    pre: Twist,
    /// Unit x axis of the joint frame during the last step (world frame).
    axis: Vec2,
    /// Whether the joint was enabled during the last step.
    active: bool,
}

/// One object's friction step for the next physics step: its inputs, then its result.
struct FrictionJob {
    /// The body's rotation (cos, sin).
    rot: (f32, f32),
    /// Its twist now.
    now: Twist,
    /// Its twist at the end of the step without friction.
    free: Twist,
    /// Its result: `None` until the job is solved, which every job is before it is read.
    step: Option<friction::Step>,
}

/// Objects handed to a thread at a time when their friction steps run on several threads.
const OBJECTS_PER_CHUNK: usize = 2;

/// Floor friction of one movable object.
#[derive(Debug, Clone)]
struct Friction {
    joint: FloorJoint,
    footprint: Footprint,
    /// Twist at the end of the last step, as the friction step predicted it.
    end: Twist,
}

/// The physics world.
pub struct Physics {
    world: PhysicsWorld,
    ground: RigidBodyHandle,
    /// Floor friction of movable objects.
    friction: Vec<Friction>,
    /// Wheel joints of robots, indexed by [`BodyId::drive`].
    drives: Vec<FloorJoint>,
    /// Every wall and object collider: the few bodies that can hide a light far away.
    fixtures: Vec<Nearby>,
    /// Robot colliders, in insertion order, with their radii.
    robots: Vec<(Nearby, f32)>,
    /// Neighbour index for sensor queries, rebuilt once per tick.
    index: NeighbourIndex,
    /// Length of the last step and rapier's solver sub-steps in it, to read its impulses.
    last_step: (f32, usize),
}

/// A uniform grid of robot positions plus the bounding boxes of walls and objects: answers
/// "what is near this point" in constant time per robot, which a tree query cannot match when
/// every robot asks every tick.
#[derive(Default)]
struct NeighbourIndex {
    cell: f32,
    min: Vec2,
    nx: usize,
    ny: usize,
    /// `starts[c]..starts[c + 1]` are the entries of cell `c` in `items`.
    starts: Vec<u32>,
    /// (position, slot in `Physics::robots`).
    items: Vec<(Vec2, u32)>,
    fixture_boxes: Vec<Aabb>,
    /// Walls and objects by coarse cell, so that a query looks at the few near it.
    fixture_grid: FixtureGrid,
    max_radius: f32,
    /// Whether no body has moved since the last rebuild (the bounds in [`Nearby`] hold).
    fresh: bool,
    /// The area the grid covers (the arena and its walls); robots outside it fall in its
    /// border cells.
    area: Option<(Vec2, Vec2)>,
}

/// A coarse grid of wall and object bounding boxes: each cell lists (in fixture order) the
/// fixtures whose box overlaps it; boxes over many cells (walls) are in `big`, asked always.
#[derive(Default)]
struct FixtureGrid {
    cell: f32,
    min: Vec2,
    nx: usize,
    ny: usize,
    starts: Vec<u32>,
    items: Vec<u32>,
    big: Vec<u32>,
    /// Scratch of the last build: each small fixture's cell range.
    spans: Vec<[usize; 4]>,
}

/// Fewer fixtures than this are scanned in full (no grid).
const FIXTURE_GRID_MIN: usize = 9;

/// A fixture box over more cells than this is asked by every query.
const FIXTURE_BIG_CELLS: usize = 16;

impl FixtureGrid {
    fn clear(&mut self) {
        self.nx = 0;
        self.ny = 0;
        self.starts.clear();
        self.items.clear();
        self.big.clear();
    }

    fn build(&mut self, boxes: &[Aabb], area: Option<(Vec2, Vec2)>) {
        self.clear();
        if boxes.len() < FIXTURE_GRID_MIN {
            return;
        }
        let (mut lo, mut hi) = (Vec2::splat(f32::MAX), Vec2::splat(f32::MIN));
        for b in boxes {
            lo = lo.min(b.mins);
            hi = hi.max(b.maxs);
        }
        if let Some(a) = area {
            (lo, hi) = a;
        }
        let span = (hi - lo).max(Vec2::splat(1e-3));
        let cell = (span.x * span.y / boxes.len() as f32)
            .sqrt()
            .max(1.0)
            .max(span.x.max(span.y) / 1024.0);
        if !cell.is_finite() {
            return;
        }
        self.cell = cell;
        self.min = lo;
        self.nx = ((span.x / cell) as usize).min(1024) + 1;
        self.ny = ((span.y / cell) as usize).min(1024) + 1;
        let cells = self.nx * self.ny;
        self.starts.resize(cells + 1, 0);
        self.spans.clear();
        for (i, b) in boxes.iter().enumerate() {
            let [x0, y0] = self.cell_xy(b.mins);
            let [x1, y1] = self.cell_xy(b.maxs);
            let s = [x0, y0, x1, y1];
            if (x1 - x0 + 1) * (y1 - y0 + 1) > FIXTURE_BIG_CELLS {
                self.big.push(i as u32);
                self.spans.push([1, 1, 0, 0]);
                continue;
            }
            for y in y0..=y1 {
                for x in x0..=x1 {
                    self.starts[y * self.nx + x + 1] += 1;
                }
            }
            self.spans.push(s);
        }
        for c in 0..cells {
            self.starts[c + 1] += self.starts[c];
        }
        let mut fill = self.starts.clone();
        self.items.resize(self.starts[cells] as usize, 0);
        for (i, &[x0, y0, x1, y1]) in self.spans.iter().enumerate() {
            // (Big fixtures have an empty range.)
            for y in y0..=y1 {
                for x in x0..=x1 {
                    let c = y * self.nx + x;
                    self.items[fill[c] as usize] = i as u32;
                    fill[c] += 1;
                }
            }
        }
    }

    /// Cell column and row of a point (points outside fall in the border cells).
    fn cell_xy(&self, p: Vec2) -> [usize; 2] {
        let d = (p - self.min) / self.cell;
        [
            (d.x.max(0.0) as usize).min(self.nx - 1),
            (d.y.max(0.0) as usize).min(self.ny - 1),
        ]
    }
}

/// Most cells of the neighbour grid, whatever the arena.
const MAX_CELLS: usize = 1 << 22;

/// Side of a neighbour-index cell (m): about 1.6 times a Khepera IV's proximity reach (0.19 m
/// from its centre).
const CELL_M: f32 = 0.3;

/// How one axis of a floor joint acts during a step.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Motor {
    /// Target velocity along the axis.
    target: f32,
    /// Damping (force per unit of velocity error) for a linearised friction, or `None` for a
    /// stiff motor that reaches the target if it can.
    damping: Option<f32>,
    /// Largest force (torque) it applies.
    cap: f32,
}

impl Motor {
    /// A stiff motor: reaches `target` with at most `cap`.
    fn hold(target: f32, cap: f32) -> Motor {
        Motor {
            target,
            damping: None,
            cap,
        }
    }

    fn apply(self, joint: &mut GenericJoint, axis: JointAxis) {
        match self.damping {
            Some(d) => joint
                .set_motor_model(axis, MotorModel::ForceBased)
                .set_motor_velocity(axis, self.target, d),
            None => joint
                .set_motor_model(axis, MotorModel::AccelerationBased)
                .set_motor_velocity(axis, self.target, MOTOR_DAMPING),
        }
        .set_motor_max_force(axis, self.cap);
    }
}

/// Whether the ray from `origin` along the unit vector `dir`, `max_dist` long, may meet a
/// collider that was at `bound`: false only when it surely misses (by more than 1 mm, far
/// above rounding), so that the exact ray cast can be skipped.
#[inline]
fn may_meet(bound: Bound, origin: Vec2, dir: Vec2, max_dist: f32) -> bool {
    const PAD: f32 = 1e-3;
    match bound {
        Bound::Unknown => true,
        Bound::Disc(c, r) => {
            let rel = c - origin;
            let along = rel.dot(dir);
            let reach = r + PAD;
            if along < -reach || along > max_dist + reach {
                return false;
            }
            let t = along.clamp(0.0, max_dist.max(0.0));
            let d = rel - dir * t;
            d.dot(d) <= reach * reach
        }
        Bound::Box(lo, hi) => {
            let (lo, hi) = (lo - Vec2::splat(PAD), hi + Vec2::splat(PAD));
            let (mut t0, mut t1) = (0.0f32, max_dist + PAD);
            for (o, d, l, h) in [(origin.x, dir.x, lo.x, hi.x), (origin.y, dir.y, lo.y, hi.y)] {
                if d.abs() < 1e-9 {
                    if o < l || o > h {
                        return false;
                    }
                } else {
                    let (a, b) = ((l - o) / d, (h - o) / d);
                    t0 = t0.max(a.min(b));
                    t1 = t1.min(a.max(b));
                    if t0 > t1 + PAD {
                        return false;
                    }
                }
            }
            true
        }
    }
}

/// The vector `v` turned by +90 degrees.
fn perp(v: Vec2) -> Vec2 {
    Vec2::new(-v.y, v.x)
}

/// `v / |v|`, or `fallback` when `v` is (nearly) zero.
fn direction_or(v: Vec2, fallback: Vec2) -> Vec2 {
    let l = v.length();
    if l > 1e-12 {
        v / l
    } else {
        fallback
    }
}

/// rapier's contact queries, with each pair's list of contact manifolds trimmed to what it
/// holds. A new pair's first manifold grows the list to room for four (Rust's smallest growth),
/// and most pairs (disc against disc or polygon) only ever hold one: about 1 KiB per pair, a
/// third of a robot's memory in a crowd. Contacts are exactly rapier's.
struct TrimmedManifolds;

impl parry::query::QueryDispatcher for TrimmedManifolds {
    fn intersection_test(
        &self,
        pos12: &parry::math::Pose,
        g1: &dyn parry::shape::Shape,
        g2: &dyn parry::shape::Shape,
    ) -> Result<parry::query::ShapeIntersection, parry::query::Unsupported> {
        DefaultQueryDispatcher.intersection_test(pos12, g1, g2)
    }
    fn distance(
        &self,
        pos12: &parry::math::Pose,
        g1: &dyn parry::shape::Shape,
        g2: &dyn parry::shape::Shape,
    ) -> Result<parry::query::ShapeDistance, parry::query::Unsupported> {
        DefaultQueryDispatcher.distance(pos12, g1, g2)
    }
    fn contact(
        &self,
        pos12: &parry::math::Pose,
        g1: &dyn parry::shape::Shape,
        g2: &dyn parry::shape::Shape,
        prediction: f32,
    ) -> Result<Option<parry::query::Contact>, parry::query::Unsupported> {
        DefaultQueryDispatcher.contact(pos12, g1, g2, prediction)
    }
    fn closest_points(
        &self,
        pos12: &parry::math::Pose,
        g1: &dyn parry::shape::Shape,
        g2: &dyn parry::shape::Shape,
        max_dist: f32,
    ) -> Result<parry::query::ClosestPoints, parry::query::Unsupported> {
        DefaultQueryDispatcher.closest_points(pos12, g1, g2, max_dist)
    }
    fn cast_shapes(
        &self,
        pos12: &parry::math::Pose,
        local_vel12: parry::math::Vector,
        g1: &dyn parry::shape::Shape,
        g2: &dyn parry::shape::Shape,
        options: parry::query::ShapeCastOptions,
    ) -> Result<Option<parry::query::ShapeCastHit>, parry::query::Unsupported> {
        DefaultQueryDispatcher.cast_shapes(pos12, local_vel12, g1, g2, options)
    }
    fn cast_shapes_nonlinear(
        &self,
        motion1: &parry::query::NonlinearRigidMotion,
        g1: &dyn parry::shape::Shape,
        motion2: &parry::query::NonlinearRigidMotion,
        g2: &dyn parry::shape::Shape,
        start_time: f32,
        end_time: f32,
        stop_at_penetration: bool,
    ) -> Result<Option<parry::query::ShapeCastHit>, parry::query::Unsupported> {
        DefaultQueryDispatcher.cast_shapes_nonlinear(
            motion1,
            g1,
            motion2,
            g2,
            start_time,
            end_time,
            stop_at_penetration,
        )
    }
}

impl parry::query::PersistentQueryDispatcher<ContactManifoldData, ContactData>
    for TrimmedManifolds
{
    fn contact_manifolds(
        &self,
        pos12: &parry::math::Pose,
        g1: &dyn parry::shape::Shape,
        g2: &dyn parry::shape::Shape,
        prediction: f32,
        manifolds: &mut Vec<ContactManifold>,
        workspace: &mut Option<parry::query::ContactManifoldsWorkspace>,
    ) -> Result<(), parry::query::Unsupported> {
        let r = DefaultQueryDispatcher
            .contact_manifolds(pos12, g1, g2, prediction, manifolds, workspace);
        if manifolds.capacity() > manifolds.len().max(1) {
            manifolds.shrink_to(manifolds.len().max(1));
        }
        r
    }
    fn contact_manifold_convex_convex(
        &self,
        pos12: &parry::math::Pose,
        g1: &dyn parry::shape::Shape,
        g2: &dyn parry::shape::Shape,
        normal_constraints1: Option<&dyn parry::query::details::NormalConstraints>,
        normal_constraints2: Option<&dyn parry::query::details::NormalConstraints>,
        prediction: f32,
        manifold: &mut ContactManifold,
    ) -> Result<(), parry::query::Unsupported> {
        DefaultQueryDispatcher.contact_manifold_convex_convex(
            pos12,
            g1,
            g2,
            normal_constraints1,
            normal_constraints2,
            prediction,
            manifold,
        )
    }
}

/// A joint of a body to the ground with velocity motors along x, y and about the vertical,
/// unpowered (no force) until a step sets their targets and force limits: an object's floor
/// friction, a robot's wheels.
fn ground_motors(joint: GenericJointBuilder) -> GenericJoint {
    joint
        .contacts_enabled(false)
        .motor_velocity(JointAxis::LinX, 0.0, MOTOR_DAMPING)
        .motor_velocity(JointAxis::LinY, 0.0, MOTOR_DAMPING)
        .motor_velocity(JointAxis::AngX, 0.0, MOTOR_DAMPING)
        .motor_max_force(JointAxis::LinX, 0.0)
        .motor_max_force(JointAxis::LinY, 0.0)
        .motor_max_force(JointAxis::AngX, 0.0)
        .build()
}

/// A joint frame at `origin` whose x axis is the unit vector `axis`.
fn frame(origin: Vec2, axis: Vec2) -> rapier2d::math::Pose {
    rapier2d::math::Pose::from_parts(origin, Rotation::from_cos_sin_unchecked(axis.x, axis.y))
}

impl Physics {
    /// An empty world stepping `dt` seconds per call to [`Physics::step`].
    pub fn new(dt: f32) -> Self {
        Self::with_capacity(dt, 0)
    }

    /// As [`Physics::new`], with room for `bodies` bodies and as many colliders made at once
    /// (a growing set would double its room, and hold up to twice what it needs).
    pub fn with_capacity(dt: f32, bodies: usize) -> Self {
        let mut world = PhysicsWorld::new();
        world.bodies = RigidBodySet::with_capacity(bodies + 1);
        world.colliders = ColliderSet::with_capacity(bodies);
        world.gravity = Vec2::ZERO;
        world.integration_parameters.dt = dt;
        world.integration_parameters.num_solver_iterations = DEFAULT_SOLVER_ITERATIONS;
        // Recycled contact pairs keep stale contact points for up to 5 cm of relative motion:
        // a robot passing a corner would be pushed off (or stopped) by a contact that is no
        // longer there (issue 10's ghost contacts). Recompute contacts every step.
        world.integration_parameters.contact_recycling = false;
        world.narrow_phase = NarrowPhase::with_query_dispatcher(TrimmedManifolds);
        let ground = world.bodies.insert(RigidBodyBuilder::fixed());
        Self {
            world,
            ground,
            friction: Vec::new(),
            drives: Vec::new(),
            fixtures: Vec::new(),
            robots: Vec::new(),
            index: NeighbourIndex::default(),
            last_step: (dt, DEFAULT_SOLVER_ITERATIONS),
        }
    }

    /// Sets how many solver sub-steps rapier runs inside each physics step (default 4). With
    /// several physics steps per tick, fewer are needed for the same solver work per tick.
    pub fn set_solver_iterations(&mut self, n: usize) {
        self.world.integration_parameters.num_solver_iterations = n.max(1);
    }

    /// Sets the length of the following steps (s).
    pub fn set_dt(&mut self, dt: f32) {
        self.world.integration_parameters.dt = dt;
    }

    /// The fastest any body's outline moves now (m/s): a robot's centre (a disc turning about
    /// its centre sweeps nothing), an object's centre plus its turning at its farthest point.
    pub fn fastest_speed(&self) -> f32 {
        let rim = |fj: &FloorJoint, reach: f32| {
            let b = &self.world.bodies[fj.body];
            b.linvel().length() + b.angvel().abs() * reach
        };
        let robots = self.drives.iter().map(|fj| rim(fj, 0.0));
        let objects = self
            .friction
            .iter()
            .map(|f| rim(&f.joint, f.footprint.reach()));
        robots.chain(objects).fold(0.0, f32::max)
    }

    /// Sets how far apart two colliders get a (speculative) contact, which must exceed how much
    /// closer two bodies can come in one step for contacts to hold at speed (default 2 cm).
    pub fn set_contact_prediction(&mut self, distance: f32) {
        let p = &mut self.world.integration_parameters;
        p.normalized_prediction_distance = distance.max(0.02) / p.length_unit;
    }

    /// Seconds per step.
    pub fn dt(&self) -> f32 {
        self.world.integration_parameters.dt
    }

    /// Adds a static wall: a box of `size` centred at `center`, rotated by `yaw`.
    pub fn add_wall(&mut self, center: Vec2, size: Vec2, yaw: f32, index: usize) -> BodyId {
        self.add_static(
            SharedShape::cuboid(size.x / 2.0, size.y / 2.0),
            None,
            Pose::new(center.x, center.y, yaw),
            Tag::Wall(index),
            WALL_FRICTION,
        )
    }

    /// Adds a static wall of any shape at `pose`, tagged as wall `index`.
    pub fn add_wall_shape(&mut self, shape: SharedShape, pose: Pose, index: usize) -> BodyId {
        self.add_static(shape, None, pose, Tag::Wall(index), WALL_FRICTION)
    }

    fn add_static(
        &mut self,
        shape: SharedShape,
        mprops: Option<MassProperties>,
        pose: Pose,
        tag: Tag,
        friction: f32,
    ) -> BodyId {
        let body = self.world.bodies.insert(
            RigidBodyBuilder::fixed()
                .translation(pose.position())
                .rotation(pose.theta),
        );
        let builder = ColliderBuilder::new(shape);
        let builder = match mprops {
            Some(m) => builder.mass_properties(m),
            None => builder,
        };
        let collider = self.world.colliders.insert_with_parent(
            builder
                .friction(friction)
                .friction_combine_rule(CoefficientCombineRule::Multiply)
                .restitution(0.0)
                .user_data(tag.encode()),
            body,
            &mut self.world.bodies,
        );
        self.fixtures.push(Nearby {
            tag,
            collider,
            bound: Bound::Unknown,
        });
        BodyId {
            body,
            collider,
            drive: None,
        }
    }

    /// Adds an object. Movable objects rub on the floor with Coulomb friction `floor_mu * m * g`
    /// spread over their footprint, sampled at points (the exact limit surface, see the module
    /// documentation).
    /// Their mass is spread evenly over the shape; `overlap`, the moments of the shape's union
    /// where its parts overlap ([`crate::geometry::overlap_moments`]), keeps the overlap from
    /// counting twice.
    #[expect(
        clippy::too_many_arguments,
        reason = "one object's set-up, field by field"
    )]
    pub fn add_object(
        &mut self,
        shape: SharedShape,
        overlap: Option<crate::geometry::AreaMoments>,
        pose: Pose,
        mass: f32,
        movable: bool,
        floor_mu: f32,
        index: usize,
    ) -> BodyId {
        let mprops = overlap.map(|m| {
            MassProperties::new(
                Vec2::new(m.center[0] as f32, m.center[1] as f32),
                mass,
                (m.polar * f64::from(mass) / m.area) as f32,
            )
        });
        if !movable {
            return self.add_static(shape, mprops, pose, Tag::Object(index), OBJECT_FRICTION);
        }
        let body = self.world.bodies.insert(
            RigidBodyBuilder::dynamic()
                .translation(pose.position())
                .rotation(pose.theta)
                .can_sleep(false),
        );
        let builder = ColliderBuilder::new(shape.clone());
        let builder = match mprops {
            Some(m) => builder.mass_properties(m),
            None => builder.density(mass / shape.mass_properties(1.0).mass().max(1e-6)),
        };
        let collider = self.world.colliders.insert_with_parent(
            builder
                .friction(OBJECT_FRICTION)
                .friction_combine_rule(CoefficientCombineRule::Multiply)
                .restitution(0.0)
                .user_data(Tag::Object(index).encode()),
            body,
            &mut self.world.bodies,
        );
        self.fixtures.push(Nearby {
            tag: Tag::Object(index),
            collider,
            bound: Bound::Unknown,
        });
        let b = &self.world.bodies[body];
        let com = b.local_center_of_mass();
        let (m, inertia) = (
            b.mass(),
            b.mass_properties().local_mprops.principal_inertia(),
        );
        let aabb = shape.compute_local_aabb();
        let footprint = Footprint::sample(
            |p| shape.contains_local_point(p),
            aabb.mins,
            aabb.maxs,
            floor_mu * mass * GRAVITY,
        );
        let joint = ground_motors(
            GenericJointBuilder::new(JointAxesMask::empty())
                .local_anchor1(Vec2::ZERO)
                .local_anchor2(com),
        );
        let joint = self
            .world
            .impulse_joints
            .insert(self.ground, body, joint, true);
        self.friction.push(Friction {
            joint: FloorJoint {
                body,
                joint,
                mass: m,
                inertia,
                pre: Twist::default(),
                axis: Vec2::X,
                active: true,
            },
            footprint,
            end: Twist::default(),
        });
        BodyId {
            body,
            collider,
            drive: None,
        }
    }

    /// Adds a robot of the given model. Its wheels are a joint to the ground (see
    /// [`Physics::drive`]).
    pub fn add_robot(&mut self, model: &RobotModel, pose: Pose, index: usize) -> BodyId {
        let body = self.world.bodies.insert(
            RigidBodyBuilder::dynamic()
                .translation(pose.position())
                .rotation(pose.theta)
                .can_sleep(false),
        );
        let collider = self.world.colliders.insert_with_parent(
            ColliderBuilder::ball(model.radius)
                .mass(model.mass)
                .friction(ROBOT_FRICTION)
                .friction_combine_rule(CoefficientCombineRule::Multiply)
                .restitution(0.0)
                .user_data(Tag::Robot(index).encode()),
            body,
            &mut self.world.bodies,
        );
        let heading = self.world.bodies[body].rotation();
        let axis = Vec2::new(heading.cos(), heading.sin());
        let joint = ground_motors(
            GenericJointBuilder::new(JointAxesMask::empty())
                .local_frame1(frame(pose.position(), axis)),
        );
        let joint = self
            .world
            .impulse_joints
            .insert(self.ground, body, joint, true);
        if let Some(j) = self.world.impulse_joints.get_mut(joint, false) {
            j.data.set_enabled(false);
        }
        let b = &self.world.bodies[body];
        let drive = self.drives.len() as u32;
        self.drives.push(FloorJoint {
            body,
            joint,
            mass: b.mass(),
            inertia: b.mass_properties().local_mprops.principal_inertia(),
            pre: Twist::default(),
            axis,
            active: false,
        });
        self.robots.push((
            Nearby {
                tag: Tag::Robot(index),
                collider,
                bound: Bound::Unknown,
            },
            model.radius,
        ));
        BodyId {
            body,
            collider,
            drive: Some(drive),
        }
    }

    /// Adds an ideal pusher for validation: a frictionless kinematic disc of `radius` at
    /// `center`, moving at the constant `velocity` whatever it meets (tagged as wall `index`).
    pub fn add_pusher(
        &mut self,
        center: Vec2,
        radius: f32,
        velocity: Vec2,
        index: usize,
    ) -> BodyId {
        let body = self.world.bodies.insert(
            RigidBodyBuilder::kinematic_velocity_based()
                .translation(center)
                .linvel(velocity),
        );
        let collider = self.world.colliders.insert_with_parent(
            ColliderBuilder::ball(radius)
                .friction(0.0)
                .friction_combine_rule(CoefficientCombineRule::Multiply)
                .restitution(0.0)
                .user_data(Tag::Wall(index).encode()),
            body,
            &mut self.world.bodies,
        );
        BodyId {
            body,
            collider,
            drive: None,
        }
    }

    /// Pose of a body (its origin and heading).
    pub fn pose(&self, id: BodyId) -> Pose {
        let b = &self.world.bodies[id.body];
        let t = b.translation();
        Pose::new(t.x, t.y, b.rotation().angle())
    }

    /// World position of a body's centre of mass.
    pub fn center_of_mass(&self, id: BodyId) -> Vec2 {
        self.world.bodies[id.body].center_of_mass()
    }

    /// Linear velocity of a body's centre of mass (m/s).
    pub fn velocity(&self, id: BodyId) -> Vec2 {
        self.world.bodies[id.body].linvel()
    }

    /// Angular velocity of a body (rad/s, counter-clockwise positive).
    pub fn angular_velocity(&self, id: BodyId) -> f32 {
        self.world.bodies[id.body].angvel()
    }

    /// Sets a body's velocity (linear at its centre of mass, angular), e.g. to launch a test.
    /// The change counts as given, not as a force from the last step.
    pub fn set_velocity(&mut self, id: BodyId, linear: Vec2, angular: f32) {
        let b = &mut self.world.bodies[id.body];
        b.set_linvel(linear, true);
        b.set_angvel(angular, true);
        let now = Twist {
            lin: linear,
            ang: angular,
        };
        let joints = self
            .friction
            .iter_mut()
            .map(|f| &mut f.joint)
            .chain(self.drives.iter_mut());
        for fj in joints.filter(|fj| fj.body == id.body) {
            fj.pre = now;
            fj.active = false;
        }
        for f in self.friction.iter_mut().filter(|f| f.joint.body == id.body) {
            f.end = now;
        }
    }

    /// The floor-friction limits of a movable object: largest force and largest torque about
    /// its centre of mass (N, N m).
    pub fn floor_limits(&self, id: BodyId) -> Option<(f32, f32)> {
        self.friction
            .iter()
            .find(|f| f.joint.body == id.body)
            .map(|f| (f.footprint.f_max, f.footprint.tau_max))
    }

    /// The wrench (force, torque about the centre of mass) that everything but `fj` applied to
    /// its body during the last step: its change of momentum minus the joint's impulse.
    fn applied_wrench(&self, fj: &FloorJoint) -> (Vec2, f32) {
        let (h, n) = self.last_step;
        let b = &self.world.bodies[fj.body];
        let mut lin = (b.linvel() - fj.pre.lin) * fj.mass;
        let mut ang = (b.angvel() - fj.pre.ang) * fj.inertia;
        if fj.active {
            if let Some(j) = self.world.impulse_joints.get(fj.joint) {
                // rapier reports the impulse of its last solver sub-step, applied to the first
                // body (the ground); the body got the opposite, over every sub-step.
                let n = n as f32;
                let m = &j.data.motors;
                let imp = fj.axis * m[0].impulse + perp(fj.axis) * m[1].impulse;
                lin += imp * n;
                ang += m[2].impulse * n;
            }
        }
        (lin / h, ang / h)
    }

    /// Sets a robot's wheel speeds `left`, `right` (m/s), as given (the world caps commands at
    /// the model's top speed and adds wheel errors, which may exceed it), for the next step: the body is pulled toward the differential-drive velocity (forward, no
    /// sideways slip, turn rate) with at most the model's drive force, in any direction, and its
    /// drive torque. An `attached` robot keeps its wheels on the floor: commanding zero, it
    /// brakes, with up to its drive force and [`RobotModel::brake_torque`].
    ///
    /// A robot touching something (or attached) is driven by its joint, solved with the
    /// contacts, so it pushes and resists with exactly its traction. A robot touching nothing
    /// gets the same capped velocity change directly, at a fraction of the cost.
    ///
    /// With `coast` the motors are off and the wheel speeds are ignored: the wheels roll along
    /// the heading against [`RobotModel::coast_force`] (rolling resistance), sideways they skid,
    /// resisted with the rest of the traction circle, and a turn in place is resisted with the
    /// rolling resistance at the wheels.
    pub fn drive(
        &mut self,
        id: BodyId,
        model: &RobotModel,
        left: f32,
        right: f32,
        attached: bool,
        coast: bool,
    ) {
        let Some(k) = id.drive else { return };
        if coast {
            self.coast(id, k as usize, model, attached);
            return;
        }
        let fj = self.drives[k as usize];
        let (l, r) = (left, right);
        let (v, w) = ((l + r) / 2.0, (r - l) / model.wheel_distance);
        let h = self.dt();
        // Touching: a contact this step can close (the robot and what it meets both moving).
        let speed = self.world.bodies[id.body].linvel().length().max(v.abs());
        let touching = attached || self.in_contact(id.collider, 2.0 * speed * h + TOUCH);
        // Read without `IndexMut`, which marks the body as changed by the user (rapier then
        // re-processes it): most robots cruise at their target and need no change.
        let b = &self.world.bodies[id.body];
        let rot = b.rotation();
        let heading = Vec2::new(rot.cos(), rot.sin());
        let target = Twist {
            lin: heading * v,
            ang: w,
        };
        let now = Twist {
            lin: b.linvel(),
            ang: b.angvel(),
        };
        let (f_cap, t_cap) = if attached {
            (model.max_force, model.brake_torque())
        } else {
            (model.max_force, model.max_torque)
        };
        if !touching {
            // The joint's effect without contacts: a velocity change capped by the traction
            // circle and the torque.
            let mut dv = target.lin - now.lin;
            let cap = f_cap / fj.mass * h;
            if dv.length() > cap {
                dv *= cap / dv.length();
            }
            let wcap = t_cap / fj.inertia * h;
            let dw = (target.ang - now.ang).clamp(-wcap, wcap);
            let after = Twist {
                lin: now.lin + dv,
                ang: now.ang + dw,
            };
            self.set_free_velocity(id, k as usize, now, after);
            return;
        }
        // Traction circle: the force that would reach the target within the step, given what
        // the rest of the world did to the robot in the last step.
        let (wf, _) = self.applied_wrench(&fj);
        let free = now.lin + wf * (h / fj.mass);
        let need = (target.lin - free) * (fj.mass / h);
        let axis = direction_or(need, fj.axis);
        let u = need.length() / f_cap;
        let caps = if u <= 1.0 {
            hold_box([u, 0.0]).map(|c| c * f_cap)
        } else {
            [f_cap, 0.0]
        };
        let origin = b.translation();
        self.drives[k as usize] = FloorJoint {
            pre: now,
            axis,
            active: true,
            ..fj
        };
        if let Some(j) = self.world.impulse_joints.get_mut(fj.joint, false) {
            j.data
                .set_local_frame1(frame(origin, axis))
                .set_motor_velocity(JointAxis::LinX, target.lin.dot(axis), MOTOR_DAMPING)
                .set_motor_velocity(JointAxis::LinY, target.lin.dot(perp(axis)), MOTOR_DAMPING)
                .set_motor_velocity(JointAxis::AngX, target.ang, MOTOR_DAMPING)
                .set_motor_max_force(JointAxis::LinX, caps[0])
                .set_motor_max_force(JointAxis::LinY, caps[1])
                .set_motor_max_force(JointAxis::AngX, t_cap);
            if !j.data.is_enabled() {
                j.data.set_enabled(true);
            }
        }
    }

    /// A robot touching nothing: its wheels' effect is a velocity change from `now` to
    /// `after`, set directly, with its drive joint off.
    fn set_free_velocity(&mut self, id: BodyId, k: usize, now: Twist, after: Twist) {
        if after != now {
            let b = &mut self.world.bodies[id.body];
            b.set_linvel(after.lin, false);
            b.set_angvel(after.ang, false);
        }
        let fj = self.drives[k];
        self.drives[k] = FloorJoint {
            pre: after,
            active: false,
            ..fj
        };
        if fj.active {
            if let Some(j) = self.world.impulse_joints.get_mut(fj.joint, false) {
                j.data.set_enabled(false);
            }
        }
    }

    /// A robot with its motors off (see [`Physics::drive`]): every velocity component is
    /// brought toward zero with at most its cap, in the robot's own frame.
    fn coast(&mut self, id: BodyId, k: usize, model: &RobotModel, attached: bool) {
        let fj = self.drives[k];
        let h = self.dt();
        let b = &self.world.bodies[id.body];
        let rot = b.rotation();
        let heading = Vec2::new(rot.cos(), rot.sin());
        let now = Twist {
            lin: b.linvel(),
            ang: b.angvel(),
        };
        let roll = model.coast_force();
        // Along the heading and across it, inside the traction circle: sqrt(roll^2 + side^2)
        // is the drive force.
        let caps = [
            roll,
            (model.max_force * model.max_force - roll * roll)
                .max(0.0)
                .sqrt(),
            (roll * model.wheel_distance / 2.0).min(model.max_torque),
        ];
        let speed = now.lin.length();
        let touching = attached || self.in_contact(id.collider, 2.0 * speed * h + TOUCH);
        if !touching {
            let toward_zero = |v: f32, cap: f32| v - v.clamp(-cap, cap);
            let along = toward_zero(now.lin.dot(heading), caps[0] / fj.mass * h);
            let side = toward_zero(now.lin.dot(perp(heading)), caps[1] / fj.mass * h);
            let after = Twist {
                lin: heading * along + perp(heading) * side,
                ang: toward_zero(now.ang, caps[2] / fj.inertia * h),
            };
            self.set_free_velocity(id, k, now, after);
            return;
        }
        let origin = b.translation();
        self.drives[k] = FloorJoint {
            pre: now,
            axis: heading,
            active: true,
            ..fj
        };
        if let Some(j) = self.world.impulse_joints.get_mut(fj.joint, false) {
            j.data.set_local_frame1(frame(origin, heading));
            for (ax, cap) in [JointAxis::LinX, JointAxis::LinY, JointAxis::AngX]
                .into_iter()
                .zip(caps)
            {
                j.data
                    .set_motor_velocity(ax, 0.0, MOTOR_DAMPING)
                    .set_motor_max_force(ax, cap);
            }
            if !j.data.is_enabled() {
                j.data.set_enabled(true);
            }
        }
    }

    /// Whether a collider has a contact point closer than `reach` (m) to another. Contacts are
    /// predicted from further away (see [`Physics::set_contact_prediction`]); those do not
    /// touch yet.
    fn in_contact(&self, collider: ColliderHandle, reach: f32) -> bool {
        self.world
            .narrow_phase
            .contact_pairs_with(collider)
            .any(|p| {
                p.solver_manifolds()
                    .iter()
                    .any(|m| m.data.solver_contacts.iter().any(|c| c.dist < reach))
            })
    }

    /// Sets every movable object's floor-friction joint for the next step (see the module
    /// documentation). The objects' friction steps are independent of each other: with a
    /// `pool` they are solved on its threads and the caller's (the same results on any number).
    fn set_floor_friction(&mut self, pool: Option<&rayon::ThreadPool>) {
        let h = self.dt();
        // What each object's step starts from, read from the last step.
        let mut jobs: Vec<FrictionJob> = self
            .friction
            .iter()
            .map(|fr| {
                let fj = fr.joint;
                let (wf, wt) = self.applied_wrench(&fj);
                let b = &self.world.bodies[fj.body];
                let rot = b.rotation();
                let now = Twist {
                    lin: b.linvel(),
                    ang: b.angvel(),
                };
                let free = Twist {
                    lin: now.lin + wf * (h / fj.mass),
                    ang: now.ang + wt * (h / fj.inertia),
                };
                FrictionJob {
                    rot: (rot.cos(), rot.sin()),
                    now,
                    free,
                    step: None,
                }
            })
            .collect();
        let friction = &self.friction;
        parallel::for_each(pool, &mut jobs, OBJECTS_PER_CHUNK, |k, job| {
            let (fj, fr) = (friction[k].joint, &friction[k]);
            job.step = Some(
                fr.footprint
                    .step(job.rot, fj.mass, fj.inertia, h, job.free, fr.end),
            );
        });
        for (k, job) in jobs.into_iter().enumerate() {
            let Some(s) = job.step else { continue };
            let fj = self.friction[k].joint;
            let fp = &self.friction[k].footprint;
            let (axis, motors) = if s.sticks {
                let axis = direction_or(s.force, fj.axis);
                let u = [
                    s.force.length() / fp.f_max,
                    0.0,
                    s.torque.abs() / fp.tau_max.max(1e-12),
                ];
                let c = hold_box(u.map(|x| x.min(1.0)));
                (
                    axis,
                    [
                        Motor::hold(0.0, c[0] * fp.f_max),
                        Motor::hold(0.0, c[1] * fp.f_max),
                        Motor::hold(0.0, c[2] * fp.tau_max),
                    ],
                )
            } else {
                // Frame along the slip: the motors resist it with the wrench's components (the
                // one across holds the predicted direction of slip), never push along it.
                let axis = direction_or(-s.end.lin, direction_or(s.force, fj.axis));
                let torque = if s.torque * s.end.ang <= 0.0 {
                    s.torque.abs()
                } else {
                    0.0
                };
                (
                    axis,
                    [
                        Motor::hold(0.0, s.force.dot(axis).max(0.0)),
                        Motor::hold(0.0, s.force.dot(perp(axis)).abs()),
                        Motor::hold(0.0, torque),
                    ],
                )
            };
            self.friction[k].end = s.end;
            self.friction[k].joint = FloorJoint {
                pre: job.now,
                axis,
                active: true,
                ..fj
            };
            if let Some(j) = self.world.impulse_joints.get_mut(fj.joint, false) {
                j.data.set_local_frame1(frame(Vec2::ZERO, axis));
                for (ax, m) in [JointAxis::LinX, JointAxis::LinY, JointAxis::AngX]
                    .into_iter()
                    .zip(motors)
                {
                    m.apply(&mut j.data, ax);
                }
            }
        }
    }

    /// Advances the world by one step, after setting the objects' floor friction for it.
    /// Call [`Physics::drive`] for every robot first.
    pub fn step(&mut self) {
        self.step_on(None);
    }

    /// [`Physics::step`], solving the objects' floor friction on `pool`'s threads too (rapier's
    /// own step stays on the caller's thread). The result does not depend on the pool.
    pub fn step_on(&mut self, pool: Option<&rayon::ThreadPool>) {
        self.set_floor_friction(pool);
        self.index.fresh = false;
        self.world.step();
        let p = &self.world.integration_parameters;
        self.last_step = (p.dt, p.num_solver_iterations);
    }

    /// Fixes `robot` to `target` at their current relative pose; contacts between the two
    /// are switched off.
    pub fn attach(&mut self, robot: BodyId, target: BodyId) -> AttachId {
        let rp = *self.world.bodies[robot.body].position();
        let tp = *self.world.bodies[target.body].position();
        let frame1 = tp.inverse() * rp;
        let joint = FixedJointBuilder::new()
            .local_frame1(frame1)
            .local_frame2(rapier2d::math::Pose::IDENTITY)
            .contacts_enabled(false)
            .build();
        AttachId(
            self.world
                .impulse_joints
                .insert(target.body, robot.body, joint, true),
        )
    }

    /// Removes an attachment.
    pub fn detach(&mut self, id: AttachId) {
        self.world.impulse_joints.remove(id.0, true);
    }

    /// Sets the area the neighbour grid covers (the arena and its walls; see
    /// [`Physics::rebuild_index`]).
    pub fn set_index_area(&mut self, lo: Vec2, hi: Vec2) {
        self.index.area = Some((lo, hi));
    }

    /// Rebuilds the neighbour index from the current positions. Call once per tick, after the
    /// physics steps and before sensing.
    pub fn rebuild_index(&mut self) {
        let idx = &mut self.index;
        idx.fixture_boxes.clear();
        for f in &self.fixtures {
            idx.fixture_boxes
                .push(self.world.colliders[f.collider].compute_aabb());
        }
        idx.fixture_grid.build(&idx.fixture_boxes, idx.area);
        for (f, b) in self.fixtures.iter_mut().zip(&idx.fixture_boxes) {
            f.bound = Bound::Box(b.mins, b.maxs);
        }
        idx.fresh = true;
        idx.items.clear();
        let (mut lo, mut hi) = (Vec2::splat(f32::MAX), Vec2::splat(f32::MIN));
        idx.max_radius = 0.0;
        for (slot, (n, r)) in self.robots.iter().enumerate() {
            let p = self.world.colliders[n.collider].position().translation;
            lo = lo.min(p);
            hi = hi.max(p);
            idx.max_radius = idx.max_radius.max(*r);
            idx.items.push((p, slot as u32));
        }
        if idx.items.is_empty() {
            idx.starts.clear();
            idx.nx = 0;
            idx.ny = 0;
            return;
        }
        // The grid covers the arena (or, without one, the robots' spread), in cells of about a
        // proximity reach, at most a few per robot and at most `MAX_CELLS`.
        if let Some(area) = idx.area {
            (lo, hi) = area;
        }
        let span = (hi - lo).max(Vec2::splat(1e-3));
        let mut cell = CELL_M.max(2.0 * idx.max_radius);
        let budget = (4 * idx.items.len() + 1024).min(MAX_CELLS) as f32;
        if (span.x / cell + 1.0) * (span.y / cell + 1.0) > budget {
            // Both the area and the longer side bound the count: (a + 1)(b + 1) <= budget.
            let by_area = (4.0 * span.x * span.y / budget).sqrt();
            let by_side = 4.0 * span.x.max(span.y) / budget;
            cell = by_area.max(by_side).max(cell);
        }
        if !cell.is_finite() {
            cell = f32::MAX;
        }
        idx.cell = cell;
        idx.min = lo;
        idx.nx = ((span.x / cell).floor() as usize).clamp(0, MAX_CELLS) + 1;
        idx.ny = ((span.y / cell).floor() as usize).clamp(0, MAX_CELLS / idx.nx) + 1;
        let cells = idx.nx * idx.ny;
        let cell_of = |p: Vec2, idx: &NeighbourIndex| {
            let cx = (((p.x - idx.min.x) / idx.cell) as usize).min(idx.nx - 1);
            let cy = (((p.y - idx.min.y) / idx.cell) as usize).min(idx.ny - 1);
            cy * idx.nx + cx
        };
        idx.starts.clear();
        idx.starts.resize(cells + 1, 0);
        for k in 0..idx.items.len() {
            let c = cell_of(idx.items[k].0, idx);
            idx.starts[c + 1] += 1;
        }
        for c in 0..cells {
            idx.starts[c + 1] += idx.starts[c];
        }
        let mut fill = idx.starts.clone();
        let mut sorted = vec![(Vec2::ZERO, 0u32); idx.items.len()];
        for &(p, slot) in &idx.items {
            let c = cell_of(p, idx);
            sorted[fill[c] as usize] = (p, slot);
            fill[c] += 1;
        }
        idx.items = sorted;
    }

    /// Colliders within the square of half-side `radius` around `center` (walls and objects
    /// by bounding box, robots by their disc's box), appended to `out` after clearing it. Uses the
    /// index from the last [`Physics::rebuild_index`]. Walls and objects come first, then robots
    /// in robot order, whatever the grid.
    pub fn nearby(&self, center: Vec2, radius: f32, out: &mut Vec<Nearby>) {
        out.clear();
        let idx = &self.index;
        let query = Aabb::new(center - Vec2::splat(radius), center + Vec2::splat(radius));
        if !self.nearby_fixtures_by_grid(&query, out) {
            for (f, b) in self.fixtures.iter().zip(&idx.fixture_boxes) {
                if b.intersects(&query) {
                    out.push(*f);
                }
            }
        }
        if idx.nx == 0 {
            return;
        }
        let first_robot = out.len();
        let reach = radius + idx.max_radius;
        let lo = center - Vec2::splat(reach) - idx.min;
        let hi = center + Vec2::splat(reach) - idx.min;
        // Robots outside the grid are in its border cells: clamp rather than skip.
        let x0 = ((lo.x / idx.cell).max(0.0) as usize).min(idx.nx - 1);
        let y0 = ((lo.y / idx.cell).max(0.0) as usize).min(idx.ny - 1);
        let x1 = ((hi.x / idx.cell) as usize).min(idx.nx - 1);
        let y1 = ((hi.y / idx.cell) as usize).min(idx.ny - 1);
        for cy in y0..=y1 {
            let row = cy * idx.nx;
            let (a, b) = (
                idx.starts[row + x0] as usize,
                idx.starts[row + x1 + 1] as usize,
            );
            for &(p, slot) in &idx.items[a..b] {
                let (mut n, r) = self.robots[slot as usize];
                if (p.x - center.x).abs() <= radius + r && (p.y - center.y).abs() <= radius + r {
                    n.bound = Bound::Disc(p, r);
                    out.push(n);
                }
            }
        }
        // In robot order, not cell order: what sensors see does not depend on the grid.
        out[first_robot..].sort_unstable_by_key(|n| match n.tag {
            Tag::Robot(i) => i,
            _ => usize::MAX,
        });
    }

    /// The fixtures whose boxes meet `query`, in fixture order, from the fixture grid; false
    /// (and nothing pushed) when there is no grid or the query spans too many cells.
    fn nearby_fixtures_by_grid(&self, query: &Aabb, out: &mut Vec<Nearby>) -> bool {
        let g = &self.index.fixture_grid;
        if g.nx == 0 {
            return false;
        }
        let [x0, y0] = g.cell_xy(query.mins);
        let [x1, y1] = g.cell_xy(query.maxs);
        const CAP: usize = 64;
        let mut buf = [0u32; CAP];
        let mut n = 0;
        for &f in &g.big {
            if n == CAP {
                return false;
            }
            buf[n] = f;
            n += 1;
        }
        for y in y0..=y1 {
            for x in x0..=x1 {
                let c = y * g.nx + x;
                for &f in &g.items[g.starts[c] as usize..g.starts[c + 1] as usize] {
                    if n == CAP {
                        return false;
                    }
                    buf[n] = f;
                    n += 1;
                }
            }
        }
        let buf = &mut buf[..n];
        buf.sort_unstable();
        let mut last = u32::MAX;
        for &f in buf.iter() {
            if f == last {
                continue;
            }
            last = f;
            if self.index.fixture_boxes[f as usize].intersects(query) {
                out.push(self.fixtures[f as usize]);
            }
        }
        true
    }

    /// The bounding box (lower and upper corners) of fixture `i` ([`Physics::fixtures`]) as of
    /// the last [`Physics::rebuild_index`].
    pub fn fixture_box(&self, i: usize) -> (Vec2, Vec2) {
        let b = &self.index.fixture_boxes[i];
        (b.mins, b.maxs)
    }

    /// Calls `f` with every robot whose disc may meet the segment from `a` to `a + dir * len`
    /// (`dir` a unit vector): every robot whose disc comes within 1 mm of it, and none farther,
    /// in grid order; stops and returns true when `f` does. Uses the index of the last
    /// [`Physics::rebuild_index`], walking only the cells along the segment.
    pub fn robots_along(
        &self,
        a: Vec2,
        dir: Vec2,
        len: f32,
        mut f: impl FnMut(Nearby) -> bool,
    ) -> bool {
        let idx = &self.index;
        if idx.nx == 0 || !(len >= 0.0) {
            return false;
        }
        let b = a + dir * len;
        let pad = idx.max_radius + 1e-3;
        let (lo, hi) = (a.min(b) - Vec2::splat(pad), a.max(b) + Vec2::splat(pad));
        let col = |x: f32| (((x - idx.min.x) / idx.cell).max(0.0) as usize).min(idx.nx - 1);
        let row = |y: f32| (((y - idx.min.y) / idx.cell).max(0.0) as usize).min(idx.ny - 1);
        let (c0, c1) = (col(lo.x), col(hi.x));
        for cx in c0..=c1 {
            // The segment's y range over the column's x range (widened by the pad); the
            // border columns hold the robots beyond the grid too.
            let xa = if cx == 0 {
                f32::MIN
            } else {
                idx.min.x + cx as f32 * idx.cell - pad
            };
            let xb = if cx == idx.nx - 1 {
                f32::MAX
            } else {
                idx.min.x + (cx + 1) as f32 * idx.cell + pad
            };
            let (ya, yb) = if dir.x.abs() > 1e-6 {
                let ta = ((xa - a.x) / dir.x).clamp(0.0, len);
                let tb = ((xb - a.x) / dir.x).clamp(0.0, len);
                let (p, q) = (a.y + dir.y * ta, a.y + dir.y * tb);
                (p.min(q) - pad, p.max(q) + pad)
            } else {
                (lo.y, hi.y)
            };
            let (r0, r1) = (row(ya.max(lo.y)), row(yb.min(hi.y)));
            for cy in r0..=r1 {
                let c = cy * idx.nx + cx;
                let (s, e) = (idx.starts[c] as usize, idx.starts[c + 1] as usize);
                for &(p, slot) in &idx.items[s..e] {
                    let (mut n, r) = self.robots[slot as usize];
                    let t = (p - a).dot(dir).clamp(0.0, len);
                    let d = p - (a + dir * t);
                    let reach = r + 1e-3;
                    n.bound = Bound::Disc(p, r);
                    if d.dot(d) <= reach * reach && f(n) {
                        return true;
                    }
                }
            }
        }
        false
    }

    /// The bounding box (min, max corners) of a wall or object found by [`Physics::nearby`], as
    /// of the last [`Physics::rebuild_index`]; `None` for robots.
    pub fn fixture_box_of(&self, n: &Nearby) -> Option<(Vec2, Vec2)> {
        let i = self
            .fixtures
            .iter()
            .position(|f| f.collider == n.collider)?;
        let b = self.index.fixture_boxes.get(i)?;
        Some((b.mins, b.maxs))
    }

    /// Casts a ray against a few colliders only; returns the index in `candidates` and the
    /// distance of the first hit within `max_dist`.
    pub fn cast_local(
        &self,
        candidates: &[Nearby],
        skip: Option<Tag>,
        origin: Vec2,
        dir: Vec2,
        max_dist: f32,
    ) -> Option<(usize, f32)> {
        let ray = Ray::new(origin, dir);
        let mut best: Option<(usize, f32)> = None;
        for (i, c) in candidates.iter().enumerate() {
            if Some(c.tag) == skip {
                continue;
            }
            let limit = best.map_or(max_dist, |b| b.1);
            if self.index.fresh && !may_meet(c.bound, origin, dir, limit) {
                continue;
            }
            let col = &self.world.colliders[c.collider];
            if let Some(t) = col.shape().cast_ray(col.position(), &ray, limit, true) {
                if best.is_none_or(|b| t < b.1) {
                    best = Some((i, t));
                }
            }
        }
        best
    }

    /// Every wall and object collider (robots excluded), in insertion order.
    pub fn fixtures(&self) -> &[Nearby] {
        &self.fixtures
    }

    /// Distance along the ray at which it enters a collider, if within `max_dist`.
    pub fn ray_entry(&self, n: &Nearby, origin: Vec2, dir: Vec2, max_dist: f32) -> Option<f32> {
        if self.index.fresh && !may_meet(n.bound, origin, dir, max_dist) {
            return None;
        }
        let col = &self.world.colliders[n.collider];
        col.shape()
            .cast_ray(col.position(), &Ray::new(origin, dir), max_dist, true)
    }

    /// The point of a nearby collider's surface nearest to `point`.
    pub fn nearest_point_of(&self, n: &Nearby, point: Vec2) -> Vec2 {
        let col = &self.world.colliders[n.collider];
        col.shape()
            .project_point(col.position(), point, false)
            .point
    }

    /// Whether `point` lies inside a body's shape.
    pub fn contains(&self, id: BodyId, point: Vec2) -> bool {
        let col = &self.world.colliders[id.collider];
        col.shape().contains_point(col.position(), point)
    }

    /// Distance (m) from `point` to a body's shape; 0 inside it.
    pub fn distance_to(&self, id: BodyId, point: Vec2) -> f32 {
        let col = &self.world.colliders[id.collider];
        col.shape().distance_to_point(col.position(), point, true)
    }

    /// Whether a disc of `radius` at `center` overlaps a body's shape (touching counts). Robust
    /// where a point projection is not: a disc centred on an edge of a concave polygon's piece
    /// overlaps it, whatever the rounding.
    pub fn disc_meets(&self, id: BodyId, center: Vec2, radius: f32) -> bool {
        let col = &self.world.colliders[id.collider];
        let ball = Ball::new(radius);
        let pose = rapier2d::math::Pose::from_translation(center);
        rapier2d::parry::query::intersection_test(&pose, &ball, col.position(), col.shape())
            .map_or(true, |r| r.intersecting)
    }

    /// The first collider (in insertion order) that a disc of `radius` at `center` overlaps.
    /// Scans every collider, so it works before the first step; meant for set-up checks.
    pub fn disc_overlaps(&self, center: Vec2, radius: f32) -> Option<Tag> {
        self.colliders()
            .find(|c| disc_meets(c, center, radius))
            .map(|c| Tag::decode(c.user_data))
    }

    /// Whether a disc of `radius` at `center` intersects the collider of `n` where it is now.
    pub fn disc_hits(&self, n: &Nearby, center: Vec2, radius: f32) -> bool {
        self.world
            .colliders
            .get(n.collider)
            .is_some_and(|c| disc_meets(c, center, radius))
    }

    /// Every collider: walls and objects in insertion order, then robots. (Not rapier's
    /// collider set: it is made with room for the robots still to come, and walking it would
    /// visit every empty slot.)
    fn colliders(&self) -> impl Iterator<Item = &Collider> {
        self.fixtures
            .iter()
            .chain(self.robots.iter().map(|(n, _)| n))
            .filter_map(|n| self.world.colliders.get(n.collider))
    }

    /// The first collider that `shape` at `pose` intersects, if any.
    pub fn shape_overlaps(&self, shape: &SharedShape, pose: rapier2d::math::Pose) -> Option<Tag> {
        self.colliders().find_map(|c| {
            rapier2d::parry::query::intersection_test(&pose, &**shape, c.position(), c.shape())
                .is_ok_and(|r| r.intersecting)
                .then(|| Tag::decode(c.user_data))
        })
    }

    /// The first object (in the order they were added) that `shape` at `pose` overlaps by
    /// more than `depth` m (bodies that only touch do not count).
    pub fn object_overlaps(
        &self,
        shape: &SharedShape,
        pose: rapier2d::math::Pose,
        depth: f32,
    ) -> Option<usize> {
        self.colliders()
            .find_map(|c| match Tag::decode(c.user_data) {
                Tag::Object(j) => {
                    rapier2d::parry::query::contact(&pose, &**shape, c.position(), c.shape(), 0.0)
                        .ok()
                        .flatten()
                        .is_some_and(|k| k.dist < -depth)
                        .then_some(j)
                }
                _ => None,
            })
    }

    /// Whether a body currently touches (within [`TOUCH`]) any collider with the given kind of
    /// tag.
    pub fn touches(&self, id: BodyId, mut pred: impl FnMut(Tag) -> bool) -> bool {
        for pair in self.world.narrow_phase.contact_pairs_with(id.collider) {
            let close = pair
                .solver_manifolds()
                .iter()
                .any(|m| m.data.solver_contacts.iter().any(|c| c.dist < TOUCH));
            if !close {
                continue;
            }
            let other = if pair.collider1 == id.collider {
                pair.collider2
            } else {
                pair.collider1
            };
            if let Some(c) = self.world.colliders.get(other) {
                if pred(Tag::decode(c.user_data)) {
                    return true;
                }
            }
        }
        false
    }

    /// Signed distance between the surfaces of two bodies: the gap, or minus the depth by which
    /// they overlap.
    pub fn separation(&self, a: BodyId, b: BodyId) -> f32 {
        let ca = &self.world.colliders[a.collider];
        let cb = &self.world.colliders[b.collider];
        rapier2d::parry::query::contact(
            ca.position(),
            ca.shape(),
            cb.position(),
            cb.shape(),
            f32::MAX,
        )
        .ok()
        .flatten()
        .map_or(f32::MAX, |c| c.dist)
    }

    /// Distance between the surfaces of two bodies (0 when they touch or overlap).
    pub fn distance(&self, a: BodyId, b: BodyId) -> f32 {
        let ca = &self.world.colliders[a.collider];
        let cb = &self.world.colliders[b.collider];
        rapier2d::parry::query::distance(ca.position(), ca.shape(), cb.position(), cb.shape())
            .map_or(f32::MAX, |d| d.distance)
    }

    /// The body's world-space shape placement, for drawing: the pose of the collider.
    pub fn collider_pose(&self, id: BodyId) -> Pose {
        let p = self.world.colliders[id.collider].position();
        Pose::new(p.translation.x, p.translation.y, p.rotation.angle())
    }
}

/// Whether a disc of `radius` at `center` intersects collider `c`.
fn disc_meets(c: &Collider, center: Vec2, radius: f32) -> bool {
    let pose = rapier2d::math::Pose::from_translation(center);
    rapier2d::parry::query::intersection_test(&pose, &Ball::new(radius), c.position(), c.shape())
        .is_ok_and(|r| r.intersecting)
}
