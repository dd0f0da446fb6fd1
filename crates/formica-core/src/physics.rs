//! Rigid-body physics: the only module that talks to rapier2d.
//!
//! Top-down 2D, no gravity. Robots are driven toward their commanded wheel speeds by
//! force-capped impulses (as ARGoS drags them with force-capped joints). Movable objects rub
//! on the floor through a joint to a static ground body whose motors hold them still with at
//! most `mu * m * g` of force (Coulomb friction), so that one robot cannot move what a team can.

use crate::geometry::{Pose, Vec2};
use crate::ops;
use crate::robot::RobotModel;
use rapier2d::prelude::*;

/// Standard gravity, for floor friction (m/s^2).
pub const GRAVITY: f32 = 9.81;
/// Contact friction coefficients (combined by product, as ARGoS does).
pub const ROBOT_FRICTION: f32 = 0.7;
/// Contact friction of objects.
pub const OBJECT_FRICTION: f32 = 0.7;
/// Contact friction of walls.
pub const WALL_FRICTION: f32 = 0.1;

/// Damping of the floor-friction velocity motors: large, so that below the force cap the
/// object is held still (a stiff velocity constraint), and above it slides.
const MOTOR_DAMPING: f32 = 1.0e6;

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
    drive: Option<ImpulseJointHandle>,
}

/// A collider near a query point, for cheap local ray casts.
#[derive(Debug, Clone, Copy)]
pub struct Nearby {
    /// What it belongs to.
    pub tag: Tag,
    collider: ColliderHandle,
}

/// A fixed joint holding a robot to a body.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct AttachId(ImpulseJointHandle);

/// The physics world.
pub struct Physics {
    world: PhysicsWorld,
    ground: RigidBodyHandle,
    /// Floor-friction joints of movable objects: (object body, joint).
    friction_joints: Vec<(RigidBodyHandle, ImpulseJointHandle)>,
    /// Every wall and object collider: the few bodies that can hide a light far away.
    fixtures: Vec<Nearby>,
    /// Robot colliders, in insertion order, with their radii.
    robots: Vec<(Nearby, f32)>,
    /// Neighbour index for sensor queries, rebuilt once per tick.
    index: NeighbourIndex,
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
    max_radius: f32,
}

/// Side of a neighbour-index cell (m): about a Khepera's proximity reach.
const CELL_M: f32 = 0.3;

impl Physics {
    /// An empty world stepping `dt` seconds per call to [`Physics::step`].
    pub fn new(dt: f32) -> Self {
        let mut world = PhysicsWorld::new();
        world.gravity = Vec2::ZERO;
        world.integration_parameters.dt = dt;
        let ground = world.bodies.insert(RigidBodyBuilder::fixed());
        Self {
            world,
            ground,
            friction_joints: Vec::new(),
            fixtures: Vec::new(),
            robots: Vec::new(),
            index: NeighbourIndex::default(),
        }
    }

    /// Seconds per step.
    pub fn dt(&self) -> f32 {
        self.world.integration_parameters.dt
    }

    /// Adds a static wall: a box of `size` centred at `center`, rotated by `yaw`.
    pub fn add_wall(&mut self, center: Vec2, size: Vec2, yaw: f32, index: usize) -> BodyId {
        self.add_static(
            SharedShape::cuboid(size.x / 2.0, size.y / 2.0),
            Pose::new(center.x, center.y, yaw),
            Tag::Wall(index),
            WALL_FRICTION,
        )
    }

    fn add_static(&mut self, shape: SharedShape, pose: Pose, tag: Tag, friction: f32) -> BodyId {
        let body = self.world.bodies.insert(
            RigidBodyBuilder::fixed()
                .translation(pose.position())
                .rotation(pose.theta),
        );
        let collider = self.world.colliders.insert_with_parent(
            ColliderBuilder::new(shape)
                .friction(friction)
                .friction_combine_rule(CoefficientCombineRule::Multiply)
                .restitution(0.0)
                .user_data(tag.encode()),
            body,
            &mut self.world.bodies,
        );
        self.fixtures.push(Nearby { tag, collider });
        BodyId {
            body,
            collider,
            drive: None,
        }
    }

