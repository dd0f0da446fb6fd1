//! `filling`: concave filling, the seed paper's Experiment 1, with its known failure fixed.
//!
//! Each robot, on its own and without messages:
//!
//! 1. **search / approach**: steers toward the object's beacon light (the light hangs above the
//!    object; its bearing from the light ring, [`light_bearing`]); random walk while the ring
//!    shows no light above its ambient background (contrast below `light_contrast`).
//! 2. **follow**: on touching something that is *object-like* (see below), follows its edge with
//!    the **left-hand rule** (the edge stays on the robot's left), at about `follow_reading`.
//!    Where the edge turns away (a convex corner), it arcs left for up to `lost_s` to find it
//!    again, then approaches the light again.
//! 3. **check**: where the object surrounds the robot over more than pi, it stops and creeps
//!    into the spot, toward what its ring sees but does not yet touch (`creep_into_gaps`), so
//!    that it settles in a corner's apex rather than where it first felt the corner. The
//!    test, from the proximity ring: at least `stop_count` of 8 sensors (the seed's 4; scaled
//!    for other rings) read more than `fire_threshold` *and are object-like*. A flat wall
//!    never lights more than 3 of the 8 sensors at that threshold; the inside of a 90 degree
//!    corner, or a wall next to an attached robot, lights 4 or 5. A robot pressed on 2 sensors
//!    (`strong_count`) with a third firing also checks: in an obtuse corner only some headings
//!    light the 4th sensor, so the check swings the heading by `swing`.
//! 4. **attach**: if the test passes on at least a third of the ticks of the `hold_s` check
//!    (and the robot stays in contact), the robot asks to attach (`AttachCommand::Attach`,
//!    once snug) until `Readings::attached` says it worked, then turns its LEDs blue and
//!    stays: it is now part of the pseudo object. If attaching
//!    fails within `attach_timeout_s`, or the surround breaks during the check, it goes back to
//!    following and does not test again for `retry_s`.
//!
//! **The fix of the seed's failure** (robots that stop because neighbours, not the object,
//! surround them). Moving robots show red LEDs, attached ones blue; the object has its own
//! colour (`object_color`). With `filter_neighbours` (default), the robot reads its colour scan
//! ([`Readings::scan_color`], as Queiroz and MacRae's panoramic cameras): a proximity sensor
//! whose bearing falls on scan bins that show a *moving robot* (any colour but the object's,
//! blue, a wall's grey or nothing) within proximity range is explained by a neighbour and is not
//! object-like. Attached (blue) robots and the object itself are object-like. With
//! `require_object` (default) the stop test also needs the object's colour or a blue robot in
//! the scan within proximity range, so arena walls and their corners (grey) never make a robot
//! stop. Together with the `hold_s` persistence test while creeping, a robot stops only where
//! the object (or the pseudo object) really surrounds it. Robots tell neighbour from object by
//! colour only, as a real robot would. `perception = "camera"` reads the colour-blob camera
//! instead (LED blobs; the object is seen only with the `camera = "oracle"` ablation).
//! `filter_neighbours = false, require_object = false, hold_s = 0` reproduces the seed's rule,
//! with the seed's sensors only (proximity and light).

use crate::controller::{
    parse_params_with_defaults, Actuation, AttachCommand, Controller, ControllerFactory, RobotRng,
};
use crate::controllers::occlusion::{self, is_robot_colour, light_contrast};
use crate::geometry::{wrap_angle, Vec2};
use crate::ops;
use crate::scenario::Color;
use crate::sensors::{Readings, SensorLayout, SensorNeeds};
use rand::Rng;
use serde::{Deserialize, Serialize};
use std::f32::consts::{FRAC_PI_2, PI, TAU};
use std::sync::Arc;

/// Which camera tells neighbours from the object.
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum FillPerception {
    /// The colour scan (default).
    #[default]
    Scan,
    /// The colour-blob camera (LEDs; objects only with the oracle ablation).
    Camera,
}

