//! `fill-transport`: the whole mission in one run. Robots fill the cavity of a movable concave
//! object; the others then carry the resulting pseudo object (object plus attached robots) to
//! the goal by occlusion-based pushing.
//!
//! Each robot starts as a **filler** ([`Filler`], as in `filling`) guided by the object's
//! centre (`Readings::beacon` and `Readings::pose`) instead of a beacon light: it drives to the
//! object, follows its edge with the left-hand rule and attaches where the object surrounds it
//! over more than pi (fillers may stack at most about two deep: `object_reach = 0.21` m). From
//! its first contact on, it sums the angle it sweeps around the object's centre.
//! **When filling is over** is decided by each robot alone, without a leader or messages: a
//! robot that has swept `laps` full turns (default 1) around the pseudo object without finding
//! a concave spot concludes that there is none left and becomes a **pusher** for good; so does a
//! robot whose lap has not advanced past its record by `stall_deg` for `stall_s` (a crowd of
//! fillers jammed around a small object never completes a lap, and nobody would push; a filler
//! that follows an obstacle or a wall as if it were the object goes back and forth). Pushers
//! run the `occlusion` controller ([`Occlusion`], beacon perception): they circle the pseudo
//! object and push where it hides the goal light (the ring's contrast low). Occlusion with
//! memory: a pusher remembers the goal's direction (world frame) from when it last saw it, and
//! takes a dark light ring as "hidden by the object" only if the object's centre lies within
//! `occluded_within_deg` of that direction (otherwise neighbours hide the goal, or the robot
//! stands on the goal's side: the pusher is told that the goal is not hidden, and does not
//! push; without relays only, see [`Params::occluded_within_deg`]). The lap also measures the
//! pseudo object: the pusher takes proximity hits as the object out to the farthest distance
//! from the centre at which the robot followed the edge, plus `reach_margin` (a fixed
//! `object_reach` too small for the pseudo object makes pushers near its ends take it for an
//! obstacle, lose it and crowd); with relays, the farthest point of the outline it followed
//! ([`Reach::Outline`]), so that an obstacle followed on the way does not count.
//! `pusher = "edge"` swaps the occlusion controller for the filler's own edge following.
//!
//! **Attached robots keep their wheels on the floor** (issue 10): braking with locked wheels
//! they would hold the pseudo object with up to their drive force each, and pushing along
//! whatever heading they stopped at they would drive it sideways. By default
//! (`attached = "push"`) a robot about to attach first turns in place to face the goal's axis
//! (within `align_deg`; it attaches only once it has seen the goal), so that its wheels roll
//! along the way the pseudo object will go; attached, it pushes along its heading toward the
//! goal's last seen direction while its heading stays within `push_within_deg` of the goal's
//! axis, and otherwise coasts with its motors off (its wheels roll along its heading and skid
//! sideways, see [`Actuation::coast`](crate::controller::Actuation#structfield.coast)). It uses
//! its own readings only (pose, light), never the object's true motion. `"comply"` and
//! `"assist"` (the earlier default) estimate the robot's own velocity from its positioning
//! sensor instead and roll with it.
//!
//! **Its own heading, filtered.** Attached robots push, and robots about to attach align, by
//! comparing their heading with the goal's last seen direction, which is itself the light's
//! bearing plus the heading: both carry the positioning sensor's heading noise. Each robot fuses
//! the turn rate it commands with the sensor's heading ([`HeadingFilter`], gain `heading_gain`)
//! and decides from the estimate, as a real robot fuses odometry with its tracker.
//!
//! LEDs: attached robots blue (the fillers' "object" colour), fillers red, pushers red while
//! pushing and yellow otherwise (never blue, so fillers do not take pushers for the object).
//! With `relays = true` (sub-goal relays, [`relay`](super::relay)) a pusher that relays shows
//! the goal's colour instead (state `relay`); so does a filler on its way to the object (it has
//! not touched it yet) that loses the goal behind an obstacle: the robots all drive to the object
//! at once, and by the time filling is over the crowd hides the object from wanderers, so
//! relays formed later are few. A pusher that has seen a goal since the run began goes back to
//! the object whenever it sees it (`relay.gate_memory_s`, see [`Params::pusher`]). Attached
//! robots and robots about to attach take the goal to be what the camera last showed, a relay
//! or the real goal (results format 17; before, the light's last direction, which pinned
//! objects against the obstacle on the corner maps).

use crate::controller::{
    parse_params_with_defaults, Actuation, AttachCommand, Controller, ControllerFactory,
    HeadingFilter, RobotRng,
};
use crate::controllers::filling::{self, FillState, Filler, FULL_TURN};
use crate::controllers::occlusion::{self, light_contrast, Occlusion};
use crate::geometry::{wrap_angle, Vec2};
use crate::ops;
use crate::scenario::Color;
use crate::sensors::{Readings, SensorLayout, SensorNeeds};
use serde::{Deserialize, Serialize};
use std::f32::consts::{PI, TAU};
use std::sync::Arc;

/// Directions from the object's centre in which a filler records the outline it follows.
const OUTLINE_BINS: usize = 36;

/// Which behaviour pushes once filling is over.
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Pusher {
    /// The `occlusion` controller (parameters in `push`).
    #[default]
    Occlusion,
    /// The filler's own edge following (left-hand rule, neighbours told apart by the camera)
    /// with the stop test off; where the goal is hidden it pushes, aiming halfway between the
    /// object's centre and the goal's last seen direction.
    Edge,
}

/// How a filler that turns pusher measures the pseudo object (its pusher's `object_reach` is
/// the largest distance from the object's centre so found, plus `reach_margin`).
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Reach {
    /// The farthest distance at which it followed any edge during its lap, an obstacle's or a
    /// wall's included.
    Farthest,
    /// The farthest point of the outline it followed: in each 10 degree direction from the
    /// object's centre, the nearest distance at which it followed an edge. A stretch along an
    /// obstacle or a wall counts only in directions where the robot never followed anything
    /// nearer, such as the object itself.
    Outline,
}

/// What an attached robot does with its wheels (they stay on the floor, issue 10).
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum AttachedDrive {
    /// Wheels locked (zero wheel speed): brakes with up to the drive force.
    Brake,
    /// Motors off: the wheels roll along the heading (a small rolling resistance) and skid
    /// sideways.
    Coast,
    /// Drives along its heading toward the goal's last seen direction (`attached_push` of the
    /// pushing speed) while its heading lies within `push_within_deg` of the goal's axis;
    /// otherwise, or before it has seen the goal, coasts.
    #[default]
    Push,
    /// Rolls with the pseudo object: commands the forward speed and turn rate it measures for
    /// itself from its positioning sensor over `comply_s`; sideways it still skids.
    Comply,
    /// As `comply`, and while the pseudo object moves toward the goal's last seen direction
    /// (faster than `assist_speed` along it), also pushes toward the goal with `attached_push`
    /// of its top pushing speed along its heading: it helps the pushers, and never holds the
    /// object back.
    Assist,
}