    /// Adds an object. Movable objects get floor friction `floor_mu * mass * g`; the torque cap
    /// assumes uniform pressure over a disc of the same area (2/3 mu m g r).
    pub fn add_object(
        &mut self,
        shape: SharedShape,
        pose: Pose,
        mass: f32,
        movable: bool,
        floor_mu: f32,
        index: usize,
    ) -> BodyId {
        if !movable {
            return self.add_static(shape, pose, Tag::Object(index), OBJECT_FRICTION);
        }
        let area = shape.mass_properties(1.0).mass().max(1e-6);
        let body = self.world.bodies.insert(
            RigidBodyBuilder::dynamic()
                .translation(pose.position())
                .rotation(pose.theta)
                .can_sleep(false),
        );
        let collider = self.world.colliders.insert_with_parent(
            ColliderBuilder::new(shape)
                .density(mass / area)
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
        });
        let force = floor_mu * mass * GRAVITY;
        let r_eff = (area / std::f32::consts::PI).sqrt();
        let torque = force * r_eff * 2.0 / 3.0;
        let com = self.world.bodies[body].local_center_of_mass();
        let joint = GenericJointBuilder::new(JointAxesMask::empty())
            .local_anchor1(Vec2::ZERO)
            .local_anchor2(com)
            .contacts_enabled(false)
            .motor_velocity(JointAxis::LinX, 0.0, MOTOR_DAMPING)
            .motor_velocity(JointAxis::LinY, 0.0, MOTOR_DAMPING)
            .motor_velocity(JointAxis::AngX, 0.0, MOTOR_DAMPING)
            .motor_max_force(JointAxis::LinX, force)
            .motor_max_force(JointAxis::LinY, force)
            .motor_max_force(JointAxis::AngX, torque)
            .build();
        let jh = self
            .world
            .impulse_joints
            .insert(self.ground, body, joint, true);
        self.friction_joints.push((body, jh));
        BodyId {
            body,
            collider,
            drive: None,
        }
    }

    /// Adds a robot of the given model. Its wheels are a joint to the ground whose velocity
    /// motors (forward, sideways and turning, in the robot's frame) are solved together with
    /// the contacts and capped at the model's drive force and torque, as ARGoS does.
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
        let joint = GenericJointBuilder::new(JointAxesMask::empty())
            .local_frame1(rapier2d::math::Pose::new(pose.position(), pose.theta))
            .contacts_enabled(false)
            .motor_velocity(JointAxis::LinX, 0.0, MOTOR_DAMPING)
            .motor_velocity(JointAxis::LinY, 0.0, MOTOR_DAMPING)
            .motor_velocity(JointAxis::AngX, 0.0, MOTOR_DAMPING)
            .motor_max_force(JointAxis::LinX, model.max_force)
            .motor_max_force(JointAxis::LinY, model.max_force)
            .motor_max_force(JointAxis::AngX, model.max_torque)
            .build();
        let drive = self
            .world
            .impulse_joints
            .insert(self.ground, body, joint, true);
        self.robots.push((
            Nearby {
                tag: Tag::Robot(index),
                collider,
            },
            model.radius,
        ));
        BodyId {
            body,
            collider,
            drive: Some(drive),
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

    /// Linear velocity of a body (m/s).
    pub fn velocity(&self, id: BodyId) -> Vec2 {
        self.world.bodies[id.body].linvel()
    }

    /// Sets a robot's wheel speeds `left`, `right` (m/s), clamped to the model's maximum, for
    /// the next step: the body is pulled toward the differential-drive velocity (forward,
    /// no sideways slip, turn rate) with at most the model's drive force and torque. With
    /// `free` the wheels exert no force (an attached robot).
    ///
    /// A robot touching something is driven by the joint's velocity motors, solved together
    /// with the contacts, so it pushes with exactly its drive force. A robot touching nothing
    /// gets the same capped velocity change directly, which is what the motors would do
    /// without contacts and costs far less than solving a joint.
    pub fn drive(&mut self, id: BodyId, model: &RobotModel, left: f32, right: f32, free: bool) {
        let Some(jh) = id.drive else { return };
        let l = left.clamp(-model.max_speed, model.max_speed);
        let r = right.clamp(-model.max_speed, model.max_speed);
        let (v, w) = ((l + r) / 2.0, (r - l) / model.wheel_distance);
        let touching = !free && self.in_contact(id.collider);
        let dt = self.dt();
        let b = &mut self.world.bodies[id.body];
        let heading = b.rotation().angle();
        let frame = rapier2d::math::Pose::new(b.translation(), heading);
        if !free && !touching {
            let target = ops::unit(heading) * v;
            let mut dv = target - b.linvel();
            let cap = model.max_force / model.mass * dt;
            if dv.length() > cap {
                dv *= cap / dv.length();
            }
            let inertia = 0.5 * model.mass * model.radius * model.radius;
            let wcap = model.max_torque / inertia * dt;
            let dw = (w - b.angvel()).clamp(-wcap, wcap);
            let (lin, ang) = (b.linvel() + dv, b.angvel() + dw);
            b.set_linvel(lin, true);
            b.set_angvel(ang, true);
        }
        let Some(j) = self.world.impulse_joints.get_mut(jh, false) else {
            return;
        };
        if touching {
            j.data
                .set_local_frame1(frame)
                .set_motor_velocity(JointAxis::LinX, v, MOTOR_DAMPING)
                .set_motor_velocity(JointAxis::AngX, w, MOTOR_DAMPING);
            if !j.data.is_enabled() {
                j.data.set_enabled(true);
            }
        } else if j.data.is_enabled() {
            j.data.set_enabled(false);
        }
    }

    fn in_contact(&self, collider: ColliderHandle) -> bool {
        self.world
            .narrow_phase
            .contact_pairs_with(collider)
            .any(|p| p.has_any_active_contact())
    }

    /// Advances the world by one step. Before stepping, each object's floor-friction frame is
    /// turned to its direction of motion, so the friction cap applies along the motion (a
    /// circle, not a box, of force).
    pub fn step(&mut self) {
        for &(body, jh) in &self.friction_joints {
            let v = self.world.bodies[body].linvel();
            if v.length_squared() > 1e-12 {
                let angle = ops::angle_of(v);
                if let Some(j) = self.world.impulse_joints.get_mut(jh, false) {
                    j.data
                        .set_local_frame1(rapier2d::math::Pose::new(Vec2::ZERO, angle));
                }
            }
        }
        self.world.step();
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

    /// Rebuilds the neighbour index from the current positions. Call once per tick, after the
    /// physics steps and before sensing.
    pub fn rebuild_index(&mut self) {
        let idx = &mut self.index;
        idx.fixture_boxes.clear();
        for f in &self.fixtures {
            idx.fixture_boxes
                .push(self.world.colliders[f.collider].compute_aabb());
        }
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
        // Keep the grid at most a few cells per robot, whatever the spread.
        let span = (hi - lo).max(Vec2::splat(1e-3));
        let mut cell = CELL_M;
        let budget = 4.0 * idx.items.len() as f32 + 1024.0;
        if (span.x / cell + 1.0) * (span.y / cell + 1.0) > budget {
            cell = ((span.x * span.y) / budget).sqrt().max(CELL_M);
        }
        idx.cell = cell;
        idx.min = lo;
        idx.nx = (span.x / cell).floor() as usize + 1;
        idx.ny = (span.y / cell).floor() as usize + 1;
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
    /// by bounding box, robots by position), appended to `out` after clearing it. Uses the
    /// index from the last [`Physics::rebuild_index`].
    pub fn nearby(&self, center: Vec2, radius: f32, out: &mut Vec<Nearby>) {
        out.clear();
        let idx = &self.index;
        let query = Aabb::new(center - Vec2::splat(radius), center + Vec2::splat(radius));
        for (f, b) in self.fixtures.iter().zip(&idx.fixture_boxes) {
            if b.intersects(&query) {
                out.push(*f);
            }
        }
        if idx.nx == 0 {
            return;
        }
        let reach = radius + idx.max_radius;
        let lo = center - Vec2::splat(reach) - idx.min;
        let hi = center + Vec2::splat(reach) - idx.min;
        if hi.x < 0.0 || hi.y < 0.0 {
            return;
        }
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
                let (n, r) = self.robots[slot as usize];
                if (p.x - center.x).abs() <= radius + r && (p.y - center.y).abs() <= radius + r {
                    out.push(n);
                }
            }
        }
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
            let col = &self.world.colliders[c.collider];
            let limit = best.map_or(max_dist, |b| b.1);
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
        let col = &self.world.colliders[n.collider];
        col.shape()
            .cast_ray(col.position(), &Ray::new(origin, dir), max_dist, true)
    }

    /// The point of a body's surface nearest to `point`, and whether `point` is inside it.
    pub fn nearest_point(&self, id: BodyId, point: Vec2) -> (Vec2, bool) {
        let col = &self.world.colliders[id.collider];
        let proj = col.shape().project_point(col.position(), point, false);
        (proj.point, proj.is_inside)
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

    /// The first collider (in insertion order) that a disc of `radius` at `center` overlaps.
    /// Scans every collider, so it works before the first step; meant for set-up checks.
    pub fn disc_overlaps(&self, center: Vec2, radius: f32) -> Option<Tag> {
        let ball = Ball::new(radius);
        let pose = rapier2d::math::Pose::from_translation(center);
        self.world.colliders.iter().find_map(|(_, c)| {
            rapier2d::parry::query::intersection_test(&pose, &ball, c.position(), c.shape())
                .is_ok_and(|r| r.intersecting)
                .then(|| Tag::decode(c.user_data))
        })
    }

    /// Whether a body currently touches any collider with the given kind of tag.
    pub fn touches(&self, id: BodyId, mut pred: impl FnMut(Tag) -> bool) -> bool {
        for pair in self.world.narrow_phase.contact_pairs_with(id.collider) {
            if !pair.has_any_active_contact() {
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