/// Parameters of `filling` (all optional; defaults suit Khepera IV and the seed's objects).
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct Params {
    /// Speed toward the beacon (m/s). Default 0.1 (the seed's maximum).
    pub speed: f32,
    /// Speed following an edge (m/s). Default 0.1.
    pub follow_speed: f32,
    /// Speed of the random walk while the beacon is hidden (m/s). Default 0.1.
    pub walk_speed: f32,
    /// Mean seconds between random turns of the random walk. Default 5.
    pub turn_every_s: f32,
    /// Gain from heading error (rad) to turn rate (rad/s). Default 3.
    pub turn_gain: f32,
    /// Largest turn rate (rad/s). Default 3.
    pub max_turn: f32,
    /// Proximity reading above which a sensor counts as firing in the stop test. Default 0.05
    /// (within about 0.10 m of the body).
    pub fire_threshold: f32,
    /// Proximity readings at or below this are taken as nothing (sensor noise). Default 0.03.
    pub noise_floor: f32,
    /// Light-ring contrast (strongest reading above the mean of the weaker half) above which
    /// the beacon light counts as seen. Default 0.08.
    pub light_contrast: f32,
    /// Camera that tells neighbours from the object: `"scan"` (default) or `"camera"`.
    pub perception: FillPerception,
    /// Colour of the object. Default `green`.
    pub object_color: Color,
    /// With `require_object` and the scan: stop only where the object surrounds the robot, the
    /// largest gap (degrees) between scan bins that show the object's colour or an attached
    /// (blue) robot, which may hide the object, being at most this. A point lies inside the
    /// object's convex hull exactly when the object leaves no gap above 180 degrees, so this
    /// keeps robots from stopping outside the hull (against the outside of a U's back wall, or
    /// stacked past a shallow cavity's mouth). 0 turns the check off. Default 190 (one bin of
    /// slack).
    pub surround_gap_deg: f32,
    /// With the surround check on: where the object surrounds the robot, this many firing
    /// object-like sensors (of 8) suffice if one of them touches an attached (blue) robot: the
    /// filling front, such as the last row at a cavity's mouth, where the pseudo object
    /// surrounds the robot over about pi only. 0 turns it off. Default 3.
    pub front_count: u32,
    /// Firing object-like sensors (of 8; scaled for other rings) that make the object surround
    /// the robot over more than pi. Default 4 (the seed's).
    pub stop_count: u32,
    /// Reading above which a sensor counts as pressed against something. Default 0.7.
    pub strong_reading: f32,
    /// Pressed object-like sensors (of 8) that, with one sensor short of `stop_count` firing,
    /// start a check (pressed into an obtuse corner, only 3 sensors may reach the object).
    /// Default 2.
    pub strong_count: u32,
    /// Largest proximity reading kept on the left while following. Default 0.95 (a Khepera IV's
    /// gap of about 4.2 cm; at 0.85, 4.5 cm, followers in the seed's U often went round empty
    /// corners and gaps of the cavity for minutes without stopping).
    pub follow_reading: f32,
    /// Turn rate per unit of reading error while following (rad/s). Default 3 (results format
    /// 29; 2 before): at 2 a follower rounding the mouth of a notch 0.2 m wide swung wide,
    /// met its far side and followed that out, passing the notch by (a random notch 0.21 m
    /// wide got a robot in 4 runs of 30, now 30).
    pub follow_gain: f32,
    /// Reading ahead (within 50 degrees of the heading) that stops forward motion. Default 0.5.
    pub front_threshold: f32,
    /// Seconds of arcing left after losing the edge before approaching again. Default 4.
    pub lost_s: f32,
    /// Radius of that arc (m). Default 0.12.
    pub arc_radius: f32,
    /// Seconds of creeping into the spot during which the surround is checked. Default 4.5
    /// (results format 26; 1.5 before): the ring reads 1.0 at any gap under 4 cm, so a robot
    /// cannot tell a snug spot from one 2 cm short, and in 1.5 s it often stopped short (in a
    /// star's pockets 1.5 to 2 cm from both sides, the disc not wholly inside the hull); the
    /// longer creep closes that gap.
    pub hold_s: f32,
    /// Seconds to wait for the attachment before giving up. Default 3.
    pub attach_timeout_s: f32,
    /// Seconds without a new stop test after a failed one. Default 5.
    pub retry_s: f32,
    /// Creeping speed into the spot during the check (m/s). Default 0.04.
    pub creep_speed: f32,
    /// During the check, creep toward what the ring sees but does not yet touch (each
    /// object-like reading weighted by how far it is from pressed, `1 - reading`), so that a
    /// robot whose stop test passes with a corner's far wall still 10 cm ahead settles in the
    /// corner's apex. False: creep toward the summed readings, which the nearest wall
    /// dominates (the robot presses into the wall beside it and stops short of the apex).
    /// Default true (`fill-transport` sets false: its figures were measured so).
    pub creep_into_gaps: bool,
    /// Amplitude (rad) of the heading swing during the check. Default 0.25.
    pub swing: f32,
    /// Ignore proximity hits explained by moving (non-blue) neighbours seen by the camera.
    /// Default true.
    pub filter_neighbours: bool,
    /// Stop only with the object or an attached (blue) robot in camera sight within proximity
    /// range (body radius + proximity range + 0.02 from the robot's centre). Default true.
    pub require_object: bool,
    /// With `require_object`: instead, stop only with the object itself (not an attached
    /// robot) in sight, its nearest point within this distance (m) of the robot's centre. This
    /// bounds how deep attached robots stack on the object. Default none (`fill-transport`
    /// sets 0.21 m).
    pub object_reach: Option<f32>,
}