/// Parameters of `fill-transport`: `fill` and `push` are the parameter tables of `filling` and
/// `occlusion`.
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct Params {
    /// Filling-phase parameters (as `filling`, with other defaults: `object_reach = 0.21`, so
    /// that attached robots stack at most about two deep on the object, `follow_reading =
    /// 0.85`, `follow_gain = 2`, `hold_s = 1.5` and `creep_into_gaps = false`, the values its
    /// figures were measured with).
    pub fill: filling::Params,
    /// Pushing-phase parameters (as `occlusion`).
    pub push: occlusion::Params,
    /// Full turns around the pseudo object without a concave spot after which a robot stops
    /// filling and pushes. Default 1.
    pub laps: f32,
    /// Pushing behaviour: `"occlusion"` (default) or `"edge"`.
    pub pusher: Pusher,
    /// `edge` pusher: pushing speed (m/s). Default 0.1.
    pub push_speed: f32,
    /// `edge` pusher: seconds the goal must stay hidden (visible) before pushing (following).
    /// Default 0.3.
    pub hidden_s: f32,
    /// Attached robots drive toward the goal's last seen direction, `attached_push` times
    /// their top pushing speed along their heading (signed by which way the goal lies), instead
    /// of braking with locked wheels: they push the pseudo object they are part of. 0 brakes.
    /// Default 0.3. In `assist` mode it is added only while the pseudo object moves toward
    /// the goal (seeds 1-10 with the preset, U / L / arc successes: assist 0.3 gave 9, 8, 6;
    /// assist 0.6 10, 3, 5; comply alone 8, 8, 8).
    pub attached_push: f32,
    /// Attached robots' wheels: `"push"` (default), `"coast"`, `"brake"`, `"comply"` or
    /// `"assist"`. Pushing attached robots turn a concave object that starts near a wall into
    /// it: the L and the H 0.25 m from a wall, seeds 1-10, arrive 1 and 0 times with `push`, 6
    /// and 6 with `comply`, which costs the open arena a third more time (results format 19;
    /// the guide's "Beyond the shipped files" page).
    pub attached: AttachedDrive,
    /// An attached robot whose heading has stayed more than `push_within_deg` off the goal's
    /// axis for this many seconds (the pseudo object turned under it) lets go, turns in place
    /// until it lies within `align_deg` of the axis, and attaches again: its wheels then roll,
    /// and push, along the way the object must go instead of skidding sideways. A robot that
    /// cannot attach again within `realign_timeout_s` (the object moved off) becomes a pusher.
    /// 0: never (results format 13 and earlier). Default 10.
    pub realign_s: f32,
    /// See `realign_s`. Default 10.
    pub realign_timeout_s: f32,
    /// `push`: an attached robot pushes only while its heading lies within this angle
    /// (degrees) of the goal's axis (toward the goal or away from it, driving backward); as the
    /// pseudo object turns further, its push would drive the object sideways, and it coasts.
    /// 180: always pushes. Default 25.
    pub push_within_deg: f32,
    /// Before attaching, a robot turns in place until its heading lies within this angle
    /// (degrees) of the goal's axis, so that its wheels roll, and push, along the way the pseudo
    /// object will go. 0: attaches at whatever heading it has. Default 10.
    pub align_deg: f32,
    /// A robot attaches only once it has seen the goal light (it keeps following the edge
    /// until then), so that it can align. Default true.
    pub attach_needs_goal: bool,
    /// `comply`: window (s) over which an attached robot estimates its own velocity. Default 2.
    pub comply_s: f32,
    /// `comply`: fraction of the measured velocity commanded. Default 1.
    pub comply_gain: f32,
    /// `comply`: attached robots heading within this angle (degrees) of the goal's last seen
    /// direction (or its opposite, driving backward) push at `attached_push` instead. 0: never.
    pub comply_push_deg: f32,
    /// `assist`: speed (m/s) toward the goal's last seen direction above which the pseudo
    /// object counts as moving toward the goal. Default 0.01.
    pub assist_speed: f32,
    /// Occlusion with memory: a pusher takes the goal as hidden *by the object* only if the
    /// object's centre lies within this angle (degrees) of the goal's last seen direction;
    /// otherwise (neighbours hide it, or the robot stands on the goal's side) it does not push.
    /// Default 90; 180 turns the check off. Without relays only for the `occlusion` pusher: with
    /// relays the goal is what the camera shows (the real goal or a relay), and the pusher's
    /// colour scan checks that the object lies toward it; the light's last direction would veto
    /// pushing toward a relay (results format 15). The `edge` pusher applies it with relays too.
    pub occluded_within_deg: f32,
    /// Seconds after which a filler whose lap has not advanced by `stall_deg` past its record
    /// (its farthest so far, either way round; going back and forth is no progress) becomes a
    /// pusher. Default 60 with relays, 120 without (results format 31; format 30: 60 either
    /// way; formats 19 to 29: 120 either way; format 18: 240 with relays; format 17 and
    /// earlier: 240 everywhere). With relays fillers also follow walls and obstacles they take
    /// for the object, and 60 delivers more at every swarm size: the obstacle design's six maps
    /// and seven shapes, seeds 1-10, 233 / 326 / 362 / 378 / 354 of 420 at N = 5 / 10 / 15 /
    /// 20 / 30 against 227 / 309 / 343 / 365 / 350 at 120
    /// (`experiments/fill-transport-stall-small-swarms.toml`,
    /// `experiments/fill-transport-stall-relays.toml`). Without relays 60 ends a crowd's
    /// circling of a small object sooner (the random draws' 3-point stars, 160 of 160 either
    /// way since results format 33, in 8-33 % less time; format 31: 146 of 160 against 141:
    /// `experiments/fill-transport-stall.toml`) but lost more than it
    /// gained over every study that runs `fill-transport` in the open (format 30: 5,720
    /// against 5,729 of 5,890; concave objects 0.25 m from a wall 77 against 90 of 150), so 120
    /// stays the default there.
    pub stall_s: Option<f32>,
    /// Lap progress (degrees around the object's centre) that counts as advancing. Default 30.
    pub stall_deg: f32,
    /// Margin (m) added to the farthest distance from the object's centre at which the robot
    /// followed the edge during its lap; the pusher's `object_reach` is at least this. Default
    /// 0.12.
    pub reach_margin: f32,
    /// Sub-goal relays for the pushers (`push.relays`, see the `relay` module); the attached
    /// robots' blue LEDs count as the object, and attached robots push toward the goal the
    /// camera last showed (the real goal or a relay), not the light's last direction. Default
    /// false.
    pub relays: bool,
    /// How a pusher measures the pseudo object: `"outline"` or `"farthest"` ([`Reach`]).
    /// Default `"outline"` with `relays`, `"farthest"` without. Where obstacles stand, fillers
    /// that the obstacle keeps from the object follow the obstacle round as if it were the
    /// object (on `qm-middle` with the H, 25 of 30 at 150 s in seed 3), and the farthest
    /// distance made pushers of 1.6 to 3.3 m reach circle round far from the object.
    /// Without relays `"farthest"` stays the default because the open-arena figures (results
    /// format 12) were measured with it.
    pub reach: Option<Reach>,
    /// Gain of the heading filter ([`HeadingFilter`]): the robot fuses its commanded turn rate
    /// with its positioning sensor's heading, and decides (goal direction, alignment before
    /// attaching, pushing while attached) from the estimate. 1 uses the sensor's heading as it
    /// comes (results format 7 and earlier). Default 0.3: on the U with heading noise of
    /// 0.2 rad, seeds 1-50 and 51-100, 37 and 37 successes at 1, 44 and 47 at 0.3 (0.15: 44,
    /// but 38 with the preset).
    pub heading_gain: f32,
}