impl Default for Params {
    fn default() -> Self {
        Self {
            speed: 0.1,
            follow_speed: 0.1,
            walk_speed: 0.1,
            turn_every_s: 5.0,
            turn_gain: 3.0,
            max_turn: 3.0,
            fire_threshold: 0.05,
            noise_floor: 0.03,
            light_contrast: 0.08,
            perception: FillPerception::Scan,
            object_color: Color::Green,
            surround_gap_deg: 190.0,
            front_count: 3,
            stop_count: 4,
            strong_reading: 0.7,
            strong_count: 2,
            follow_reading: 0.95,
            follow_gain: 3.0,
            front_threshold: 0.5,
            lost_s: 4.0,
            arc_radius: 0.12,
            hold_s: 4.5,
            attach_timeout_s: 3.0,
            retry_s: 5.0,
            creep_speed: 0.04,
            creep_into_gaps: true,
            swing: 0.25,
            filter_neighbours: true,
            require_object: true,
            object_reach: None,
        }
    }
}

impl Params {
    /// Rejects values that make no sense (non-positive speeds and gains, negative times).
    pub fn validate(&self) -> Result<(), String> {
        let positive = [
            ("speed", self.speed),
            ("follow_speed", self.follow_speed),
            ("walk_speed", self.walk_speed),
            ("turn_every_s", self.turn_every_s),
            ("turn_gain", self.turn_gain),
            ("max_turn", self.max_turn),
            ("fire_threshold", self.fire_threshold),
            ("follow_reading", self.follow_reading),
            ("front_threshold", self.front_threshold),
            ("arc_radius", self.arc_radius),
            ("attach_timeout_s", self.attach_timeout_s),
            ("creep_speed", self.creep_speed),
        ];
        let non_negative = [
            ("follow_gain", self.follow_gain),
            ("noise_floor", self.noise_floor),
            ("light_contrast", self.light_contrast),
            ("lost_s", self.lost_s),
            ("hold_s", self.hold_s),
            ("retry_s", self.retry_s),
            ("swing", self.swing),
            ("surround_gap_deg", self.surround_gap_deg),
        ];
        crate::controller::check_params(&positive, &non_negative)?;
        if self.stop_count == 0 || self.stop_count > 8 {
            return Err(format!(
                "`stop_count` must be 1 to 8, got {}",
                self.stop_count
            ));
        }
        Ok(())
    }

    /// The sensors a filler with these parameters reads (besides what guides it).
    pub fn needs(&self) -> SensorNeeds {
        let seeing = self.filter_neighbours || self.require_object;
        SensorNeeds {
            proximity: true,
            light: true,
            beacon: false,
            camera: seeing && self.perception == FillPerception::Camera,
            scan: seeing && self.perception == FillPerception::Scan,
        }
    }
}

/// Builds the factory.
pub fn factory(
    params: Option<&toml::Table>,
    layout: &SensorLayout,
) -> Result<ControllerFactory, String> {
    let p: Params = parse_params_with_defaults(params)?;
    p.validate()?;
    let needs = p.needs();
    let (p, layout) = (Arc::new(p), Arc::new(layout.clone()));
    Ok(ControllerFactory::new(needs, move || {
        Box::new(Filling::shared(p.clone(), layout.clone()))
    }))
}

/// States of a filling robot.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FillState {
    /// Beacon unknown: random walk.
    Search,
    /// Steering toward the beacon.
    Approach,
    /// Following an edge with the left-hand rule.
    Follow,
    /// Lost the edge: arcing left to find it again.
    Arc,
    /// Surrounded: creeping into the spot while the surround is checked.
    Check,
    /// Asking to attach.
    Attach,
    /// Attached: part of the pseudo object.
    Stopped,
}

impl FillState {
    /// Short name for viewers and metrics.
    pub fn name(self) -> &'static str {
        match self {
            FillState::Search => "search",
            FillState::Approach => "approach",
            FillState::Follow => "follow",
            FillState::Arc => "arc",
            FillState::Check => "check",
            FillState::Attach => "attach",
            FillState::Stopped => "stopped",
        }
    }
}

/// What the proximity ring and camera say this tick.
#[derive(Debug, Clone, Copy, Default)]
struct Percept {
    /// Firing object-like sensors that touch an attached (blue) robot.
    blue: usize,
    /// The object surrounds the robot (the surround check passed, and is on).
    inside: bool,
    /// Summed vector of object-like readings (robot frame).
    obj: Vec2,
    /// Summed vector of object-like readings above the noise floor, each weighted by
    /// `1 - reading`: toward what is seen but not touched (robot frame).
    gaps: Vec2,
    /// Largest object-like reading.
    obj_max: f32,
    /// Object-like sensors above the firing threshold.
    count: usize,
    /// Object-like sensors above `strong_reading`.
    strong: usize,
    /// Summed vector of readings explained by moving neighbours.
    nb: Vec2,
    /// Largest reading within 50 degrees of the heading (anything).
    front: f32,
    /// The object or an attached robot is in camera sight within proximity range.
    object_seen: bool,
}

/// The filling behaviour, guided by a bearing supplied each tick (the beacon light for
/// `filling`, the object's centre for `fill-transport`). Embeddable.
#[derive(Debug, Clone)]
pub struct Filler {
    /// Shared by the group's robots.
    p: Arc<Params>,
    layout: Arc<SensorLayout>,
    state: FillState,
    since_s: f32,
    last_s: f32,
    /// Last tick with object-like contact (s).
    contact_s: f32,
    /// Last tick the surround held during a check (s).
    held_s: f32,
    /// No stop test before this time (s).
    retry_until: f32,
    walk_turn: f32,
    walk_left_s: f32,
    /// Angle swept around the reference point since the first contact (rad).
    circled: f32,
    /// Whether the robot has touched something object-like yet.
    touched: bool,
    last_angle: Option<f32>,
    stop_needed: usize,
    strong_needed: usize,
    /// Firing sensors that suffice at the filling front (0: off).
    front_needed: usize,
    /// Whether the stop test runs (off: follow edges for ever, as pushers do).
    stopping: bool,
    /// Ticks of the current check, and how many of them passed the stop test.
    checks: u32,
    passes: u32,
}

impl Filler {
    /// A filler with parameters `p` for robots with `layout`.
    pub fn new(p: Params, layout: &SensorLayout) -> Filler {
        Filler::shared(Arc::new(p), Arc::new(layout.clone()))
    }

    /// [`Filler::new`] with parameters and layout shared by every robot of a group.
    pub fn shared(p: Arc<Params>, layout: Arc<SensorLayout>) -> Filler {
        let n = layout.proximity_angles.len().max(1);
        let stop_needed = ((p.stop_count as usize * n) as f32 / 8.0).ceil() as usize;
        let strong_needed = ((p.strong_count as usize * n) as f32 / 8.0).ceil().max(1.0) as usize;
        let front_needed = ((p.front_count as usize * n) as f32 / 8.0).ceil() as usize;
        Filler {
            p,
            layout,
            state: FillState::Approach,
            since_s: 0.0,
            last_s: 0.0,
            contact_s: f32::NEG_INFINITY,
            held_s: 0.0,
            retry_until: f32::NEG_INFINITY,
            walk_turn: 0.0,
            walk_left_s: 0.0,
            circled: 0.0,
            touched: false,
            last_angle: None,
            stop_needed: stop_needed.max(1),
            stopping: true,
            checks: 0,
            passes: 0,
            strong_needed,
            front_needed,
        }
    }