impl Default for Params {
    fn default() -> Self {
        Self {
            fill: filling::Params {
                object_reach: Some(0.21),
                // `filling`'s 0.95 makes no clear difference here (seeds 1-50, results format
                // 16: 249 against 250 successes over the five concave scenarios); the figures
                // were measured at 0.85.
                follow_reading: 0.85,
                creep_into_gaps: false,
                // `filling`'s 4.5 s (results format 26) was not measured here; the figures
                // were measured at 1.5.
                hold_s: 1.5,
                // `filling`'s 3 (results format 29) was not measured here either; 2 was.
                follow_gain: 2.0,
                ..filling::Params::default()
            },
            push: occlusion::Params::default(),
            laps: 1.0,
            occluded_within_deg: 90.0,
            reach_margin: 0.12,
            stall_s: None,
            stall_deg: 30.0,
            pusher: Pusher::Occlusion,
            push_speed: 0.1,
            hidden_s: 0.3,
            attached_push: 0.3,
            attached: AttachedDrive::Push,
            realign_s: 10.0,
            realign_timeout_s: 10.0,
            push_within_deg: 25.0,
            align_deg: 10.0,
            attach_needs_goal: true,
            assist_speed: 0.01,
            comply_s: 2.0,
            comply_gain: 1.0,
            comply_push_deg: 0.0,
            relays: false,
            reach: None,
            heading_gain: 0.3,
        }
    }
}

impl Params {
    /// The pushers' `occlusion` parameters: `push`, with relays on if `relays` says so, the
    /// relays' patience 300 s unless set (relays form while the others fill), and their gate
    /// open to any goal seen since the run began unless set (`relay.gate_memory_s`): a pusher
    /// has been round the object and knows where it is; made to see a goal at that moment, the
    /// pushers of an object stuck beside an obstacle wandered away from it.
    pub fn pusher(&self) -> occlusion::Params {
        let mut push = self.push.clone();
        push.relays = self.with_relays();
        push.relay.patience_s.get_or_insert(RELAY_PATIENCE_S);
        push.relay.gate_memory_s.get_or_insert(f32::MAX);
        push
    }

    /// Whether pushers use sub-goal relays (`relays` or `push.relays`), which some defaults
    /// follow.
    fn with_relays(&self) -> bool {
        self.relays || self.push.relays
    }

    /// Seconds a filler's lap may stall before it pushes: `stall_s`, or its default (60 with
    /// relays, 120 without).
    pub fn stall_s(&self) -> f32 {
        self.stall_s
            .unwrap_or(if self.with_relays() { 60.0 } else { 120.0 })
    }

    /// How pushers measure the pseudo object: `reach`, or its default.
    pub fn reach(&self) -> Reach {
        self.reach.unwrap_or(if self.with_relays() {
            Reach::Outline
        } else {
            Reach::Farthest
        })
    }
}

/// Patience of the pushers' relays (s) unless set (`relay.patience_s`).
pub const RELAY_PATIENCE_S: f32 = 300.0;

/// Builds the factory.
pub fn factory(
    params: Option<&toml::Table>,
    layout: &SensorLayout,
) -> Result<ControllerFactory, String> {
    let mut p: Params = parse_params_with_defaults(params)?;
    p.push = p.pusher();
    p.fill.validate().map_err(|e| format!("fill: {e}"))?;
    p.push.validate().map_err(|e| format!("push: {e}"))?;
    let positive = |x: f32| x > 0.0 && x.is_finite();
    if !positive(p.laps) {
        return Err(format!("`laps` must be a positive number, got {}", p.laps));
    }
    if !(p.heading_gain > 0.0 && p.heading_gain <= 1.0) {
        return Err(format!(
            "`heading_gain` must be above 0 and at most 1, got {}",
            p.heading_gain
        ));
    }
    if !(positive(p.stall_s()) && positive(p.stall_deg)) {
        return Err(format!(
            "`stall_s` and `stall_deg` must be positive numbers, got {} and {}",
            p.stall_s(),
            p.stall_deg
        ));
    }
    if !(0.0..=1.0).contains(&p.reach_margin) {
        return Err(format!(
            "`reach_margin` must be 0 to 1 m, got {}",
            p.reach_margin
        ));
    }
    if !(p.realign_s >= 0.0 && p.realign_s.is_finite() && positive(p.realign_timeout_s)) {
        return Err(format!(
            "`realign_s` must be 0 or more and `realign_timeout_s` positive, got {} and {}",
            p.realign_s, p.realign_timeout_s
        ));
    }
    if !(0.0..=1.0).contains(&p.attached_push) {
        return Err(format!(
            "`attached_push` must be 0 to 1, got {}",
            p.attached_push
        ));
    }
    if !(positive(p.comply_s) && p.comply_s <= 60.0) {
        return Err(format!(
            "`comply_s` must be above 0 and at most 60 s, got {}",
            p.comply_s
        ));
    }
    if !(0.0..=2.0).contains(&p.comply_gain) {
        return Err(format!(
            "`comply_gain` must be 0 to 2, got {}",
            p.comply_gain
        ));
    }
    if !(0.0..=1.0).contains(&p.assist_speed) {
        return Err(format!(
            "`assist_speed` must be 0 to 1 m/s, got {}",
            p.assist_speed
        ));
    }
    if !(0.0..=180.0).contains(&p.push_within_deg) {
        return Err(format!(
            "`push_within_deg` must be 0 to 180, got {}",
            p.push_within_deg
        ));
    }
    if !(0.0..=90.0).contains(&p.align_deg) {
        return Err(format!("`align_deg` must be 0 to 90, got {}", p.align_deg));
    }
    if !(0.0..=90.0).contains(&p.comply_push_deg) {
        return Err(format!(
            "`comply_push_deg` must be 0 to 90, got {}",
            p.comply_push_deg
        ));
    }
    if !(0.0..=180.0).contains(&p.occluded_within_deg) {
        return Err(format!(
            "`occluded_within_deg` must be 0 to 180, got {}",
            p.occluded_within_deg
        ));
    }
    let fill_needs = p.fill.needs();
    let push_needs = Occlusion::needs(&p.push);
    let needs = SensorNeeds {
        proximity: true,
        light: true,
        beacon: true,
        camera: fill_needs.camera || push_needs.camera,
        scan: fill_needs.scan || push_needs.scan,
    };
    let shared = Shared::of(&p, layout);
    Ok(ControllerFactory::new(needs, move || {
        Box::new(FillTransport::with(&p, &shared))
    }))
}