    /// Turns the stop test on or off (off: the robot only approaches and follows edges).
    pub fn set_stopping(&mut self, on: bool) {
        self.stopping = on;
    }

    /// Current state.
    pub fn fill_state(&self) -> FillState {
        self.state
    }

    /// Whether the robot has touched something object-like yet.
    pub fn touched(&self) -> bool {
        self.touched
    }

    /// This tick's direction (rad, world frame) of the robot from the reference point given
    /// to [`Filler::step_guided`], once it has touched something object-like.
    pub fn around(&self) -> Option<f32> {
        self.last_angle
    }

    /// Angle (rad, counter-clockwise positive) swept around the reference point given to
    /// [`Filler::step_guided`] since the robot first touched something object-like.
    pub fn circled(&self) -> f32 {
        self.circled
    }

    /// Lets a stopped filler move again: it approaches the object and follows edges anew (a
    /// robot that let go of the object and lost it).
    pub fn release(&mut self) {
        if self.state == FillState::Stopped {
            self.state = FillState::Approach;
        }
    }

    /// Puts the filler in the stopped state, as if it had attached (unit tests of controllers
    /// built on it).
    #[cfg(test)]
    pub(crate) fn stop_for_test(&mut self) {
        self.state = FillState::Stopped;
    }

    fn set_state(&mut self, s: FillState, now: f32) {
        if s != self.state {
            self.state = s;
            self.since_s = now;
        }
    }

    fn twist(&self, forward: f32, turn: f32) -> Actuation {
        let t = turn.clamp(-self.p.max_turn, self.p.max_turn);
        Actuation::from_twist(forward, t, &self.layout)
    }

    /// Whether colour `c` is the object or an attached robot (object-like).
    fn object_like(&self, c: Color) -> bool {
        c == self.p.object_color || c == Color::Blue
    }

    /// Whether the camera sees the object (or, without `object_reach`, an attached robot) near
    /// enough for the stop test.
    fn object_seen(&self, r: &Readings) -> bool {
        let reach = self.layout.radius + self.layout.proximity_range + 0.02;
        let obj = self.p.object_color;
        match self.p.perception {
            FillPerception::Scan => r
                .scan_color
                .iter()
                .zip(&r.scan_range)
                .any(|(c, d)| match self.p.object_reach {
                    Some(dd) => *c == obj && *d <= dd,
                    None => self.object_like(*c) && *d <= reach,
                }),
            FillPerception::Camera => r.blobs.iter().any(|b| match self.p.object_reach {
                Some(dd) => b.color == obj && b.distance <= dd,
                None => {
                    // LED blobs are robot centres; object blobs (oracle) surface points.
                    let d = if b.color == obj {
                        b.distance
                    } else {
                        b.distance - self.layout.radius
                    };
                    self.object_like(b.color) && d <= reach
                }
            }),
        }
    }

    /// Whether the object's colour surrounds the robot in the scan (see
    /// `Params::surround_gap_deg`); true when the check is off or there is no scan.
    fn object_surrounds(&self, r: &Readings) -> bool {
        let n = r.scan_color.len();
        if self.p.surround_gap_deg <= 0.0 || self.p.perception != FillPerception::Scan || n == 0 {
            return true;
        }
        let bins: Vec<usize> = (0..n)
            .filter(|i| self.object_like(r.scan_color[*i]))
            .collect();
        let (Some(first), Some(last)) = (bins.first(), bins.last()) else {
            return false;
        };
        let mut gap = first + n - last;
        for w in bins.windows(2) {
            gap = gap.max(w[1] - w[0]);
        }
        gap as f32 * 360.0 / n as f32 <= self.p.surround_gap_deg
    }

    /// Whether a proximity hit at bearing `a` (robot frame) falls on scan bins showing an
    /// attached (blue) robot within proximity range.
    fn blue_at(&self, r: &Readings, a: f32) -> bool {
        let reach = self.layout.radius + self.layout.proximity_range + 0.02;
        let half = PI / self.layout.scan_angles.len().max(1) as f32 + 0.15;
        r.scan_color
            .iter()
            .zip(&r.scan_range)
            .zip(&self.layout.scan_angles)
            .any(|((c, d), b)| *c == Color::Blue && *d <= reach && wrap_angle(a - b).abs() <= half)
    }

    /// Whether a proximity hit at bearing `a` (robot frame) is explained by a moving neighbour.
    fn neighbour_at(&self, r: &Readings, a: f32) -> bool {
        let reach = self.layout.radius + self.layout.proximity_range + 0.02;
        let rad = self.layout.radius;
        let obj = self.p.object_color;
        match self.p.perception {
            FillPerception::Scan => {
                let half = PI / self.layout.scan_angles.len().max(1) as f32 + 0.15;
                r.scan_color
                    .iter()
                    .zip(&r.scan_range)
                    .zip(&self.layout.scan_angles)
                    .any(|((c, d), b)| {
                        is_robot_colour(*c, obj)
                            && *c != Color::Blue
                            && *d <= reach
                            && wrap_angle(a - b).abs() <= half
                    })
            }
            FillPerception::Camera => r.blobs.iter().any(|b| {
                if !is_robot_colour(b.color, obj) || b.color == Color::Blue {
                    return false;
                }
                let centre = b.distance.max(rad);
                if centre - rad > reach {
                    return false;
                }
                let half = ops::asin((rad / centre).min(1.0)) + 0.15;
                wrap_angle(a - b.bearing).abs() <= half
            }),
        }
    }

    fn perceive(&self, r: &Readings) -> Percept {
        let mut out = Percept {
            object_seen: !self.p.require_object
                || (self.object_seen(r) && self.object_surrounds(r)),
            inside: self.p.require_object
                && self.p.surround_gap_deg > 0.0
                && self.p.perception == FillPerception::Scan
                && self.object_surrounds(r),
            ..Percept::default()
        };
        for (v, a) in r.proximity.iter().zip(&self.layout.proximity_angles) {
            if *v <= self.p.noise_floor {
                continue;
            }
            let dir = ops::unit(*a);
            if wrap_angle(*a).abs() < 0.88 {
                out.front = out.front.max(*v);
            }
            if self.p.filter_neighbours && self.neighbour_at(r, *a) {
                out.nb += dir * *v;
            } else {
                out.obj += dir * *v;
                out.gaps += dir * (1.0 - v.min(1.0));
                out.obj_max = out.obj_max.max(*v);
                if *v > self.p.fire_threshold {
                    out.count += 1;
                    if self.front_needed > 0 && self.blue_at(r, *a) {
                        out.blue += 1;
                    }
                }
                if *v >= self.p.strong_reading {
                    out.strong += 1;
                }
            }
        }
        out
    }

    /// Whether the stop test passes on this percept.
    fn surrounded(&self, pc: &Percept) -> bool {
        let front =
            self.front_needed > 0 && pc.inside && pc.blue > 0 && pc.count >= self.front_needed;
        (pc.count >= self.stop_needed || front) && pc.object_seen
    }

    /// Whether a check is worth starting: surrounded, or pressed against something over 3
    /// sensors (an obtuse corner shows its 4th sensor only at some headings; the check turns
    /// the robot to look).
    fn candidate(&self, pc: &Percept) -> bool {
        self.surrounded(pc)
            || (pc.count + 1 >= self.stop_needed
                && pc.strong >= self.strong_needed
                && pc.object_seen)
    }

    /// Left-hand edge following on object-like readings; anything ahead stops forward motion.
    fn follow(&self, pc: &Percept) -> Actuation {
        let beta = ops::angle_of(pc.obj);
        let err = wrap_angle(beta - FRAC_PI_2);
        let mut turn = self.layout.turn_gain(self.p.turn_gain) * err
            + self.p.follow_gain * (self.p.follow_reading - pc.obj_max);
        let mut fwd = self.p.follow_speed * (1.0 - err.abs() / PI).max(0.2);
        if pc.front > self.p.front_threshold {
            fwd = 0.0;
            turn = turn.min(-0.5 * self.p.max_turn);
        }
        self.twist(fwd, turn)
    }