/// What a group's robots share: the pusher's and the filler's parameters and the layout.
struct Shared {
    pusher: Arc<occlusion::Params>,
    fill: Arc<filling::Params>,
    layout: Arc<SensorLayout>,
}

impl Shared {
    fn of(p: &Params, layout: &SensorLayout) -> Shared {
        Shared {
            pusher: Arc::new(p.pusher()),
            fill: Arc::new(p.fill.clone()),
            layout: Arc::new(layout.clone()),
        }
    }
}

/// A robot's own recent poses (from its positioning sensor), for a least-squares estimate of
/// its velocity and turn rate.
#[derive(Debug, Clone)]
struct Track {
    window_s: f32,
    /// (time, x, y, unwrapped heading).
    poses: std::collections::VecDeque<[f32; 4]>,
}

impl Track {
    fn new(window_s: f32) -> Track {
        Track {
            window_s,
            poses: std::collections::VecDeque::new(),
        }
    }

    fn add(&mut self, r: &Readings) {
        let p = r.pose;
        let theta = match self.poses.back() {
            Some(last) => last[3] + wrap_angle(p.theta - last[3]),
            None => p.theta,
        };
        self.poses.push_back([r.time_s, p.x, p.y, theta]);
        while self
            .poses
            .front()
            .is_some_and(|f| r.time_s - f[0] > self.window_s + 1e-4)
        {
            self.poses.pop_front();
        }
    }

    /// World velocity (m/s), turn rate (rad/s) and mean heading over the window, once it spans
    /// at least half of it.
    fn velocity(&self) -> Option<(Vec2, f32, f32)> {
        let (first, last) = (self.poses.front()?, self.poses.back()?);
        if last[0] - first[0] < 0.5 * self.window_s {
            return None;
        }
        let n = self.poses.len() as f32;
        let mut mean = [0.0f32; 4];
        for p in &self.poses {
            for (m, x) in mean.iter_mut().zip(p) {
                *m += x / n;
            }
        }
        let (mut stt, mut sx, mut sy, mut sa) = (0.0f32, 0.0f32, 0.0f32, 0.0f32);
        for p in &self.poses {
            let dt = p[0] - mean[0];
            stt += dt * dt;
            sx += dt * (p[1] - mean[1]);
            sy += dt * (p[2] - mean[2]);
            sa += dt * (p[3] - mean[3]);
        }
        if stt <= 0.0 {
            return None;
        }
        Some((Vec2::new(sx / stt, sy / stt), sa / stt, mean[3]))
    }
}

/// Signed angle (rad) from heading `theta` to the nearer end of the axis through direction
/// `g`: to `g` itself or to its opposite (a robot can push either way, driving backward).
fn axis_offset(g: f32, theta: f32) -> f32 {
    let off = wrap_angle(g - theta);
    if off.abs() > PI / 2.0 {
        wrap_angle(off - PI)
    } else {
        off
    }
}

/// The fill-then-transport controller.
#[derive(Debug, Clone)]
pub struct FillTransport {
    filler: Filler,
    pusher: Occlusion,
    laps: f32,
    pushing: bool,
    occluded_within: f32,
    reach_margin: f32,
    stall_s: f32,
    stall_rad: f32,
    /// Lap progress watch: the lap's record (rad, either way round) and when it last grew by
    /// `stall_rad`.
    lap_anchor: Option<(f32, f32)>,
    /// Angle swept when the lap began: reset once, when the robot first declines to attach
    /// for want of a seen goal, so that it gets a full lap to see the goal and come back.
    lap_start: Option<f32>,
    /// How the pseudo object is measured.
    reach: Reach,
    /// Farthest distance from the object's centre (m) at which this robot followed an edge.
    farthest: f32,
    /// The outline it followed: for each of `OUTLINE_BINS` directions from the object's
    /// centre (world frame), the nearest distance (m) at which it followed an edge there
    /// (infinite where it never did).
    outline: [f32; OUTLINE_BINS],
    /// That distance, smoothed over the last ticks of edge following.
    dist_smooth: Option<f32>,
    /// Direction of the goal light (world frame, rad) when last seen.
    goal_dir: Option<f32>,
    pusher_kind: Pusher,
    push_speed: f32,
    hidden_s: f32,
    attached_push: f32,
    attached: AttachedDrive,
    push_within: f32,
    realign_s: f32,
    realign_timeout_s: f32,
    /// Attached and off the goal's axis since this time.
    misaligned_since: Option<f32>,
    /// Realigning (let go to turn in place) since this time.
    realigning_since: Option<f32>,
    align: f32,
    attach_needs_goal: bool,
    comply_push: f32,
    comply_gain: f32,
    assist_speed: f32,
    /// Own poses while attached, for the velocity estimate.
    track: Track,
    /// `edge` pusher: pushing now, and since when the goal has been hidden / visible.
    pushing_now: bool,
    hidden_since: Option<f32>,
    visible_since: Option<f32>,
    /// This tick's readings with the filtered heading (a buffer reused every tick).
    seen: Readings,
    /// Whether this tick's dark light ring is not the object's doing (occlusion with memory).
    veto: bool,
    layout: Arc<SensorLayout>,
    /// The robot's own heading, filtered.
    heading: HeadingFilter,
}