    /// Toward `target` (robot-frame bearing), or a random walk without one; around neighbours.
    fn approach(&mut self, r: &Readings, rng: &mut RobotRng, target: Option<f32>) -> Actuation {
        let dt = (r.time_s - self.last_s).max(0.0);
        let (fwd, turn) = match target {
            Some(b) => {
                let fwd = if b.abs() > 1.2 {
                    0.0
                } else {
                    self.p.speed * ops::cos(b).max(0.0)
                };
                (fwd, self.layout.turn_gain(self.p.turn_gain) * b)
            }
            None => {
                if self.walk_left_s > 0.0 {
                    self.walk_left_s -= dt;
                    (self.p.walk_speed * 0.3, self.walk_turn)
                } else {
                    if rng.random::<f32>() < dt / self.p.turn_every_s {
                        self.walk_left_s = rng.random_range(0.3..1.5);
                        self.walk_turn = if rng.random::<bool>() { 1.5 } else { -1.5 };
                    }
                    (self.p.walk_speed, 0.0)
                }
            }
        };
        self.twist(fwd, turn)
    }

    /// One tick. `target`: bearing (robot frame) to steer toward when not touching anything
    /// (None: random walk). `centre`: a world point to count the angle swept around while
    /// following (the object's centre), if known.
    pub fn step_guided(
        &mut self,
        r: &Readings,
        rng: &mut RobotRng,
        target: Option<f32>,
        centre: Option<Vec2>,
    ) -> Actuation {
        let now = r.time_s;
        if self.state == FillState::Stopped || (r.attached && self.state == FillState::Attach) {
            self.set_state(FillState::Stopped, now);
            self.last_s = now;
            return Actuation {
                led: Color::Blue,
                ..Actuation::default()
            };
        }
        let pc = self.perceive(r);
        let contact = pc.obj_max > 0.0;
        if contact {
            self.contact_s = now;
        }
        // Angle swept around the centre since the robot first touched something object-like.
        if contact {
            self.touched = true;
        }
        match (self.touched, centre) {
            (true, Some(c)) => {
                let d = r.pose.position() - c;
                let a = ops::angle_of(d);
                if let Some(last) = self.last_angle {
                    self.circled += wrap_angle(a - last);
                }
                self.last_angle = Some(a);
            }
            _ => self.last_angle = None,
        }

        let mut hops = 0;
        let act = loop {
            hops += 1;
            if hops > 4 {
                break self.twist(0.0, 0.0);
            }
            match self.state {
                FillState::Search | FillState::Approach => {
                    if contact {
                        self.set_state(FillState::Follow, now);
                        continue;
                    }
                    let st = if target.is_some() {
                        FillState::Approach
                    } else {
                        FillState::Search
                    };
                    self.set_state(st, now);
                    let mut a = self.approach(r, rng, target);
                    // A moving neighbour ahead: turn right in place (pass it on the outside).
                    if pc.nb.x > 0.3 && pc.front > self.p.front_threshold * 0.5 {
                        a = self.twist(0.0, -0.5 * self.p.max_turn);
                    }
                    break a;
                }
                FillState::Follow => {
                    if self.stopping && now >= self.retry_until && self.candidate(&pc) {
                        self.held_s = now;
                        self.checks = 0;
                        self.passes = 0;
                        self.set_state(FillState::Check, now);
                        continue;
                    }
                    if !contact {
                        self.set_state(FillState::Arc, now);
                        continue;
                    }
                    break self.follow(&pc);
                }
                FillState::Arc => {
                    if contact {
                        self.set_state(FillState::Follow, now);
                        continue;
                    }
                    if now - self.since_s >= self.p.lost_s {
                        self.set_state(FillState::Approach, now);
                        continue;
                    }
                    if pc.front > self.p.front_threshold {
                        break self.twist(0.0, -0.5 * self.p.max_turn);
                    }
                    let fwd = self.p.follow_speed * 0.8;
                    break self.twist(fwd, fwd / self.p.arc_radius);
                }
                FillState::Check | FillState::Attach => {
                    if pc.count + 1 >= self.stop_needed && pc.object_seen {
                        self.held_s = now;
                    } else if now - self.held_s > 0.35 {
                        self.retry_until = now + self.p.retry_s;
                        self.set_state(FillState::Follow, now);
                        continue;
                    }
                    let t = now - self.since_s;
                    if self.state == FillState::Check {
                        self.checks += 1;
                        if self.surrounded(&pc) {
                            self.passes += 1;
                        }
                        if t >= self.p.hold_s {
                            // Surrounded for at least a third of the check: attach.
                            if self.passes * 3 >= self.checks && self.passes > 0 {
                                self.set_state(FillState::Attach, now);
                            } else {
                                self.retry_until = now + self.p.retry_s;
                                self.set_state(FillState::Follow, now);
                                continue;
                            }
                        }
                    } else if t > self.p.attach_timeout_s {
                        self.retry_until = now + self.p.retry_s;
                        self.set_state(FillState::Follow, now);
                        continue;
                    }
                    // Creep into the spot, swinging the heading by `swing` so that the ring
                    // samples it at all offsets.
                    let toward = if self.p.creep_into_gaps && pc.gaps.length() > 0.05 {
                        pc.gaps
                    } else {
                        pc.obj
                    };
                    let beta = if toward.length() > 1e-6 {
                        ops::angle_of(toward)
                    } else {
                        0.0
                    };
                    let swing = if self.state == FillState::Check {
                        self.p.swing * ops::sin(TAU * t / self.p.hold_s.max(0.5))
                    } else {
                        0.0
                    };
                    let fwd = self.p.creep_speed * ops::cos(beta).max(0.0);
                    let mut a = self.twist(
                        fwd,
                        self.layout.turn_gain(0.5 * self.p.turn_gain) * (beta + swing),
                    );
                    // Attach once snug (pressed on more sensors than a check needs), or after
                    // half the time-out if the robot cannot get closer.
                    let snug = pc.strong > self.strong_needed;
                    if self.state == FillState::Attach
                        && (snug || t > 0.5 * self.p.attach_timeout_s)
                    {
                        a.attach = AttachCommand::Attach;
                    }
                    break a;
                }
                FillState::Stopped => {
                    break Actuation::default();
                }
            }
        };
        self.last_s = now;
        let led = if self.state == FillState::Stopped {
            Color::Blue
        } else {
            Color::Red
        };
        act.with_led(led)
    }
}

/// The `filling` controller: a [`Filler`] guided by the object's beacon light.
#[derive(Debug, Clone)]
pub struct Filling {
    filler: Filler,
    layout: Arc<SensorLayout>,
}

impl Filling {
    /// A controller with parameters `p` for robots with `layout`.
    pub fn new(p: Params, layout: &SensorLayout) -> Filling {
        Filling::shared(Arc::new(p), Arc::new(layout.clone()))
    }

    /// [`Filling::new`] with parameters and layout shared by every robot of a group.
    pub fn shared(p: Arc<Params>, layout: Arc<SensorLayout>) -> Filling {
        Filling {
            filler: Filler::shared(p, layout.clone()),
            layout,
        }
    }
}

/// Bearing (robot frame) of a light on the ring, if the ring's contrast (see
/// [`light_contrast`]) exceeds `threshold`.
pub fn light_bearing(r: &Readings, layout: &SensorLayout, threshold: f32) -> Option<f32> {
    let contrast = light_contrast(&r.light);
    if contrast <= threshold {
        return None;
    }
    occlusion::light_bearing_with(&r.light, &layout.light_angles, contrast)
}

impl Controller for Filling {
    fn step(&mut self, r: &Readings, rng: &mut RobotRng) -> Actuation {
        let target = light_bearing(r, &self.layout, self.filler.p.light_contrast);
        self.filler.step_guided(r, rng, target, None)
    }

    fn state(&self) -> &'static str {
        self.filler.state.name()
    }
}

/// A full turn (rad), for callers counting laps with [`Filler::circled`].
pub const FULL_TURN: f32 = TAU;