impl FillTransport {
    /// A controller with parameters `p` for robots with `layout`.
    pub fn new(p: Params, layout: &SensorLayout) -> FillTransport {
        FillTransport::with(&p, &Shared::of(&p, layout))
    }

    /// [`FillTransport::new`] with what a group's robots share.
    fn with(p: &Params, shared: &Shared) -> FillTransport {
        let reach = p.reach();
        let mut pusher = Occlusion::shared(shared.pusher.clone(), shared.layout.clone());
        pusher.add_relay_object_color(Color::Blue);
        FillTransport {
            filler: Filler::shared(shared.fill.clone(), shared.layout.clone()),
            pusher,
            laps: p.laps,
            pushing: false,
            occluded_within: p.occluded_within_deg.to_radians(),
            reach_margin: p.reach_margin,
            stall_s: p.stall_s(),
            stall_rad: p.stall_deg.to_radians(),
            lap_anchor: None,
            lap_start: None,
            reach,
            farthest: 0.0,
            outline: [f32::INFINITY; OUTLINE_BINS],
            dist_smooth: None,
            goal_dir: None,
            pusher_kind: p.pusher,
            push_speed: p.push_speed,
            hidden_s: p.hidden_s,
            attached_push: p.attached_push,
            attached: p.attached,
            push_within: p.push_within_deg.to_radians(),
            realign_s: p.realign_s,
            realign_timeout_s: p.realign_timeout_s,
            misaligned_since: None,
            realigning_since: None,
            align: p.align_deg.to_radians(),
            attach_needs_goal: p.attach_needs_goal,
            comply_push: p.comply_push_deg.to_radians(),
            comply_gain: p.comply_gain,
            assist_speed: p.assist_speed,
            track: Track::new(p.comply_s),
            pushing_now: false,
            hidden_since: None,
            visible_since: None,
            seen: Readings::default(),
            veto: false,
            layout: shared.layout.clone(),
            heading: HeadingFilter::new(p.heading_gain),
        }
    }

    /// Whether this robot has finished filling and now pushes.
    pub fn is_pusher(&self) -> bool {
        self.pushing
    }
}

impl FillTransport {
    /// Remembers where the goal was last seen and, when the light is hidden although the object
    /// is not between the robot and that direction, tells the pusher that the goal is not
    /// hidden by the object.
    fn filter_light(&mut self, r: &Readings) {
        self.veto = false;
        let threshold = self.pusher.params().lit_contrast;
        if let Some(b) = filling::light_bearing(r, &self.layout, threshold) {
            self.goal_dir = Some(wrap_angle(b + r.pose.theta));
            return;
        }
        let (Some(goal), Some(c)) = (self.goal_dir, r.beacon) else {
            return;
        };
        let to = c - r.pose.position();
        let centre_dir = ops::angle_of(to);
        self.veto = wrap_angle(centre_dir - goal).abs() > self.occluded_within;
    }
}

impl FillTransport {
    /// Wheel speeds of an attached robot (see [`AttachedDrive`]).
    fn attached_drive(&mut self, r: &Readings) -> Actuation {
        let push = |g: f32| {
            let v = self.attached_push * self.push_speed * ops::cos(g - r.pose.theta);
            Actuation::from_twist(v, 0.0, &self.layout)
        };
        match self.attached {
            AttachedDrive::Brake => Actuation::default(),
            AttachedDrive::Coast => Actuation::coasting(),
            AttachedDrive::Push => match self.goal_dir {
                Some(g) if axis_offset(g, r.pose.theta).abs() <= self.push_within => push(g),
                _ => Actuation::coasting(),
            },
            AttachedDrive::Comply | AttachedDrive::Assist => {
                self.track.add(r);
                if let Some(g) = self.goal_dir {
                    if axis_offset(g, r.pose.theta).abs() < self.comply_push {
                        return push(g);
                    }
                }
                let Some((vel, w, theta)) = self.track.velocity() else {
                    return Actuation::default();
                };
                let mut fwd = vel.dot(ops::unit(theta)) * self.comply_gain;
                if self.attached == AttachedDrive::Assist {
                    if let Some(g) = self.goal_dir {
                        if vel.dot(ops::unit(g)) > self.assist_speed {
                            fwd += self.attached_push * self.push_speed * ops::cos(g - theta);
                        }
                    }
                }
                Actuation::from_twist(fwd, w * self.comply_gain, &self.layout)
            }
        }
    }

    /// Ends filling: from now on the robot pushes, with the pseudo object's size as it measured it.
    fn start_pushing(&mut self) {
        self.pushing = true;
        self.filler.set_stopping(false);
        let size = match self.reach {
            Reach::Farthest => self.farthest,
            Reach::Outline => outline_reach(&self.outline),
        };
        let reach = self.pusher.object_reach().max(size + self.reach_margin);
        self.pusher.set_object_reach(reach);
    }

    /// A stopped filler's realignment (see `Params::realign_s`): `None` while it stays attached
    /// as it is (or once it has become a pusher, having lost the object).
    fn realign(&mut self, r: &Readings) -> Option<Actuation> {
        if self.realign_s <= 0.0 {
            return None;
        }
        let now = r.time_s;
        let g = self.goal_dir?;
        let e = axis_offset(g, r.pose.theta);
        let let_go = Actuation {
            attach: AttachCommand::Detach,
            ..Actuation::coasting()
        }
        .with_led(Color::Blue);
        let Some(t0) = self.realigning_since else {
            let off = r.attached && e.abs() > self.push_within;
            if !off {
                self.misaligned_since = None;
                return None;
            }
            let since = *self.misaligned_since.get_or_insert(now);
            if now - since < self.realign_s - 1e-4 {
                return None;
            }
            self.misaligned_since = None;
            self.realigning_since = Some(now);
            return Some(let_go);
        };
        if r.attached && now > t0 {
            // Attached again (the detach of the first tick has been applied by now).
            if e.abs() <= self.align {
                self.realigning_since = None;
                return None;
            }
            return Some(let_go);
        }
        if now - t0 > self.realign_timeout_s {
            self.realigning_since = None;
            self.filler.release();
            self.start_pushing();
            return None;
        }
        if e.abs() > 0.5 * self.align {
            let turn = (3.0 * e).clamp(-3.0, 3.0);
            return Some(Actuation::from_twist(0.0, turn, &self.layout).with_led(Color::Blue));
        }
        Some(
            Actuation {
                attach: AttachCommand::Attach,
                ..Actuation::default()
            }
            .with_led(Color::Blue),
        )
    }

    /// A robot about to attach: without a goal seen yet (and `attach_needs_goal`), it does not
    /// attach (the filler times out and follows on); otherwise it first turns in place until
    /// its heading lies within `align` of the goal's axis.
    fn before_attach(&self, r: &Readings, act: Actuation) -> Actuation {
        let Some(g) = self.goal_dir else {
            return if self.attach_needs_goal {
                Actuation {
                    attach: AttachCommand::Keep,
                    ..act
                }
            } else {
                act
            };
        };
        let e = axis_offset(g, r.pose.theta);
        if self.align > 0.0 && e.abs() > self.align {
            let turn = (3.0 * e).clamp(-3.0, 3.0);
            return Actuation::from_twist(0.0, turn, &self.layout).with_led(act.led);
        }
        act
    }

    /// The `edge` pusher: follow the pseudo object's edge; where the goal is hidden by it,
    /// push toward its centre.
    fn edge_push(&mut self, r: &Readings, rng: &mut RobotRng) -> Actuation {
        let now = r.time_s;
        let hidden = !r.light.is_empty()
            && !self.veto
            && light_contrast(&r.light) < self.pusher.params().dark_contrast;
        if hidden {
            self.visible_since = None;
            self.hidden_since.get_or_insert(now);
        } else {
            self.hidden_since = None;
            self.visible_since.get_or_insert(now);
        }
        let long = |since: Option<f32>| since.is_some_and(|t| now - t >= self.hidden_s - 1e-4);
        let touching = matches!(self.filler.fill_state(), FillState::Follow | FillState::Arc);
        if self.pushing_now && long(self.visible_since) {
            self.pushing_now = false;
        } else if !self.pushing_now && touching && long(self.hidden_since) {
            self.pushing_now = true;
        }
        let centre = r.beacon;
        let target = centre.map(|c| {
            let to = c - r.pose.position();
            wrap_angle(ops::angle_of(to) - r.pose.theta)
        });
        if self.pushing_now {
            if let Some(b) = target {
                // Push toward where the goal was last seen, as long as the object's centre is
                // ahead; without a memory of the goal, toward the centre.
                let aim = match self.goal_dir {
                    Some(g) => {
                        let rel = wrap_angle(g - r.pose.theta);
                        if wrap_angle(rel - b).abs() < 1.0 {
                            0.5 * (rel + b)
                        } else {
                            b
                        }
                    }
                    None => b,
                };
                let fwd = if aim.abs() < 0.5 {
                    self.push_speed
                } else {
                    0.0
                };
                let turn = (3.0 * aim).clamp(-3.0, 3.0);
                return Actuation::from_twist(fwd, turn, &self.layout).with_led(Color::Red);
            }
            self.pushing_now = false;
        }
        let act = self.filler.step_guided(r, rng, target, centre);
        act.with_led(Color::Yellow)
    }
}

/// The farthest point of an outline (see [`Reach::Outline`]): the largest of its finite
/// distances, 0 if it has none.
fn outline_reach(outline: &[f32]) -> f32 {
    outline
        .iter()
        .filter(|d| d.is_finite())
        .fold(0.0, |m: f32, d| m.max(*d))
}

impl Controller for FillTransport {
    fn step(&mut self, r: &Readings, rng: &mut RobotRng) -> Actuation {
        let mut seen = std::mem::take(&mut self.seen);
        seen.clone_from(r);
        seen.pose.theta = self.heading.update(r.pose.theta, r.time_s);
        let act = self.decide(&seen, rng);
        self.seen = seen;
        self.heading.commanded(&act, &self.layout);
        act
    }

    fn state(&self) -> &'static str {
        self.state_name()
    }
}

impl FillTransport {
    /// This tick's decision from readings `r` (the heading filtered).
    fn decide(&mut self, r: &Readings, rng: &mut RobotRng) -> Actuation {
        self.filter_light(r);
        if !self.pushing && self.pusher.params().relays {
            // Relays form on the way to the object too: a filler that has not reached it yet
            // wanders as far as the relay rule is concerned.
            let free = !self.filler.touched()
                && matches!(
                    self.filler.fill_state(),
                    FillState::Approach | FillState::Search
                );
            if let Some(act) = self.pusher.relay_only(r, rng, free) {
                return act;
            }
            // With relays the goal is what the camera shows (the real goal or a relay):
            // attached robots push, and robots about to attach align, toward it, not toward
            // the light's last direction, which an obstacle may stand across.
            if let Some(g) = self.pusher.goal_direction(r) {
                self.goal_dir = Some(g);
            }
        }
        if !self.pushing {
            let centre = r.beacon;
            let target = centre.map(|c| {
                let to = c - r.pose.position();
                wrap_angle(ops::angle_of(to) - r.pose.theta)
            });
            let mut act = self.filler.step_guided(r, rng, target, centre);
            if act.attach == AttachCommand::Attach {
                if self.goal_dir.is_none() && self.attach_needs_goal && self.lap_start.is_none() {
                    self.lap_start = Some(self.filler.circled());
                    self.lap_anchor = None;
                }
                act = self.before_attach(r, act);
            }
            if self.filler.fill_state() == FillState::Stopped {
                if let Some(act) = self.realign(r) {
                    return act;
                }
                if !self.pushing {
                    return self.attached_drive(r).with_led(act.led);
                }
            }
            let st = self.filler.fill_state();
            if let (Some(c), FillState::Follow | FillState::Arc) = (centre, st) {
                // Smoothed: the maximum of noisy distances would grow with the noise.
                let d = (c - r.pose.position()).length();
                let s = match self.dist_smooth {
                    Some(s) if (d - s).abs() < 0.1 => s + 0.2 * (d - s),
                    _ => d,
                };
                self.dist_smooth = Some(s);
                self.farthest = self.farthest.max(s);
                // The filler's own angle round the centre this tick (it sums the lap from it).
                if let Some(at) = self.filler.around() {
                    let at = at + PI;
                    let bin = ((at / TAU * OUTLINE_BINS as f32) as usize).min(OUTLINE_BINS - 1);
                    self.outline[bin] = self.outline[bin].min(s);
                }
            } else {
                self.dist_smooth = None;
            }
            let lap = self.filler.circled() - self.lap_start.unwrap_or(0.0);
            // Progress is a new record of the lap: a filler that goes back and forth (round
            // an obstacle it took for the object, then along a wall and back) never completes
            // one, and stalls.
            let stalled = self.filler.touched() && {
                let (best, t) = *self.lap_anchor.get_or_insert((lap.abs(), r.time_s));
                if lap.abs() >= best + self.stall_rad {
                    self.lap_anchor = Some((lap.abs(), r.time_s));
                    false
                } else {
                    r.time_s - t >= self.stall_s
                }
            };
            let done = (lap.abs() >= self.laps * FULL_TURN || stalled)
                && matches!(st, FillState::Follow | FillState::Arc);
            if !done || st == FillState::Stopped {
                return act;
            }
            self.start_pushing();
        }
        if self.pusher_kind == Pusher::Edge {
            return self.edge_push(r, rng);
        }
        if self.veto && !self.pusher.params().relays {
            self.pusher.veto_hidden();
        }
        let act = self.pusher.step(r, rng);
        let led = if self.pusher.is_relay() {
            act.led
        } else if self.pusher.is_pushing() {
            Color::Red
        } else {
            Color::Yellow
        };
        act.with_led(led)
    }

    fn state_name(&self) -> &'static str {
        if !self.pushing && self.pusher.is_relay() {
            "relay"
        } else if self.pushing && self.pusher_kind == Pusher::Edge {
            if self.pushing_now {
                "push"
            } else {
                "push-follow"
            }
        } else if self.realigning_since.is_some() {
            "realign"
        } else if self.pushing {
            match self.pusher.state() {
                "search" => "push-search",
                "approach" => "push-approach",
                "circle" => "push-circle",
                "escape" => "push-escape",
                other => other,
            }
        } else {
            self.filler.fill_state().name()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Pose;
    use crate::robot::RobotModel;
    use crate::scenario::SensorConfig;
    use rand::SeedableRng;
    use std::f32::consts::{FRAC_PI_2, TAU};

    #[test]
    fn setting_one_fill_key_keeps_the_other_fill_defaults_of_fill_transport() {
        // A user who sets one key of the nested `fill` table gets fill-transport's defaults
        // for the rest, not `filling`'s (object_reach none, follow_reading 0.95).
        let t: toml::Table = toml::from_str("fill = { creep_speed = 0.03 }").unwrap();
        let p: Params = parse_params_with_defaults(Some(&t)).unwrap();
        let d = Params::default();
        assert_eq!(p.fill.creep_speed, 0.03);
        assert_eq!(p.fill.object_reach, Some(0.21));
        assert_eq!(p.fill.object_reach, d.fill.object_reach);
        assert_eq!(p.fill.follow_reading, d.fill.follow_reading);
        assert_eq!(p.fill.creep_into_gaps, d.fill.creep_into_gaps);
        assert_eq!(p.fill.hold_s, 1.5);
        assert_eq!(p.fill.follow_gain, 2.0);
        // Unknown keys in a nested table are still errors.
        let t: toml::Table = toml::from_str("fill = { creep = 0.03 }").unwrap();
        let e = parse_params_with_defaults::<Params>(Some(&t)).unwrap_err();
        assert!(e.contains("creep"), "{e}");
    }

    /// Proximity readings of a robot with an edge close on its left (0.9 on the sensor
    /// nearest +90 degrees, nothing elsewhere).
    fn edge_on_the_left(layout: &SensorLayout) -> Vec<f32> {
        let left = (0..layout.proximity_angles.len())
            .min_by(|a, b| {
                let d = |i: &usize| wrap_angle(layout.proximity_angles[*i] - FRAC_PI_2).abs();
                d(a).total_cmp(&d(b))
            })
            // Cannot fail: a Khepera IV has 8 proximity sensors.
            .unwrap();
        let mut proximity = vec![0.0; layout.proximity_angles.len()];
        proximity[left] = 0.9;
        proximity
    }

    /// The pusher's `object_reach` of a filler that follows the object (0.35 m from its
    /// centre) over 60 degrees, an obstacle 1.5 m out back over those 60 degrees, then the
    /// object over a full lap, measuring the pseudo object by `reach`.
    fn reach_after_an_excursion(reach: Reach) -> f32 {
        let layout = SensorLayout::of(&RobotModel::khepera4(), &SensorConfig::default());
        let p = Params {
            reach: Some(reach),
            ..Params::default()
        };
        let mut ft = FillTransport::new(p, &layout);
        let mut rng = RobotRng::seed_from_u64(1);
        let proximity = edge_on_the_left(&layout);
        // 1 degree a tick: the object from 0 to 60 degrees, the obstacle back to 0, the
        // object from 0 on.
        for k in 0..500 {
            let (deg, radius) = match k {
                0..60 => (k, 0.35),
                60..120 => (120 - k, 1.5),
                _ => (k - 120, 0.35),
            };
            let a = (deg as f32).to_radians();
            let r = Readings {
                time_s: k as f32 * 0.1,
                proximity: proximity.clone(),
                light: vec![0.0; layout.light_angles.len()],
                pose: Pose::new(radius * ops::cos(a), radius * ops::sin(a), a + FRAC_PI_2),
                beacon: Some(Vec2::ZERO),
                ..Readings::default()
            };
            ft.step(&r, &mut rng);
            if ft.is_pusher() {
                return ft.pusher.object_reach();
            }
        }
        panic!("still filling after a lap");
    }

    #[test]
    fn the_outline_leaves_out_an_obstacle_followed_on_the_way() {
        // The outline's farthest point is the object's (0.35 m, plus the 0.12 m margin; the
        // pusher's default reach, 0.6 m, is larger); the farthest distance takes the obstacle
        // (1.5 + 0.12 m).
        let outline = reach_after_an_excursion(Reach::Outline);
        assert!((outline - 0.6).abs() < 1e-4, "outline reach {outline}");
        let farthest = reach_after_an_excursion(Reach::Farthest);
        assert!((farthest - 1.62).abs() < 0.01, "farthest reach {farthest}");
    }

    #[test]
    fn with_relays_pushers_measure_the_outline_and_remember_the_goal() {
        let p = Params {
            relays: true,
            ..Params::default()
        };
        assert_eq!(p.reach(), Reach::Outline);
        assert_eq!(p.pusher().relay.gate_memory_s, Some(f32::MAX));
        // Without relays, as results format 12 measured the open arena.
        assert_eq!(Params::default().reach(), Reach::Farthest);
        // Set by the user, kept.
        let mut set = p.clone();
        set.push.relay.gate_memory_s = Some(0.0);
        assert_eq!(set.pusher().relay.gate_memory_s, Some(0.0));
    }

    /// A stopped (attached) filler that has seen the goal along +x, its readings at time `t`
    /// with heading `theta_deg`.
    fn attached_filler() -> (FillTransport, SensorLayout) {
        let layout = SensorLayout::of(&RobotModel::khepera4(), &SensorConfig::default());
        let mut ft = FillTransport::new(Params::default(), &layout);
        ft.filler.stop_for_test();
        ft.goal_dir = Some(0.0);
        (ft, layout)
    }

    fn at(t: f32, theta_deg: f32, attached: bool, layout: &SensorLayout) -> Readings {
        Readings {
            time_s: t,
            proximity: vec![0.0; layout.proximity_angles.len()],
            light: vec![0.0; layout.light_angles.len()],
            pose: Pose::new(0.0, 0.0, theta_deg.to_radians()),
            beacon: Some(Vec2::new(-0.3, 0.0)),
            attached,
            ..Readings::default()
        }
    }

    #[test]
    fn an_attached_robot_turned_off_the_goal_axis_lets_go_turns_and_attaches_again() {
        let (mut ft, layout) = attached_filler();
        let mut rng = RobotRng::seed_from_u64(1);
        // 60 degrees off the axis (the pseudo object turned under it): it coasts for
        // `realign_s` (10 s), then lets go.
        let mut t = 0.0;
        let mut detached_at = None;
        while t < 20.0 {
            let act = ft.step(&at(t, 60.0, true, &layout), &mut rng);
            if act.attach == AttachCommand::Detach {
                detached_at = Some(t);
                break;
            }
            assert!(act.coast, "at {t} s a misaligned attached robot coasts");
            t += 0.1;
        }
        let t0 = detached_at.expect("never let go");
        assert!((9.9..10.2).contains(&t0), "let go at {t0} s");
        assert_eq!(ft.state(), "realign");
        // Detached, it turns in place toward the axis (clockwise: right wheel slower).
        let act = ft.step(&at(t0 + 0.1, 60.0, false, &layout), &mut rng);
        assert!(act.left > 0.0 && act.right < 0.0, "turns {act:?}");
        // Once on the axis (as its filtered heading has it) it attaches again, wheels still.
        let mut t = t0 + 0.2;
        loop {
            let act = ft.step(&at(t, 2.0, false, &layout), &mut rng);
            if act.attach == AttachCommand::Attach {
                assert_eq!((act.left, act.right), (0.0, 0.0));
                break;
            }
            assert!(t < t0 + 3.0, "not attached again at {t} s: {act:?}");
            t += 0.1;
        }
        // Attached again on the axis: it pushes toward the goal and stays attached.
        let act = ft.step(&at(t + 0.1, 2.0, true, &layout), &mut rng);
        assert_eq!(act.attach, AttachCommand::Keep);
        assert!(act.left > 0.0 && act.right > 0.0, "pushes {act:?}");
        assert_eq!(ft.state(), "stopped");
        assert!(!ft.is_pusher());
    }

    #[test]
    fn a_robot_that_cannot_attach_again_becomes_a_pusher() {
        let (mut ft, layout) = attached_filler();
        let mut rng = RobotRng::seed_from_u64(1);
        let mut t = 0.0;
        while ft.state() != "realign" {
            assert!(t < 20.0, "never let go");
            ft.step(&at(t, -90.0, true, &layout), &mut rng);
            t += 0.1;
        }
        // The object moved off: it never touches anything again.
        let start = t;
        while !ft.is_pusher() {
            assert!(t < start + 11.0, "still realigning at {t} s");
            ft.step(&at(t, 0.0, false, &layout), &mut rng);
            t += 0.1;
        }
        assert!(t > start + 9.9, "gave up after {} s", t - start);
        // Its filler moves again (the `edge` pusher follows edges with it).
        assert_ne!(ft.filler.fill_state(), FillState::Stopped);
        // With `realign_s = 0` an attached robot stays attached whatever its heading.
        let layout2 = layout.clone();
        let mut off = FillTransport::new(
            Params {
                realign_s: 0.0,
                ..Params::default()
            },
            &layout2,
        );
        off.filler.stop_for_test();
        off.goal_dir = Some(0.0);
        for k in 0..300 {
            let act = off.step(&at(k as f32 * 0.1, 60.0, true, &layout2), &mut rng);
            assert_eq!(act.attach, AttachCommand::Keep);
        }
    }

    #[test]
    fn a_filler_that_goes_back_and_forth_stalls_and_pushes() {
        // A filler that follows an edge round 120 degrees of the object's centre and back,
        // again and again (an obstacle taken for the object, then a wall back), never completes
        // a lap. Its lap progress is the record, so it stalls after `stall_s` (120 s without
        // relays, 60 s with) and pushes; counted as any swing of 30 degrees it would fill for
        // ever.
        let layout = SensorLayout::of(&RobotModel::khepera4(), &SensorConfig::default());
        for (relays, stall) in [(false, 120.0), (true, 60.0)] {
            let p = Params {
                relays,
                ..Params::default()
            };
            assert_eq!(p.stall_s(), stall);
            let t = stalls_after(FillTransport::new(p, &layout), &layout);
            assert!((stall..stall + 60.0).contains(&t), "pushes from {t} s");
        }
    }

    /// When a filler swinging 120 degrees round the object and back becomes a pusher (s).
    fn stalls_after(mut ft: FillTransport, layout: &SensorLayout) -> f32 {
        let mut rng = RobotRng::seed_from_u64(1);
        let proximity = edge_on_the_left(layout);
        let mut became = None;
        for k in 0..4000 {
            let t = k as f32 * 0.1;
            let a = TAU / 3.0 * 0.5 * (1.0 - ops::cos(TAU * t / 40.0));
            let r = Readings {
                time_s: t,
                proximity: proximity.clone(),
                light: vec![0.0; layout.light_angles.len()],
                pose: Pose::new(0.4 * ops::cos(a), 0.4 * ops::sin(a), a + FRAC_PI_2),
                beacon: Some(Vec2::ZERO),
                ..Readings::default()
            };
            ft.step(&r, &mut rng);
            if ft.is_pusher() {
                became = Some(t);
                break;
            }
        }
        // A filler that never turns pusher fails here.
        became.expect("still filling after 400 s")
    }
}
