//! `occlusion`: occlusion-based cooperative transport of convex objects (Chen et al., IEEE
//! T-RO 2015), the seed paper's Experiment 2.
//!
//! Each robot, on its own and without communication:
//!
//! 1. **search / approach**: finds the object and drives to it. With `perception = "beacon"`
//!    it steers to the object's centre (`Readings::beacon`, as in the seed); with
//!    `perception = "camera"` it steers to the nearest object-coloured bin of its colour scan
//!    ([`Readings::scan_color`]); with none in sight, back to where it last saw the object (by
//!    its own positioning), else toward the nearest robot whose LED says it is at the object
//!    (pushing: red; circling: blue), else it random-walks. It does not shove what is in its
//!    way.
//! 2. **circle**: follows the object's outline with the **left-hand rule** (default
//!    `circle_side = "left"`; with relays `"shortest"`): the object stays on the robot's left,
//!    so robots go round it counter-clockwise seen from above, `circle_gap` from its surface,
//!    watching the goal light.
//! 3. **push**: where the object hides the goal (the light ring's contrast, its strongest
//!    reading above the mean of its weaker half, stays below `dark_contrast` for `hidden_s`;
//!    ambient light and noise never read exactly zero), it turns to face the object along the
//!    surface normal (the bearing to the nearest surface point), turned at most
//!    `push_goal_bias_deg` toward the goal, and pushes. With the camera it also pushes a pusher
//!    (red LED) that touches it on the object's side with the object just beyond, so that
//!    pushers stack in rows, as beacon robots (which cannot tell a pusher from the object) do.
//!    When the goal shows again (contrast
//!    above `lit_contrast` for `visible_s`), it goes back to circling. The two thresholds make
//!    a hysteresis, so that noise does not flip the decision every tick.
//! 4. **escape**: time-outs free stuck robots. A robot that should move but has not moved
//!    `stuck_dist` in `stuck_s` (a pusher: `push_stuck_s`) backs off and turns away for
//!    `escape_s`. A beacon robot circling with something other than the object right ahead
//!    for `block_s` (a wall, a neighbour) goes round the other way for `reverse_s`.
//!
//! Two additions to Chen's rule make it work with Khepera IVs, whose light sensors sit 1.5 cm
//! above the floor so that a neighbour within about 0.3 m hides the goal as well as the object
//! does (with the rule alone, 8 % of the seed's trials succeed, see README):
//!
//! - **Which way the goal is.** Each time a robot sees the goal it takes its bearing (a
//!   parabola through the strongest sensor and its two neighbours, [`light_bearing`], which
//!   assumes no particular spread law) and, with its own pose, intersects it with the earlier
//!   bearings (least squares), so it knows where the goal is even while it is hidden.
//! - **Hidden by the object, not a neighbour**: a dark goal counts only if the object's
//!   direction (beacon: its centre; camera: the centroid of what the colour scan shows of it)
//!   is within `occluder_angle_deg` of the goal's direction. With the beacon this also keeps pushers near
//!   the line from the goal through the centre, so they turn the object little. A robot that
//!   has never seen the goal does not know where it lies, and does not push
//!   (`push_needs_goal`, since results format 33).
//!
//! Where the object's surface is: with the camera, the nearest object-coloured bin of the scan
//! gives the inward surface normal and the gap (to the scan's resolution), and proximity hits in
//! other directions or at other distances are neighbours (bins of robot colours) or walls.
//! With the beacon the robot only knows the centre: within `object_reach` of it, proximity hits
//! on the half facing the centre are taken to be the object (neighbours and walls there fool
//! it, as in the seed); farther out every hit is an obstacle.
//!
//! Positions are noisy: progress (the escape time-outs) is measured on a smoothed position.
//!
//! **Near walls** (both off by default): Chen's rule lets the object turn and drift sideways
//! as it goes, which in the open costs nothing, but an object travelling along a wall touches
//! it. With `balance_turn` a pusher holds still while the object turns the way its own push
//! turns it; with `squeeze_s` a robot caught between the object and a wall pushes the object
//! off the wall.
//!
//! Set `occluder_angle_deg = 180` and `push_goal_bias_deg = 0` for Chen's rule alone; add
//! `goal_sensor = "camera"` for Queiroz and MacRae's baseline, where robots see the goal as a
//! coloured region in the blob camera instead of a dark light ring.
//!
//! **Relays** (`relays = true`, off by default; Queiroz and MacRae 2024, see [`relay`]): the goal
//! is then what the blob camera shows in the goal's colour (`relay.goal_color`; the goal light
//! needs that `color`), the real goal or a relay, instead of the light ring; robots approach the
//! object only with both the object (in the colour scan) and a goal in sight; and a free robot that
//! loses the goal where an obstacle, not the object, hides it stops and shows the goal's colour
//! (state `relay`) until the object comes near or it sees the real goal light. With no goal in
//! sight, a circling robot pushes only where its colour scan shows the object toward where it last
//! saw the goal (`relay.occlusion_bins`, instead of `occluder_angle_deg`), and robots go round the
//! object the shorter way to its back (`circle_side = "shortest"`).

use crate::controller::{
    parse_params_with_defaults, Actuation, Controller, ControllerFactory, RobotRng,
};
use crate::controllers::relay::{self, Relay};
use crate::geometry::{wrap_angle, Vec2};
use crate::ops;
use crate::scenario::Color;
use crate::sensors::{Readings, SensorLayout, SensorNeeds};
use rand::Rng;
use serde::{Deserialize, Serialize};
use std::collections::VecDeque;
use std::f32::consts::{FRAC_PI_2, PI};
use std::sync::Arc;

/// How a robot finds the object.
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Perception {
    /// Told the object's centre (`Readings::beacon`); proximity tells where its surface is.
    #[default]
    Beacon,
    /// Sees the object's colour with the colour scan (`Readings::scan_color`).
    Camera,
}

/// How a robot sees the goal.
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum GoalSensor {
    /// The light ring: the goal is hidden when the ring's contrast drops (Chen et al.).
    Light,
    /// The blob camera: the goal is whatever it shows in `relay.goal_color` (the goal light
    /// needs that `color`), as Queiroz and MacRae's robots see a coloured goal region.
    Camera,
}

/// Which way robots go round the object.
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Side {
    /// Left-hand rule: object on the robot's left, counter-clockwise seen from above.
    #[default]
    Left,
    /// Right-hand rule: object on the right, clockwise.
    Right,
    /// Whichever way is shorter to the side opposite the goal (as far as the robot knows); the
    /// left-hand rule if it has not seen the goal yet.
    Shortest,
}

/// Parameters of `occlusion` (all optional; defaults suit Khepera IV and the seed's 0.5 m box).
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct Params {
    /// `"beacon"` (default) or `"camera"`.
    pub perception: Perception,
    /// Way round the object: `"left"`, `"right"` or `"shortest"`. Default `"left"`; with
    /// `relays = true`, `"shortest"` (Queiroz and MacRae's robots also go the shorter way).
    pub circle_side: Option<Side>,
    /// Colour of the object as the camera sees it (camera perception). Default `green`.
    pub object_color: Color,
    /// LED colour while circling the object. Default `blue`; pushing is `red`. Fillers
    /// (`filling`, `fill-transport`) take a blue LED for a robot attached to the object: give
    /// `occlusion` robots that share an arena with them another colour (`"magenta"`).
    pub circle_led: Color,
    /// Light-ring contrast (strongest reading minus the mean of the weaker half) above which
    /// a hidden goal counts as visible again. Default 0.1.
    pub lit_contrast: f32,
    /// Contrast below which a visible goal counts as hidden. Default 0.06.
    pub dark_contrast: f32,
    /// Speed driving to the object (m/s). Default 0.1.
    pub approach_speed: f32,
    /// Speed circling the object (m/s). Default 0.1.
    pub circle_speed: f32,
    /// Speed pushing (m/s). Default 0.1.
    pub push_speed: f32,
    /// Speed of the random walk while searching (camera, object unseen) (m/s). Default 0.1.
    pub search_speed: f32,
    /// Largest turn rate (rad/s). Default 3.0.
    pub max_turn: f32,
    /// Gain from heading error (rad) to turn rate (rad/s). Default 3.0.
    pub turn_gain: f32,
    /// Gap between body and object surface kept while circling (m). Default 0.03.
    pub circle_gap: f32,
    /// Heading correction per metre of gap error while circling (rad/m). Default 12.
    pub gap_gain: f32,
    /// Gap at which approach turns into circling (m). Default 0.06.
    pub contact_gap: f32,
    /// Largest heading error (rad) at which a pusher still drives forward. Default 0.5.
    pub push_align: f32,
    /// Largest angle (deg) by which a pusher turns from the surface normal toward the goal's
    /// direction (0: along the normal, as Chen et al.). Default 45.
    pub push_goal_bias_deg: f32,
    /// Seconds the goal must stay hidden before a circling robot pushes. Default 0.3.
    pub hidden_s: f32,
    /// Seconds the goal must stay visible before a pusher circles again. Default 0.3.
    pub visible_s: f32,
    /// Length of the summed proximity vector of non-object hits (each reading along its
    /// sensor's bearing) above which they are avoided. Default 0.3.
    pub avoid_threshold: f32,
    /// Seconds without moving `stuck_dist` after which an approaching or circling robot escapes.
    /// Default 8.
    pub stuck_s: f32,
    /// Seconds without moving `stuck_dist` after which a pusher gives up and escapes. Default 30.
    pub push_stuck_s: f32,
    /// Distance (m) that counts as having moved. Default 0.03.
    pub stuck_dist: f32,
    /// Seconds an escape lasts (backing off, then turning away). Default 2.
    pub escape_s: f32,
    /// Seconds with something other than the object (a wall, a neighbour) right ahead after
    /// which a circling robot turns back and goes round the other way. Default: 3 with the
    /// beacon; never with the camera (camera robots tell walls from neighbours and go round
    /// neighbours; turning back at walls made them slower and fail more near a wall).
    pub block_s: Option<f32>,
    /// Seconds of circling the other way after the way round was blocked. Default 20.
    pub reverse_s: f32,
    /// Beacon perception: within this distance of the object's centre (m), proximity hits on
    /// the side facing the centre are taken to be the object; farther out every hit is an
    /// obstacle, and a circling robot counts as lost and approaches again. Should exceed the
    /// object's largest radius plus about 0.2 m (`formica check` and `run` warn when a value
    /// set is shorter): on seed-transport with a 0.9 m box (radius 0.64 m), the median time
    /// over seeds 1-20 is 294 s with 0.6 and 74 s with 0.85, every trial a success; a 1.0 m
    /// box, the middle of whose faces is out of reach too, is never pushed with 0.6 (0 of 10;
    /// 10 of 10 with 0.91). Default 0.6; the `occlusion` controller, given no value, takes the
    /// tracked object's radius plus 0.2 m if that is more ([`default_object_reach`], since
    /// results format 21), and `fill-transport`'s pushers measure the object on their lap.
    pub object_reach: f32,
    /// Largest angle (deg) between the goal's direction (triangulated from the bearings seen
    /// so far) and the object's direction for a hidden goal to count as hidden *by the object*
    /// (a neighbour right in front also hides it). 180 switches the check off. Default 30.
    /// It also caps how many robots push at once: 45 lets e-pucks deliver the seed's box 45
    /// times of 50 instead of 26, but turns light objects into walls (the box by the south
    /// wall 48 -> 41; `experiments/occluder-angle.toml`). With relays,
    /// `relay.occlusion_bins` decides instead (unless it is 0).
    pub occluder_angle_deg: f32,
    /// A dark goal counts as hidden by the object only once the robot has seen the goal (and
    /// knows which way it lies); until then the robot circles. A robot that has never seen it
    /// cannot tell the object's shadow from its neighbours': 20 foot-bots starting in a block
    /// between the seed's box and the goal, in each other's shadow, pushed the box away from
    /// the goal into the wall (2 of 20 arrive, seeds 1-20; 20 of 20 with the sighting). False:
    /// before the goal is first seen, any dark goal counts as hidden (results format 31 and
    /// earlier). No effect with the goal seen by the camera (relays) or with
    /// `occluder_angle_deg = 180`. Default true.
    pub push_needs_goal: bool,
    /// Sub-goal relays (Queiroz and MacRae 2024): the goal is what the camera shows in
    /// `relay.goal_color`, and robots that lose it behind an obstacle become relays. Default
    /// false.
    pub relays: bool,
    /// How the goal is seen: `"light"` (the light ring) or `"camera"` (the blob camera shows
    /// it in `relay.goal_color`). Default `"light"`; with `relays = true`, `"camera"` (the
    /// only choice there). `"camera"` without relays is Queiroz and MacRae's baseline: their
    /// robots see the goal as a coloured region and push where they cannot see it.
    pub goal_sensor: Option<GoalSensor>,
    /// Relay parameters (used with `relays = true`).
    pub relay: relay::Params,
    /// Seconds a pusher pushes without moving `stuck_dist` before it **slides**: for `slide_s`
    /// it pushes `slide_deg` off the surface normal, to a side drawn at random, so that it
    /// slides along the object's face and pushes it off-centre: an object caught on a wall's
    /// end turns and comes free instead of being pressed into it. 0 never slides. Default 0;
    /// with `relays = true`, 8 (seeds 1-50, N = 20: offset gap 17 -> 23 of 50, obstacle wall
    /// 11 -> 20, two corners 22 -> 24, middle 47 -> 46, corner 44 -> 44; turning away from the
    /// side where the scan shows a wall did no better than a random side).
    pub slide_after_s: Option<f32>,
    /// Angle (deg) from the surface normal of a sliding push. Default 45.
    pub slide_deg: f32,
    /// Seconds a slide lasts. Default 10.
    pub slide_s: f32,
    /// Spread the pushers over the hidden side: a circling robot that finds the goal hidden
    /// goes on round while it stays hidden, and pushes where it stops making progress (a
    /// pusher ahead of it) or, having come out on the far side, turns back and pushes
    /// `spread_return` of the way back along the hidden stretch. 0 pushes where it first finds
    /// the goal hidden (the rule of Chen et al.). Otherwise the seconds without progress that
    /// count as stopped. Default 0.5 (a box needing 5 of 20 Khepera IV pushing together: 26 ->
    /// 50 of 50; near a wall 91 / 80 -> 91 / 96 of 100 on the map and its mirror image; see
    /// the Transport results page).
    pub spread_s: f32,
    /// Fraction of the hidden stretch walked back by a spreading robot that came out on its
    /// far side: 0 pushes at the far edge, 0.5 in the middle. Default 0.5.
    pub spread_return: f32,
    /// With the beacon (beacon perception): pushers spread only while the object stands still,
    /// that is while its centre (smoothed) moved less than this (m) over the last 3 s; a robot
    /// that finds the goal hidden behind a moving object pushes at once, as without spreading.
    /// 0 spreads whether or not the object moves (as camera perception, which has no beacon,
    /// always does). Default 0.05.
    pub spread_still_m: f32,
    /// Squeezed robots push: a circling robot with the object on one side (within
    /// `contact_gap`) and something else close on the other (a wall, an obstacle, a neighbour
    /// about 9 cm or less from its body, within 57 degrees of straight away from the object)
    /// for this many seconds pushes the object away from it, along the surface normal, goal in
    /// sight or not, until its far side senses nothing. Keeps objects off walls they travel
    /// along. 0 never (default). See `balance_turn` for what the two do together.
    pub squeeze_s: f32,
    /// Torque balance (beacon perception): a pusher measures how the face it pushes turns
    /// (its own heading plus the surface's bearing, over the last 2 s) and, when the object
    /// turns faster than this (rad/s) the way its own push turns it (the push's moment about
    /// the beacon's centre), holds still instead of pushing. Keeps the object from turning
    /// into walls. 0 never (default). Both on (`balance_turn = 0.03, squeeze_s = 3`, seeds
    /// 1-50, `experiments/near-wall.toml`, results format 33): five concave objects 0.25 m
    /// from a wall 209 -> 200 of 250 (the arc 40 -> 28; format 31, before `push_needs_goal`:
    /// 113 -> 162), the seed's box 0.25 m from it 47 -> 50 of 50, at a quarter more time in
    /// the open (the seed's box: median 97.0 -> 123.0 s). Alone, neither helped much at
    /// format 31 (seeds 1-30, the five concave objects, 69 of 150: balance 70, squeeze 81).
    pub balance_turn: f32,
}

impl Default for Params {
    fn default() -> Self {
        Self {
            perception: Perception::Beacon,
            object_color: Color::Green,
            circle_led: CIRCLE_LED,
            lit_contrast: 0.1,
            dark_contrast: 0.06,
            circle_side: None,
            approach_speed: 0.1,
            circle_speed: 0.1,
            push_speed: 0.1,
            search_speed: 0.1,
            max_turn: 3.0,
            turn_gain: 3.0,
            circle_gap: 0.03,
            gap_gain: 12.0,
            contact_gap: 0.06,
            push_align: 0.5,
            push_goal_bias_deg: 45.0,
            hidden_s: 0.3,
            visible_s: 0.3,
            avoid_threshold: 0.3,
            stuck_s: 8.0,
            push_stuck_s: 30.0,
            stuck_dist: 0.03,
            escape_s: 2.0,
            block_s: None,
            reverse_s: 20.0,
            object_reach: 0.6,
            occluder_angle_deg: 30.0,
            push_needs_goal: true,
            relays: false,
            goal_sensor: None,
            relay: relay::Params::default(),
            slide_after_s: None,
            slide_deg: 45.0,
            slide_s: 10.0,
            spread_s: 0.5,
            spread_return: 0.5,
            spread_still_m: 0.05,
            squeeze_s: 0.0,
            balance_turn: 0.0,
        }
    }
}

/// Summed proximity reading on the far side from the object above which a circling robot
/// counts as squeezed (`Params::squeeze_s`): a wall about 9 cm from a Khepera IV's body (a
/// 0.25 m gap between the object and the wall for a robot circling 3 cm from the object). It
/// pushes on until the far side reads nothing ([`NOISE_FLOOR`]).
const SQUEEZE_READING: f32 = 0.1;

/// Window over which a pusher measures how the face it pushes turns (s), for
/// `Params::balance_turn`.
const BALANCE_WINDOW_S: f32 = 2.0;

/// Builds the factory.
pub fn factory(
    params: Option<&toml::Table>,
    layout: &SensorLayout,
) -> Result<ControllerFactory, String> {
    let p = params_for(params, layout)?;
    p.validate()?;
    let needs = Occlusion::needs(&p);
    let (p, layout) = (Arc::new(p), Arc::new(layout.clone()));
    Ok(ControllerFactory::new(needs, move || {
        Box::new(Occlusion::shared(p.clone(), layout.clone()))
    }))
}

/// How far beyond the object's radius `object_reach` should reach (m): the robot's body and
/// its gap as it goes round, with room for the beacon's noise.
pub const REACH_BEYOND_RADIUS_M: f32 = 0.2;

/// `object_reach` when the parameters leave it out: 0.6 m, or the radius of the objects the
/// beacon tracks ([`SensorLayout::beacon_radius`]) plus [`REACH_BEYOND_RADIUS_M`] if that is
/// more. The positioning system that tells robots where the object is knows its size too.
pub fn default_object_reach(layout: &SensorLayout) -> f32 {
    let base = Params::default().object_reach;
    match layout.beacon_radius {
        Some(r) if r + REACH_BEYOND_RADIUS_M > base => r + REACH_BEYOND_RADIUS_M,
        _ => base,
    }
}

/// The parameters robots with `layout` use for the scenario's `params`: the defaults for what
/// it leaves out, `object_reach` sized by [`default_object_reach`].
pub fn params_for(params: Option<&toml::Table>, layout: &SensorLayout) -> Result<Params, String> {
    let mut p: Params = parse_params_with_defaults(params)?;
    if reach_left_out(params) {
        p.object_reach = default_object_reach(layout);
    }
    Ok(p)
}

/// Whether `params` leave `object_reach` out, so that [`params_for`] sizes it to the object.
pub fn reach_left_out(params: Option<&toml::Table>) -> bool {
    !params.is_some_and(|t| t.contains_key("object_reach"))
}

impl Params {
    /// Whether the goal is seen with the blob camera (`goal_sensor`, or relays).
    pub fn goal_camera(&self) -> bool {
        match self.goal_sensor {
            Some(g) => g == GoalSensor::Camera,
            None => self.relays,
        }
    }

    /// Rejects speeds, gains and times that are not positive (or gaps that are negative).
    pub fn validate(&self) -> Result<(), String> {
        let positive = [
            ("approach_speed", self.approach_speed),
            ("circle_speed", self.circle_speed),
            ("push_speed", self.push_speed),
            ("search_speed", self.search_speed),
            ("max_turn", self.max_turn),
            ("turn_gain", self.turn_gain),
            ("contact_gap", self.contact_gap),
            ("push_align", self.push_align),
            ("stuck_s", self.stuck_s),
            ("push_stuck_s", self.push_stuck_s),
            ("stuck_dist", self.stuck_dist),
            ("escape_s", self.escape_s),
            ("object_reach", self.object_reach),
            ("occluder_angle_deg", self.occluder_angle_deg),
            ("lit_contrast", self.lit_contrast),
            ("dark_contrast", self.dark_contrast),
        ];
        let non_negative = [
            ("circle_gap", self.circle_gap),
            ("gap_gain", self.gap_gain),
            ("hidden_s", self.hidden_s),
            ("visible_s", self.visible_s),
            ("avoid_threshold", self.avoid_threshold),
            ("reverse_s", self.reverse_s),
            ("block_s", self.block_s.unwrap_or(0.0)),
            ("push_goal_bias_deg", self.push_goal_bias_deg),
            ("slide_after_s", self.slide_after_s.unwrap_or(0.0)),
            ("slide_deg", self.slide_deg),
            ("slide_s", self.slide_s),
            ("spread_s", self.spread_s),
            ("spread_return", self.spread_return),
            ("spread_still_m", self.spread_still_m),
            ("squeeze_s", self.squeeze_s),
            ("balance_turn", self.balance_turn),
        ];
        crate::controller::check_params(&positive, &non_negative)?;
        self.relay.validate()?;
        if self.relays && self.goal_sensor == Some(GoalSensor::Light) {
            return Err(
                "relays = true needs goal_sensor = \"camera\" (relays show the goal's colour, \
                 which the light ring cannot see)"
                    .to_string(),
            );
        }
        if self.goal_camera() && self.relay.goal_color == self.object_color {
            return Err(format!(
                "relay.goal_color and object_color are both {}: robots could not tell the \
                 goal from the object",
                self.object_color.name()
            ));
        }
        if self.spread_return > 1.0 {
            return Err(format!(
                "`spread_return` ({}) is a fraction of the hidden stretch: 0 to 1",
                self.spread_return
            ));
        }
        if self.dark_contrast > self.lit_contrast {
            return Err(format!(
                "`dark_contrast` ({}) must not exceed `lit_contrast` ({})",
                self.dark_contrast, self.lit_contrast
            ));
        }
        Ok(())
    }
}

/// Behaviour states.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum State {
    Search,
    Approach,
    Circle,
    Push,
    Escape,
    /// Standing in for the goal (relays).
    Relay,
}

/// Where the object's surface is, as far as this robot can tell.
#[derive(Debug, Clone, Copy)]
struct Surface {
    /// Bearing of the nearest surface point, robot frame (rad): the inward surface normal.
    bearing: f32,
    /// Gap between the body and the surface (m).
    gap: f32,
}

/// The occlusion-based transport controller. Embeddable: another controller may own one and
/// call [`Controller::step`] on it for its pushing phase.
#[derive(Debug, Clone)]
pub struct Occlusion {
    /// Shared by the group's robots until one changes them ([`Occlusion::set_object_reach`]).
    p: Arc<Params>,
    layout: Arc<SensorLayout>,
    state: State,
    /// When the current state began (s).
    since_s: f32,
    /// Time of the last step (s).
    last_s: f32,
    /// Since when the goal has been hidden / visible (s).
    hidden_since: Option<f32>,
    visible_since: Option<f32>,
    /// Progress watch of the escape time-outs (`stuck`).
    progress: Progress,
    /// Smoothed own position (positioning noise averaged out), for the progress watch.
    smooth: Option<Vec2>,
    /// Whether the goal light counts as visible now (with hysteresis).
    goal_lit: bool,
    /// Tell the goal as not hidden on the next step (an embedding controller's veto).
    veto_hidden: bool,
    /// Way round chosen on reaching the object (+1: object on the left).
    side: f32,
    /// Go round the other way until this time (s).
    reverse_until: f32,
    /// Since when something other than the object has been right ahead while circling (s).
    blocked_since: Option<f32>,
    /// Since when the robot has been squeezed between the object and something else (s).
    squeezed_since: Option<f32>,
    /// Pushing because squeezed (`Params::squeeze_s`), not because the goal is hidden.
    squeeze_push: bool,
    /// Samples of the pushed face over the last [`BALANCE_WINDOW_S`]: time (s) and inward
    /// normal (world frame, rad).
    face: VecDeque<(f32, f32)>,
    /// The pushed face's turn rate over that window (rad/s).
    spin: f32,
    /// World-frame direction of the goal when it was last seen (rad).
    goal_dir: Option<f32>,
    /// Where the goal is, triangulated from every bearing seen so far.
    goal_fix: GoalFix,
    /// Escape turn direction (+1 left, -1 right).
    escape_turn: f32,
    /// Random-walk turn while searching: rate and seconds left.
    walk_turn: f32,
    walk_left_s: f32,
    /// The camera's view of the goal (`goal_sensor = "camera"`), and with `relays = true` the
    /// relay behaviour.
    relay: Option<Box<Relay>>,
    /// Sliding (see `Params::slide_after_s`) until this time (s), turning the push this way
    /// (+1 left, -1 right).
    slide_until: f32,
    slide_dir: f32,
    /// Spreading over the hidden side (`Params::spread_s`), from reaching the object on.
    spread: Spread,
    /// Whether the object moves (`Params::spread_still_m`).
    object: ObjectMotion,
    /// Camera perception: where (world frame, by the robot's own positioning) the scan last
    /// showed the object, until the robot gets there without seeing it.
    seen_at: Option<Vec2>,
}

/// Where a robot stood and since when, for "no progress for so long" tests.
#[derive(Debug, Clone, Copy)]
struct Progress {
    at: Vec2,
    /// NaN until the first check.
    since: f32,
}

impl Default for Progress {
    fn default() -> Self {
        Progress {
            at: Vec2::ZERO,
            since: f32::NAN,
        }
    }
}

impl Progress {
    fn restart(&mut self, here: Vec2, now: f32) {
        self.at = here;
        self.since = now;
    }

    /// Restarts (and says so) on the first check or once `here` is `dist` from where it
    /// started.
    fn moved(&mut self, here: Vec2, now: f32, dist: f32) -> bool {
        let moved = self.since.is_nan() || (here - self.at).length() >= dist;
        if moved {
            self.restart(here, now);
        }
        moved
    }

    /// Seconds without progress.
    fn stalled(&self, now: f32) -> f32 {
        now - self.since
    }
}

/// Which leg of spreading a circling robot is on.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
enum Leg {
    /// Has not found the goal hidden since reaching the object.
    #[default]
    Fresh,
    /// Going on round through the hidden side.
    Through,
    /// Came out on its far side and turned back.
    Back,
}

/// A circling robot's spreading (`Params::spread_s`).
#[derive(Debug, Clone, Copy, Default)]
struct Spread {
    leg: Leg,
    /// Metres walked through the hidden side, and back since turning.
    through_m: f32,
    back_m: f32,
    /// Position at the last tick of circling.
    last: Option<Vec2>,
    /// No progress with the goal hidden, and whether it was hidden at the last tick of
    /// circling (a turn back on the spot does not count).
    progress: Progress,
    was_hidden: bool,
}

/// Whether the object moves, from the beacon: its smoothed centre compared every 3 s.
#[derive(Debug, Clone, Copy, Default)]
struct ObjectMotion {
    smooth: Option<Vec2>,
    /// Time and smoothed centre at the start of the current 3 s window.
    anchor: Option<(f32, Vec2)>,
    moving: bool,
}

impl ObjectMotion {
    /// Takes the beacon's reading `beacon` at `now`; moving is more than `still_m` in the last
    /// window. No beacon forgets; a jump (another object's beacon) starts again.
    fn update(&mut self, beacon: Option<Vec2>, now: f32, still_m: f32) {
        let Some(c) = beacon else {
            *self = ObjectMotion::default();
            return;
        };
        let smooth = match self.smooth {
            Some(s) if (c - s).length() < 0.3 => s + (c - s) * 0.1,
            _ => {
                self.anchor = None;
                c
            }
        };
        self.smooth = Some(smooth);
        match self.anchor {
            Some((t, a)) if now - t >= 3.0 => {
                self.moving = (smooth - a).length() > still_m;
                self.anchor = Some((now, smooth));
            }
            Some(_) => {}
            None => self.anchor = Some((now, smooth)),
        }
    }
}

impl Occlusion {
    /// A controller with parameters `p` for robots with `layout`.
    pub fn new(p: Params, layout: &SensorLayout) -> Occlusion {
        Occlusion::shared(Arc::new(p), Arc::new(layout.clone()))
    }

    /// [`Occlusion::new`] with parameters and layout shared by every robot of a group (a
    /// swarm's controllers then hold one copy of them, not one each).
    pub fn shared(p: Arc<Params>, layout: Arc<SensorLayout>) -> Occlusion {
        let relay = p
            .goal_camera()
            .then(|| Box::new(Relay::new(p.relay.clone(), &layout, vec![p.object_color])));
        Occlusion {
            relay,
            p,
            layout,
            state: State::Approach,
            since_s: 0.0,
            last_s: 0.0,
            hidden_since: None,
            visible_since: None,
            progress: Progress::default(),
            smooth: None,
            goal_lit: false,
            veto_hidden: false,
            side: 1.0,
            reverse_until: f32::NEG_INFINITY,
            blocked_since: None,
            squeezed_since: None,
            squeeze_push: false,
            face: VecDeque::new(),
            spin: 0.0,
            goal_dir: None,
            goal_fix: GoalFix::default(),
            escape_turn: 1.0,
            walk_turn: 0.0,
            walk_left_s: 0.0,
            seen_at: None,
            slide_until: f32::NEG_INFINITY,
            slide_dir: 1.0,
            spread: Spread::default(),
            object: ObjectMotion::default(),
        }
    }

    /// Beacon perception: the distance from the object's centre (m) within which proximity
    /// hits facing the centre are taken to be the object.
    pub fn object_reach(&self) -> f32 {
        self.p.object_reach
    }

    /// Changes `object_reach` (m), e.g. to a size the robot measured on its way round.
    pub fn set_object_reach(&mut self, reach: f32) {
        Arc::make_mut(&mut self.p).object_reach = reach;
    }

    /// The way round: `Params::circle_side`, by default the left-hand rule, and the shorter
    /// way to the back side with relays (as Queiroz and MacRae's robots choose it).
    fn circle_side(&self) -> Side {
        match self.p.circle_side {
            Some(s) => s,
            None if self.p.relays => Side::Shortest,
            None => Side::Left,
        }
    }

    /// Seconds of pushing without progress before sliding (`Params::slide_after_s` or its
    /// default: 8 with relays, otherwise never).
    fn slide_after_s(&self) -> f32 {
        match self.p.slide_after_s {
            Some(s) => s,
            None if self.p.relays => 8.0,
            None => 0.0,
        }
    }

    /// Seconds blocked before turning back (`Params::block_s` or its default).
    fn block_s(&self) -> f32 {
        match (self.p.block_s, self.p.perception) {
            (Some(s), _) => s,
            (None, Perception::Beacon) => 3.0,
            (None, Perception::Camera) => f32::INFINITY,
        }
    }

    /// The sensors a controller with parameters `p` reads.
    pub fn needs(p: &Params) -> SensorNeeds {
        SensorNeeds {
            proximity: true,
            light: true,
            beacon: p.perception == Perception::Beacon,
            camera: p.goal_camera(),
            scan: p.perception == Perception::Camera || p.relays,
        }
    }

    /// With relays: colours that also count as the object when the relay rule looks for it
    /// in the scan (a pseudo object's attached robots).
    pub fn add_relay_object_color(&mut self, c: Color) {
        if let Some(relay) = self.relay.take() {
            let mut colors = vec![self.p.object_color, c];
            colors.dedup();
            self.relay = Some(Box::new(Relay::new(
                relay.params().clone(),
                &self.layout,
                colors,
            )));
        }
    }

    /// With relays: the relay rule for a robot that another controller drives this tick (a
    /// filler on its way to the object, which counts as wandering when `free`). Returns what a
    /// relay does (stand still, showing the goal's colour) while the robot relays.
    pub fn relay_only(
        &mut self,
        r: &Readings,
        rng: &mut RobotRng,
        free: bool,
    ) -> Option<Actuation> {
        if let Some(relay) = self.relay.as_mut() {
            relay.observe(r, &self.layout);
        }
        self.relay_update(r, rng, free)
    }

    /// One tick of the relay rule (after `Relay::observe`): the relay's actuation while the
    /// robot relays; a robot that stops relaying goes back to searching.
    fn relay_update(&mut self, r: &Readings, rng: &mut RobotRng, free: bool) -> Option<Actuation> {
        let relay = self.relay.as_mut().filter(|_| self.p.relays)?;
        let real_goal = light_contrast(&r.light) > self.p.lit_contrast;
        if relay.update(r, free, real_goal, rng) {
            self.set_state(State::Relay, r);
            self.last_s = r.time_s;
            return Some(self.twist(0.0, 0.0).with_led(self.p.relay.goal_color));
        }
        if self.state == State::Relay {
            self.set_state(State::Search, r);
        }
        None
    }

    /// Whether the robot is a relay now.
    pub fn is_relay(&self) -> bool {
        self.state == State::Relay
    }

    /// Its parameters.
    pub fn params(&self) -> &Params {
        &self.p
    }

    /// Whether the robot is pushing the object now.
    pub fn is_pushing(&self) -> bool {
        self.state == State::Push
    }

    /// On the next step, a dark light ring does not count as the goal hidden by the object
    /// (the embedding controller knows better, e.g. from where it last saw the goal).
    pub fn veto_hidden(&mut self) {
        self.veto_hidden = true;
    }

    /// Whether the goal light counts as visible (after the last step).
    pub fn goal_visible(&self) -> bool {
        self.goal_lit
    }

    fn set_state(&mut self, s: State, r: &Readings) {
        if s != self.state {
            if s != State::Push {
                self.squeeze_push = false;
            }
            self.face.clear();
            self.spin = 0.0;
            self.state = s;
            self.since_s = r.time_s;
            self.progress.restart(self.position(r), r.time_s);
            self.spread.was_hidden = false;
            self.spread.last = None;
        }
    }

    /// Own position, smoothed (for progress).
    fn position(&self, r: &Readings) -> Vec2 {
        self.smooth.unwrap_or(r.pose.position())
    }

    fn twist(&self, forward: f32, turn: f32) -> Actuation {
        let t = turn.clamp(-self.p.max_turn, self.p.max_turn);
        Actuation::from_twist(forward, t, &self.layout)
    }

    /// Camera perception, the object out of sight: the bearing (robot frame) back to where the
    /// scan last showed it, until the robot is there (then it searches at random).
    fn back_to_seen(&mut self, r: &Readings) -> Option<f32> {
        let to = self.seen_at? - r.pose.position();
        if to.length() < SEEN_REACHED_M {
            self.seen_at = None;
            return None;
        }
        Some(wrap_angle(ops::angle_of(to) - r.pose.theta))
    }

    /// Camera perception, the object out of sight: the bearing (robot frame) of the nearest
    /// robot whose LED says it is at the object (pushing: red; circling: `circle_led`), as the scan
    /// shows it. Robots behind a crowd that hides the object join it so.
    fn toward_busy(&self, r: &Readings) -> Option<f32> {
        let object = self.p.object_color;
        let busy = |c: Color| c != object && (c == PUSH_LED || c == self.p.circle_led);
        nearest_in_scan(r, &self.layout.scan_angles, busy).map(|(b, _)| b)
    }

    /// Camera perception: the bearing (robot frame) of a pusher (a robot showing the push LED
    /// colour) touching this robot on the side where the object is (`s`, within
    /// [`PUSHER_AHEAD_RAD`]), the object no farther than a robot's width and a contact gap:
    /// pushing it pushes the object.
    fn pusher_ahead(&self, r: &Readings, s: Surface) -> Option<f32> {
        let reach = 2.0 * self.layout.radius + self.p.contact_gap;
        if self.p.perception != Perception::Camera || s.gap > reach {
            return None;
        }
        let object = self.p.object_color;
        let touching = |c: Color, d: f32, b: f32| {
            c == PUSH_LED
                && object != PUSH_LED
                && d - self.layout.radius <= self.p.contact_gap
                && wrap_angle(b - s.bearing).abs() <= PUSHER_AHEAD_RAD
        };
        scan_bins(r, &self.layout.scan_angles)
            .filter(|&(c, d, b)| touching(c, d, b))
            .min_by(|x, y| x.1.total_cmp(&y.1))
            .map(|(_, _, b)| b)
    }

    /// Bearing (robot frame) to the object's centre, with the beacon.
    fn centre_bearing(&self, r: &Readings) -> Option<(f32, f32)> {
        let c = r.beacon?;
        let to = c - r.pose.position();
        Some((wrap_angle(ops::angle_of(to) - r.pose.theta), to.length()))
    }

    /// Torque balance (`Params::balance_turn`) for a pusher on surface `s` pushing toward
    /// `push` (robot frame, rad): records how the pushed face turns, and says whether the object
    /// turns faster than `balance_turn` the way this push turns it (then the pusher holds).
    fn balance_holds(&mut self, r: &Readings, s: Surface, push: f32) -> bool {
        if self.p.balance_turn <= 0.0 || s.gap > self.p.contact_gap {
            return false;
        }
        let now = r.time_s;
        let phi = wrap_angle(r.pose.theta + s.bearing);
        self.face.push_back((now, phi));
        while self
            .face
            .front()
            .is_some_and(|(t, _)| now - t > BALANCE_WINDOW_S)
        {
            self.face.pop_front();
        }
        if let Some(&(t0, p0)) = self.face.front() {
            if now - t0 > 0.5 * BALANCE_WINDOW_S {
                self.spin = wrap_angle(phi - p0) / (now - t0);
            }
        }
        let Some((cb, d)) = self.centre_bearing(r) else {
            return false;
        };
        if now - self.since_s <= 1.0 || self.spin.abs() <= self.p.balance_turn {
            return false;
        }
        // Robot frame: the push's moment about the object's centre.
        let arm = ops::unit(s.bearing) * (self.layout.radius + s.gap) - ops::unit(cb) * d;
        arm.perp_dot(ops::unit(push)) * self.spin > 0.0
    }

    /// Whether the robot is squeezed between the object (surface `s`, within `contact_gap`)
    /// and something else on its far side: `other` (proximity hits that are not the object,
    /// summed) stronger than `reading`, within 1 rad of straight away from the surface.
    fn squeezed(&self, s: Surface, other: Vec2, reading: f32) -> bool {
        s.gap <= self.p.contact_gap
            && other.length() > reading
            && wrap_angle(ops::angle_of(other) - s.bearing - PI).abs() < 1.0
    }

    /// The object's surface; the summed proximity vector (robot frame) of everything else; and
    /// of the part of it that may be a wall (camera: hits where no neighbour's LED shows; beacon:
    /// all of it).
    fn perceive(&self, r: &Readings) -> (Option<Surface>, Vec2, Vec2) {
        let range = self.layout.proximity_range;
        match self.p.perception {
            Perception::Camera => {
                let object = self.p.object_color;
                let seen = nearest_in_scan(r, &self.layout.scan_angles, |c| c == object);
                let surface = seen.map(|(a, d)| Surface {
                    bearing: a,
                    gap: (d - self.layout.radius).max(0.0),
                });
                // Proximity hits off the object's direction, or nearer or farther than its surface (a
                // neighbour in between), are others.
                let mut other = Vec2::ZERO;
                let mut wall = Vec2::ZERO;
                let half_bin = std::f32::consts::PI / self.layout.scan_angles.len().max(1) as f32;
                for (v, a) in r.proximity.iter().zip(&self.layout.proximity_angles) {
                    if *v <= NOISE_FLOOR {
                        continue;
                    }
                    let est = linear_gap(*v, range);
                    let is_object = surface.is_some_and(|s| {
                        wrap_angle(a - s.bearing).abs() < 0.8 && (est - s.gap).abs() <= 0.05
                    });
                    if is_object {
                        continue;
                    }
                    let dir = ops::unit(*a) * *v;
                    other += dir;
                    let is_robot = scan_bins(r, &self.layout.scan_angles).any(|(c, d, b)| {
                        is_robot_colour(c, self.p.object_color)
                            && wrap_angle(b - a).abs() < 0.5 + half_bin
                            && d - self.layout.radius <= est + 0.06
                    });
                    if !is_robot {
                        wall += dir;
                    }
                }
                (surface, other, wall)
            }
            Perception::Beacon => {
                let Some((cb, dist)) = self.centre_bearing(r) else {
                    return (None, Vec2::ZERO, Vec2::ZERO);
                };
                let near = dist <= self.p.object_reach;
                let mut obj = Vec2::ZERO;
                let mut best = 0.0f32;
                let mut other = Vec2::ZERO;
                for (v, a) in r.proximity.iter().zip(&self.layout.proximity_angles) {
                    if *v <= NOISE_FLOOR {
                        continue;
                    }
                    let dir = ops::unit(*a) * *v;
                    if near && wrap_angle(a - cb).abs() <= FRAC_PI_2 + 0.1 {
                        obj += dir;
                        best = best.max(*v);
                    } else {
                        other += dir;
                    }
                }
                let surface = if !near {
                    // Too far for the object to be in proximity range.
                    Surface {
                        bearing: cb,
                        gap: dist,
                    }
                } else if best > 0.0 {
                    Surface {
                        bearing: ops::angle_of(obj),
                        gap: linear_gap(best, range),
                    }
                } else {
                    // Nothing sensed: the surface lies somewhere toward the centre.
                    Surface {
                        bearing: cb,
                        gap: range + 0.05,
                    }
                };
                (Some(surface), other, other)
            }
        }
    }

    /// Time-out bookkeeping: whether the robot has stayed put for `limit` seconds.
    fn stuck(&mut self, r: &Readings, limit: f32) -> bool {
        let here = self.position(r);
        if self.progress.moved(here, r.time_s, self.p.stuck_dist) {
            return false;
        }
        self.progress.stalled(r.time_s) >= limit
    }

    /// Whether the goal has been hidden by the object for `hidden_s`, and visible for
    /// `visible_s`. `object` is the object's bearing (robot frame).
    fn goal_hidden(&mut self, r: &Readings, object: Option<f32>) -> (bool, bool) {
        let veto = std::mem::take(&mut self.veto_hidden);
        let mut contrast = None;
        let dark = if let Some(relay) = &self.relay {
            // Relays: the goal is what the camera shows in the goal's colour.
            self.goal_lit = relay.goal_seen();
            !self.goal_lit && !veto
        } else {
            let contrast = *contrast.insert(light_contrast(&r.light));
            self.goal_lit = if self.goal_lit {
                contrast >= self.p.dark_contrast
            } else {
                contrast > self.p.lit_contrast
            };
            !r.light.is_empty() && !self.goal_lit && !veto
        };
        if self.goal_lit && self.relay.is_none() {
            let angles = &self.layout.light_angles;
            let bearing = match contrast {
                Some(c) => light_bearing_with(&r.light, angles, c),
                None => light_bearing(&r.light, angles),
            };
            if let Some(b) = bearing {
                let g = wrap_angle(b + r.pose.theta);
                self.goal_dir = Some(g);
                self.goal_fix.add(r.pose.position(), g);
            }
        }
        // A hidden goal counts only if the object lies toward where the goal was. With
        // relays, the colour scan must show the object there (`relay.occlusion_bins`).
        let scanned = match (&self.relay, self.goal_direction(r), object) {
            (Some(rl), Some(g), Some(_)) if self.p.relays => {
                rl.object_hides(r, &self.layout, wrap_angle(g - r.pose.theta))
            }
            _ => None,
        };
        let by_object = match (self.goal_direction(r), object) {
            _ if scanned.is_some() => scanned == Some(true),
            (Some(g), Some(o)) => {
                wrap_angle(o + r.pose.theta - g).abs() <= self.p.occluder_angle_deg.to_radians()
            }
            // Never seen the goal: a neighbour may be what hides it.
            (None, _) if self.relay.is_none() && self.p.push_needs_goal => {
                self.p.occluder_angle_deg >= 180.0
            }
            _ => true,
        };
        let hidden = dark && by_object;
        if hidden {
            self.visible_since = None;
            self.hidden_since.get_or_insert(r.time_s);
        } else {
            self.hidden_since = None;
            self.visible_since.get_or_insert(r.time_s);
        }
        let long_hidden = self
            .hidden_since
            .is_some_and(|t| r.time_s - t >= self.p.hidden_s - 1e-4);
        let long_visible = self
            .visible_since
            .is_some_and(|t| r.time_s - t >= self.p.visible_s - 1e-4);
        (long_hidden, long_visible)
    }

    /// World-frame direction of the goal from here: toward the triangulated goal once the
    /// bearings seen so far pin it down, otherwise the last bearing seen.
    pub fn goal_direction(&self, r: &Readings) -> Option<f32> {
        if let Some(relay) = &self.relay {
            return relay.goal_direction(r);
        }
        let here = r.pose.position();
        match self.goal_fix.estimate() {
            Some(g) if (g - here).length() > 0.05 => {
                let d = g - here;
                Some(ops::angle_of(d))
            }
            _ => self.goal_dir,
        }
    }

    /// The way round (+1: object on the left) for a robot that sees the object at `bearing`.
    fn choose_side(&self, r: &Readings, bearing: f32) -> f32 {
        match (self.circle_side(), self.goal_direction(r)) {
            (Side::Left, _) | (Side::Shortest, None) => 1.0,
            (Side::Right, _) => -1.0,
            (Side::Shortest, Some(g)) => {
                // Where the robot is, seen from the object, against where the back side is.
                let here = wrap_angle(r.pose.theta + bearing + PI);
                let back = wrap_angle(g + PI);
                // Object on the left means going counter-clockwise round it.
                if wrap_angle(back - here) >= 0.0 {
                    1.0
                } else {
                    -1.0
                }
            }
        }
    }

    fn escape(&mut self, r: &Readings, rng: &mut RobotRng) {
        self.escape_turn = if rng.random::<bool>() { 1.0 } else { -1.0 };
        self.set_state(State::Escape, r);
    }

    /// Approach / search: drive toward the object, around other things.
    fn approach(
        &mut self,
        r: &Readings,
        rng: &mut RobotRng,
        target: Option<f32>,
        other: Vec2,
    ) -> Actuation {
        let avoid = self.avoid_turn(other);
        match target {
            Some(b) => {
                let turn = self.layout.turn_gain(self.p.turn_gain) * b + avoid;
                let fwd = if b.abs() > 1.2 {
                    0.0
                } else {
                    self.p.approach_speed * ops::cos(b).max(0.0)
                };
                // Something other than the object ahead: do not shove it, go round.
                let fwd = if other.x > self.p.avoid_threshold {
                    0.0
                } else if other.length() > self.p.avoid_threshold && other.x > 0.0 {
                    fwd * 0.3
                } else {
                    fwd
                };
                self.twist(fwd, turn)
            }
            None => {
                let dt = (r.time_s - self.last_s).max(0.0);
                if self.walk_left_s > 0.0 {
                    self.walk_left_s -= dt;
                    return self.twist(self.p.search_speed * 0.3, self.walk_turn + avoid);
                }
                if rng.random::<f32>() < dt / 5.0 {
                    self.walk_left_s = rng.random_range(0.3..1.5);
                    self.walk_turn = if rng.random::<bool>() { 1.5 } else { -1.5 };
                }
                let fwd = if other.length() > self.p.avoid_threshold && other.x > 0.0 {
                    0.0
                } else {
                    self.p.search_speed
                };
                self.twist(fwd, avoid)
            }
        }
    }

    /// Turn rate away from what `other` (summed proximity of non-object hits) points at.
    fn avoid_turn(&self, other: Vec2) -> f32 {
        if other.length() <= self.p.avoid_threshold || other.x <= 0.0 {
            return 0.0;
        }
        let side = if other.y > 0.0 { -1.0 } else { 1.0 };
        side * self.p.max_turn * (other.length()).min(1.0)
    }
}

/// Least-squares intersection of the bearing lines along which a robot has seen the goal.
#[derive(Debug, Clone, Copy, Default)]
struct GoalFix {
    /// Sum of n n^T over observations (n: unit normal of the bearing line): xx, xy, yy.
    a: [f32; 3],
    /// Sum of n (n . p).
    b: [f32; 2],
    /// Last observation: where from and which way, to reject estimates behind the robot.
    last: Option<(Vec2, f32)>,
}

impl GoalFix {
    fn add(&mut self, p: Vec2, dir: f32) {
        let n = Vec2::new(-ops::sin(dir), ops::cos(dir));
        let c = n.dot(p);
        self.a[0] += n.x * n.x;
        self.a[1] += n.x * n.y;
        self.a[2] += n.y * n.y;
        self.b[0] += n.x * c;
        self.b[1] += n.y * c;
        self.last = Some((p, dir));
    }

    /// The goal's floor point, once bearings from different places (at least about 3 degrees
    /// apart) pin it down.
    fn estimate(&self) -> Option<Vec2> {
        let [xx, xy, yy] = self.a;
        let det = xx * yy - xy * xy;
        let tr = xx + yy;
        if tr <= 0.0 || det < 0.0005 * tr * tr {
            return None;
        }
        let g = Vec2::new(
            (yy * self.b[0] - xy * self.b[1]) / det,
            (xx * self.b[1] - xy * self.b[0]) / det,
        );
        let (p, dir) = self.last?;
        let d = g - p;
        (d.length() > 1e-3 && wrap_angle(ops::angle_of(d) - dir).abs() < 0.5).then_some(g)
    }
}

/// Proximity readings at or below this are taken as nothing (the sensors' noise floor).
pub const NOISE_FLOOR: f32 = 0.03;

/// LED colours of pushing and circling robots, which camera robots read as "at the object".
const PUSH_LED: Color = Color::Red;
const CIRCLE_LED: Color = Color::Blue; // the default of `circle_led`

/// How far off the object's direction (rad) a pusher may stand and still be pushed through.
const PUSHER_AHEAD_RAD: f32 = 0.5;

/// How near (m) a robot must come to where it last saw the object to give up looking there.
const SEEN_REACHED_M: f32 = 0.3;

/// Bearing (robot frame) of the centroid of the scan's `wanted` points (each bin's bearing
/// and range): where the bulk of what the robot sees of the object lies, as the beacon's
/// centre would say. `None` when no bin shows it.
pub fn centroid_in_scan(
    r: &Readings,
    angles: &[f32],
    wanted: impl Fn(Color) -> bool,
) -> Option<f32> {
    let mut sum = Vec2::ZERO;
    for (c, d, a) in scan_bins(r, angles) {
        if wanted(c) {
            sum += ops::unit(a) * d;
        }
    }
    // No bin wanted leaves the sum zero.
    (sum.length() > 1e-6).then(|| ops::angle_of(sum))
}

/// The gap (m) to what a proximity reading `v` sees, read linearly: `(1 - v) * range`. Exact
/// for the e-puck's linear curve, close for the Khepera IV's exponential one (6 cm reads as
/// 6.2 cm), up to 3.7 cm long for the foot-bot's inverse law; reading each model through its
/// own curve (`ProximityCurve::distance`) was measured and cost foot-bots trials
/// (docs/src/results/unseen.md, "Foot-bots shove the box").
fn linear_gap(v: f32, range: f32) -> f32 {
    (1.0 - v) * range
}

/// The colour scan's bins as (colour, range, bearing), as far as readings and layout agree.
fn scan_bins<'a>(
    r: &'a Readings,
    angles: &'a [f32],
) -> impl Iterator<Item = (Color, f32, f32)> + 'a {
    r.scan_color
        .iter()
        .zip(&r.scan_range)
        .zip(angles)
        .map(|((c, d), a)| (*c, *d, *a))
}

/// The nearest thing the colour scan shows in a colour `wanted` accepts: its bearing (robot
/// frame, rad) and range (m). The scan's ranges are coarse (`scan_step`), so a flat face
/// near the robot reads the same range over several neighbouring bins; the bearing is the
/// middle of that run of equally near bins, not its first bin, which would pull every estimate
/// the same way round (counter-clockwise from the robot's heading) and make robots going
/// round one way see the object differently from those going the other way. `None` if no bin
/// shows such a colour.
pub fn nearest_in_scan(
    r: &Readings,
    angles: &[f32],
    wanted: impl Fn(Color) -> bool,
) -> Option<(f32, f32)> {
    let n = r.scan_color.len().min(r.scan_range.len()).min(angles.len());
    let hit = |i: usize| wanted(r.scan_color[i]);
    let first = (0..n)
        .filter(|&i| hit(i))
        .min_by(|&a, &b| r.scan_range[a].total_cmp(&r.scan_range[b]))?;
    let d = r.scan_range[first];
    let tie = |i: usize| hit(i) && r.scan_range[i] <= d;
    // The run of equally near bins round `first`, at most the whole ring.
    let mut back = 0;
    while back + 1 < n && tie((first + n - back - 1) % n) {
        back += 1;
    }
    let mut ahead = 0;
    while back + ahead + 1 < n && tie((first + ahead + 1) % n) {
        ahead += 1;
    }
    let step = std::f32::consts::TAU / n as f32;
    let bearing = wrap_angle(angles[first] + (ahead as f32 - back as f32) * 0.5 * step);
    Some((bearing, d))
}

/// Whether a colour the scan shows is a robot's (an LED, or an unlit body), not the object
/// (`object`), a wall, or nothing.
pub fn is_robot_colour(c: Color, object: Color) -> bool {
    c != object && !matches!(c, Color::Off | Color::Grey)
}

/// How much a light stands out on the ring: the strongest reading minus the mean of the
/// weaker half (ambient light and the noise floor; a light reaches at most about half of the
/// sensors of the built-in models). Zero for an empty ring.
pub fn light_contrast(light: &[f32]) -> f32 {
    let n = light.len();
    if n == 0 {
        return 0.0;
    }
    if n == RING8 {
        let mut sorted = [0.0f32; RING8];
        sorted.copy_from_slice(light);
        sort8_total(&mut sorted);
        return contrast_of_sorted(&sorted);
    }
    let mut sorted = [0.0f32; 64];
    let m = n.min(64);
    sorted[..m].copy_from_slice(&light[..m]);
    sorted[..m].sort_by(f32::total_cmp);
    contrast_of_sorted(&sorted[..m])
}

/// The light contrast of a non-empty ring sorted in ascending order.
fn contrast_of_sorted(sorted: &[f32]) -> f32 {
    let m = sorted.len();
    let half = (m / 2).max(1);
    let background = sorted[..half].iter().sum::<f32>() / half as f32;
    sorted[m - 1] - background
}

/// Ring size with a sorting network of its own (the Khepera IV's and the e-puck's eight
/// light sensors).
const RING8: usize = 8;

/// Sorts eight readings in the order of `f32::total_cmp`, as `sort_by(f32::total_cmp)` does,
/// with an optimal 19-comparator network on their total-order integer keys (no branches; the
/// light ring is sorted on every tick of every robot).
fn sort8_total(v: &mut [f32; RING8]) {
    // `f32::total_cmp`'s key: flip the magnitude bits of negative numbers. Its own inverse.
    let key = |b: i32| b ^ ((((b >> 31) as u32) >> 1) as i32);
    let [mut k0, mut k1, mut k2, mut k3, mut k4, mut k5, mut k6, mut k7] =
        v.map(|x| key(x.to_bits() as i32));
    // Compare-exchange: the smaller key to the left.
    macro_rules! cx {
        ($a:ident, $b:ident) => {
            let lo = $a.min($b);
            $b = $a.max($b);
            $a = lo;
        };
    }
    cx!(k0, k2);
    cx!(k1, k3);
    cx!(k4, k6);
    cx!(k5, k7);
    cx!(k0, k4);
    cx!(k1, k5);
    cx!(k2, k6);
    cx!(k3, k7);
    cx!(k0, k1);
    cx!(k2, k3);
    cx!(k4, k5);
    cx!(k6, k7);
    cx!(k2, k4);
    cx!(k3, k5);
    cx!(k1, k4);
    cx!(k3, k6);
    cx!(k1, k2);
    cx!(k3, k4);
    cx!(k5, k6);
    *v = [k0, k1, k2, k3, k4, k5, k6, k7].map(|x| f32::from_bits(key(x) as u32));
}

/// Bearing of a light from the readings of sensors at `angles`: the vertex of the parabola
/// through the strongest sensor and its two ring neighbours (readings less the ring's
/// background). It assumes no particular spread law; on the built-in models' law it is within
/// about 4 degrees with 8 sensors (a plain vector sum is off by up to about 10). `None` if the
/// ring shows no light above its background.
pub fn light_bearing(light: &[f32], angles: &[f32]) -> Option<f32> {
    let light = &light[..light.len().min(angles.len())];
    light_bearing_with(light, angles, light_contrast(light))
}

/// [`light_bearing`] given the whole ring's [`light_contrast`], so that a controller that has
/// computed it does not sort the ring again (recomputed over the first `angles.len()` readings
/// if the ring has more).
pub(crate) fn light_bearing_with(light: &[f32], angles: &[f32], contrast: f32) -> Option<f32> {
    let n = light.len().min(angles.len());
    let contrast = if n < light.len() {
        light_contrast(&light[..n])
    } else {
        contrast
    };
    let (i, &ri) = light[..n]
        .iter()
        .enumerate()
        .max_by(|a, b| a.1.total_cmp(b.1))?;
    let background = ri - contrast;
    if ri - background <= 0.0 {
        return None;
    }
    if n < 3 {
        return Some(angles[i]);
    }
    let (p, q) = ((i + n - 1) % n, (i + 1) % n);
    let y0 = ri - background;
    let ym = (light[p] - background).max(0.0);
    let yp = (light[q] - background).max(0.0);
    let xm = wrap_angle(angles[p] - angles[i]);
    let xp = wrap_angle(angles[q] - angles[i]);
    // Parabola y = a x^2 + b x + y0 through (xm, ym), (0, y0), (xp, yp).
    let den = xm * xp * (xm - xp);
    if den.abs() < 1e-9 {
        return Some(angles[i]);
    }
    let a = (xp * (ym - y0) - xm * (yp - y0)) / den;
    let b = (xm * xm * (yp - y0) - xp * xp * (ym - y0)) / den;
    let offset = if a < 0.0 { -b / (2.0 * a) } else { 0.0 };
    let offset = offset.clamp(xm.min(xp) / 2.0, xm.max(xp) / 2.0);
    Some(wrap_angle(angles[i] + offset))
}

impl Controller for Occlusion {
    fn step(&mut self, r: &Readings, rng: &mut RobotRng) -> Actuation {
        let here = r.pose.position();
        self.smooth = Some(match self.smooth {
            Some(s) if (here - s).length() < 0.2 => s + (here - s) * 0.2,
            _ => here,
        });
        self.object
            .update(r.beacon, r.time_s, self.p.spread_still_m);
        let (surface, other, wall) = self.perceive(r);
        if let (Perception::Camera, Some(s)) = (self.p.perception, surface) {
            let d = s.gap + self.layout.radius;
            self.seen_at = Some(r.pose.position() + ops::unit(s.bearing + r.pose.theta) * d);
        }
        let object_dir = match self.p.perception {
            Perception::Beacon => self.centre_bearing(r).map(|(b, _)| b),
            Perception::Camera => {
                let object = self.p.object_color;
                centroid_in_scan(r, &self.layout.scan_angles, |c| c == object)
            }
        };
        if let Some(relay) = self.relay.as_mut() {
            relay.observe(r, &self.layout);
        }
        let (hidden, visible) = self.goal_hidden(r, object_dir);
        let now = r.time_s;
        // A robot searching or on its way to the object may relay (one circling or pushing
        // loses the goal behind the object). One on its way saw the object and a goal last
        // tick: losing the goal now, it stands where the object's way round an obstacle
        // begins. (Search alone, before results format 12, left the offset gap 30 of 50.)
        let free = matches!(self.state, State::Search | State::Approach);
        if let Some(act) = self.relay_update(r, rng, free) {
            return act;
        }
        // Relays: a free robot approaches the object only with both it and a goal in sight;
        // otherwise it wanders, keeping clear of everything (the object included).
        let gated = self.p.relays && self.relay.as_ref().is_some_and(|rl| !rl.gate());
        let wander_other = if gated {
            r.proximity
                .iter()
                .zip(&self.layout.proximity_angles)
                .filter(|(v, _)| **v > NOISE_FLOOR)
                .fold(Vec2::ZERO, |acc, (v, a)| acc + ops::unit(*a) * *v)
        } else {
            other
        };
        // State changes re-run the step in the new state; a few at most per tick.
        let mut hops = 0;
        let act = loop {
            hops += 1;
            if hops > 4 {
                // States disagree (should not happen): back off and try again.
                self.escape(r, rng);
                break self.twist(-self.p.approach_speed, 0.0);
            }
            match self.state {
                State::Search | State::Approach | State::Relay => {
                    let target = match (self.p.perception, surface) {
                        _ if gated => None,
                        (Perception::Camera, Some(s)) => Some(s.bearing),
                        (Perception::Camera, None) => {
                            self.back_to_seen(r).or_else(|| self.toward_busy(r))
                        }
                        (Perception::Beacon, _) => self.centre_bearing(r).map(|(b, _)| b),
                    };
                    // Camera: a pusher (red LED) right ahead with the object just beyond it
                    // and the goal hidden: push it, so that pushers stack in rows as they do
                    // when the beacon cannot tell a pusher from the object.
                    let stack = || surface.and_then(|s| self.pusher_ahead(r, s));
                    if hidden && !gated && stack().is_some() {
                        self.set_state(State::Push, r);
                        continue;
                    }
                    let contact = surface.filter(|s| !gated && s.gap <= self.p.contact_gap);
                    if let Some(s) = contact {
                        self.side = self.choose_side(r, s.bearing);
                        self.spread = Spread::default();
                        self.reverse_until = f32::NEG_INFINITY;
                        self.blocked_since = None;
                        self.set_state(State::Circle, r);
                        continue;
                    }
                    let st = if target.is_some() {
                        State::Approach
                    } else {
                        State::Search
                    };
                    self.set_state(st, r);
                    if self.stuck(r, self.p.stuck_s) {
                        self.escape(r, rng);
                        continue;
                    }
                    break self.approach(r, rng, target, wander_other);
                }
                State::Circle => {
                    let Some(s) = surface else {
                        self.set_state(State::Search, r);
                        continue;
                    };
                    if self.p.perception == Perception::Beacon {
                        if let Some((_, d)) = self.centre_bearing(r) {
                            if d > self.p.object_reach {
                                self.set_state(State::Approach, r);
                                continue;
                            }
                        }
                    } else if s.gap > 2.0 * self.p.contact_gap + 0.1 {
                        self.set_state(State::Approach, r);
                        continue;
                    }
                    if self.p.squeeze_s > 0.0 {
                        if self.squeezed(s, other, SQUEEZE_READING) {
                            let since = *self.squeezed_since.get_or_insert(now);
                            if now - since >= self.p.squeeze_s {
                                self.squeeze_push = true;
                                self.set_state(State::Push, r);
                                continue;
                            }
                        } else {
                            self.squeezed_since = None;
                        }
                    }
                    let here = self.position(r);
                    let sp = &mut self.spread;
                    let step = sp.last.map_or(0.0, |l| (here - l).length());
                    sp.last = Some(here);
                    match sp.leg {
                        Leg::Through if hidden => sp.through_m += step,
                        Leg::Back => sp.back_m += step,
                        _ => {}
                    }
                    // Spreading: not once walked back far enough, nor (a fresh find) while
                    // the object moves.
                    let returned =
                        sp.leg == Leg::Back && sp.back_m >= self.p.spread_return * sp.through_m;
                    let moving = self.p.spread_still_m > 0.0 && self.object.moving;
                    let fresh = sp.leg == Leg::Fresh;
                    let spreading = self.p.spread_s > 0.0 && !returned && !(fresh && moving);
                    // Stopped: no progress since the goal went dark here.
                    if !hidden || !sp.was_hidden {
                        sp.progress.restart(here, now);
                    } else {
                        sp.progress.moved(here, now, self.p.stuck_dist);
                    }
                    sp.was_hidden = hidden;
                    let stopped = sp.progress.stalled(now) >= self.p.spread_s;
                    if hidden && (!spreading || stopped) {
                        self.set_state(State::Push, r);
                        continue;
                    }
                    if spreading {
                        if hidden && sp.leg != Leg::Back {
                            sp.leg = Leg::Through;
                        } else if sp.leg == Leg::Through && visible {
                            // Out on the far side: back along the hidden stretch.
                            sp.leg = Leg::Back;
                            sp.back_m = 0.0;
                            self.side = -self.side;
                        }
                    }
                    // Something other than the object ahead: go round it; if it may be a wall
                    // and stays, go the other way round the object.
                    let ahead =
                        |v: Vec2| v.length() > self.p.avoid_threshold && v.x > 0.3 * v.length();
                    let blocked_ahead = ahead(other);
                    let reversed = now < self.reverse_until;
                    if ahead(wall) {
                        let since = *self.blocked_since.get_or_insert(now);
                        if now - since >= self.block_s() {
                            // Blocked: turn back (or back to the first way round).
                            self.reverse_until = if reversed {
                                f32::NEG_INFINITY
                            } else {
                                now + self.p.reverse_s
                            };
                            self.blocked_since = None;
                        }
                    } else {
                        self.blocked_since = None;
                    }
                    if self.stuck(r, self.p.stuck_s) {
                        self.escape(r, rng);
                        continue;
                    }
                    let side = if now < self.reverse_until {
                        -self.side
                    } else {
                        self.side
                    };
                    // Object on the left (side +1): its bearing should be +90 degrees.
                    let err = wrap_angle(s.bearing - side * FRAC_PI_2);
                    let gap_err = (s.gap - self.p.circle_gap).clamp(-0.1, 0.1);
                    let mut turn = self.layout.turn_gain(self.p.turn_gain) * err
                        + side * self.p.gap_gain * gap_err;
                    let mut fwd = self.p.circle_speed * (1.0 - err.abs() / PI).max(0.2);
                    if blocked_ahead {
                        // Go round a neighbour on the outside.
                        turn -= side * self.p.max_turn * 0.5;
                        fwd *= 0.3;
                    }
                    break self.twist(fwd, turn);
                }
                State::Push => {
                    let Some(s) = surface else {
                        self.set_state(State::Search, r);
                        continue;
                    };
                    if self.squeeze_push && !self.squeezed(s, other, NOISE_FLOOR) {
                        self.squeeze_push = false;
                        self.squeezed_since = None;
                    }
                    if visible && !self.squeeze_push {
                        self.set_state(State::Circle, r);
                        continue;
                    }
                    // Pushing through a pusher ahead (camera): toward it.
                    let s = match self.pusher_ahead(r, s) {
                        Some(b) if s.gap > self.p.contact_gap => Surface {
                            bearing: b,
                            gap: 0.0,
                        },
                        _ => s,
                    };
                    if s.gap > 2.0 * self.p.contact_gap + 0.05 {
                        self.set_state(State::Approach, r);
                        continue;
                    }
                    if self.stuck(r, self.p.push_stuck_s) {
                        self.escape(r, rng);
                        continue;
                    }
                    let slide_after = self.slide_after_s();
                    if slide_after > 0.0 && now >= self.slide_until && self.stuck(r, slide_after) {
                        self.slide_dir = if rng.random::<bool>() { 1.0 } else { -1.0 };
                        self.slide_until = now + self.p.slide_s;
                    }
                    let bias = self.p.push_goal_bias_deg.to_radians();
                    let err = match self.goal_direction(r) {
                        _ if self.squeeze_push && !hidden => s.bearing,
                        _ if now < self.slide_until => {
                            wrap_angle(s.bearing + self.slide_dir * self.p.slide_deg.to_radians())
                        }
                        Some(g) if bias > 0.0 => {
                            let to_goal = wrap_angle(g - r.pose.theta - s.bearing);
                            wrap_angle(s.bearing + to_goal.clamp(-bias, bias))
                        }
                        _ => s.bearing,
                    };
                    let mut fwd = if err.abs() < self.p.push_align {
                        self.p.push_speed
                    } else {
                        0.0
                    };
                    if self.balance_holds(r, s, err) {
                        fwd = 0.0;
                    }
                    break self.twist(fwd, self.layout.turn_gain(self.p.turn_gain) * err);
                }
                State::Escape => {
                    let t = now - self.since_s;
                    if t >= self.p.escape_s {
                        self.set_state(State::Approach, r);
                        continue;
                    }
                    if t < self.p.escape_s * 0.5 {
                        break self.twist(-self.p.approach_speed, 0.0);
                    }
                    break self.twist(0.0, self.escape_turn * self.p.max_turn * 0.5);
                }
            }
        };
        self.last_s = now;
        let led = match self.state {
            State::Push => PUSH_LED,
            State::Circle => self.p.circle_led,
            State::Escape => Color::Yellow,
            State::Search | State::Approach => Color::White,
            State::Relay => self.p.relay.goal_color,
        };
        act.with_led(led)
    }

    fn state(&self) -> &'static str {
        match self.state {
            State::Search => "search",
            State::Approach => "approach",
            State::Circle => "circle",
            State::Push => "push",
            State::Escape => "escape",
            State::Relay => "relay",
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Pose;
    use crate::robot::RobotModel;

    #[test]
    fn relays_go_round_the_shorter_way_unless_told() {
        let layout = crate::sensors::SensorLayout::of(
            &RobotModel::khepera4(),
            &crate::scenario::SensorConfig::default(),
        );
        let with = |relays, circle_side| {
            Occlusion::new(
                Params {
                    relays,
                    circle_side,
                    ..Params::default()
                },
                &layout,
            )
            .circle_side()
        };
        assert_eq!(with(false, None), Side::Left);
        assert_eq!(with(true, None), Side::Shortest);
        assert_eq!(with(true, Some(Side::Left)), Side::Left);
    }

    #[test]
    fn the_scan_centroid_points_where_the_bulk_of_the_object_is() {
        let angles: Vec<f32> = (0..36)
            .map(|i| wrap_angle(i as f32 * std::f32::consts::TAU / 36.0))
            .collect();
        let green = |c: Color| c == Color::Green;
        // Scan bins that show the object at `range(bearing)` between bearings `from..=to` (deg).
        let scan = |from: i32, to: i32, range: &dyn Fn(f32) -> f32| {
            let mut r = Readings::default();
            for a in &angles {
                let deg = (a.to_degrees()).round() as i32;
                let on = (from..=to).contains(&deg);
                r.scan_color
                    .push(if on { Color::Green } else { Color::Off });
                r.scan_range.push(if on { range(*a) } else { 1.0 });
            }
            r
        };
        // A flat face 0.1 m ahead, seen out to 1 m either side: straight ahead.
        let face = scan(-80, 80, &|a| (0.1 / ops::cos(a)).min(1.0));
        // Both scans show green bins ahead of the robot: their sum is not zero, so the
        // centroid exists.
        let ahead = centroid_in_scan(&face, &angles, green).expect("the face is in sight");
        assert!(ahead.abs() < 1e-4, "{ahead}");
        // At the face's left end: the bulk lies to the right, not along the normal.
        let end = scan(-80, 0, &|a| (0.1 / ops::cos(a)).min(1.0));
        let b = centroid_in_scan(&end, &angles, green).expect("the face is in sight");
        assert!((-1.2..-0.5).contains(&b), "{b}");
        // Nothing of the object in sight: no direction.
        let none = scan(200, 200, &|_| 1.0);
        assert_eq!(centroid_in_scan(&none, &angles, green), None);
    }

    #[test]
    fn a_robot_that_changes_its_reach_changes_its_own_only() {
        let layout = Arc::new(crate::sensors::SensorLayout::of(
            &RobotModel::khepera4(),
            &crate::scenario::SensorConfig::default(),
        ));
        let p = Arc::new(Params::default());
        let (mut a, b) = (
            Occlusion::shared(p.clone(), layout.clone()),
            Occlusion::shared(p.clone(), layout),
        );
        assert!(
            Arc::ptr_eq(&a.p, &b.p),
            "a group's robots share their parameters"
        );
        a.set_object_reach(0.9);
        assert_eq!(a.object_reach(), 0.9);
        assert_eq!(b.object_reach(), 0.6);
        assert_eq!(p.object_reach, 0.6);
    }

    #[test]
    fn a_robot_on_its_way_to_the_object_relays_where_a_wall_hides_the_goal() {
        // Seeing the object (beacon, 0.5 m behind) and the goal ahead, the robot approaches;
        // the next tick a wall hides the goal. It stands in for the goal: robots on their way
        // lose the goal where the object's way round the obstacle begins (with relays and the
        // angle test, seeds 1-50: offset gap 30 -> 43 of 50, two corners 25 -> 36).
        use crate::controllers::relay::tests::{layout, lost, readings};
        let l = layout();
        let mut occ = Occlusion::new(
            Params {
                relays: true,
                ..Params::default()
            },
            &l,
        );
        let mut rng = <RobotRng as rand::SeedableRng>::seed_from_u64(1);
        let behind = 3.0f32;
        let beacon = Some(ops::unit(behind) * 0.5);
        let seen = Readings {
            beacon,
            ..readings(0.1, Some(0.0), Some(behind), &l)
        };
        occ.step(&seen, &mut rng);
        assert_eq!(occ.state(), "approach");
        assert!(!occ.is_relay());
        let hidden = Readings {
            beacon,
            ..lost(0.2, Some(behind), &l)
        };
        let act = occ.step(&hidden, &mut rng);
        assert!(occ.is_relay());
        assert_eq!(occ.state(), "relay");
        assert_eq!(act.led, Color::Cyan);
    }

    /// Runs a camera-perception controller with parameters `p` for `ticks` ticks (0.1 s each),
    /// the goal light dark and the colour scan showing the object in the one bin nearest
    /// `object_bearing` (robot frame), `gap` from the body; `pose(i)` is the pose at tick `i`.
    /// Returns the layout and, tick by tick, the actuation and the state.
    fn dark_goal_run(
        p: Params,
        object_bearing: f32,
        gap: f32,
        ticks: usize,
        pose: impl Fn(usize) -> Pose,
    ) -> (crate::sensors::SensorLayout, Vec<(Actuation, &'static str)>) {
        // The goal never shows here: these runs test what a robot does once it takes the goal
        // for hidden, so it may without a sighting (the sighting rule is tested apart).
        let p = Params {
            push_needs_goal: false,
            ..p
        };
        goal_run(p, object_bearing, gap, ticks, pose, |_| None, |_| None)
    }

    /// As `dark_goal_run`, but the goal light shines from `light(pose)` (robot frame) where
    /// it returns a bearing, and the beacon reads `beacon(i)` at tick `i`.
    fn goal_run(
        p: Params,
        object_bearing: f32,
        gap: f32,
        ticks: usize,
        pose: impl Fn(usize) -> Pose,
        light: impl Fn(&Pose) -> Option<f32>,
        beacon: impl Fn(usize) -> Option<Vec2>,
    ) -> (crate::sensors::SensorLayout, Vec<(Actuation, &'static str)>) {
        let model = RobotModel::khepera4();
        let layout =
            crate::sensors::SensorLayout::of(&model, &crate::scenario::SensorConfig::default());
        let mut c = Occlusion::new(
            Params {
                perception: Perception::Camera,
                ..p
            },
            &layout,
        );
        let n = layout.scan_angles.len();
        let off = |k: usize| wrap_angle(layout.scan_angles[k] - object_bearing).abs();
        // The scan has at least one bin (`scan_bins` is at least 1), so there is a nearest.
        let bin = (0..n).min_by(|a, b| off(*a).total_cmp(&off(*b))).unwrap();
        let mut scan_color = vec![Color::Off; n];
        let mut scan_range = vec![layout.scan_range; n];
        scan_color[bin] = Color::Green;
        scan_range[bin] = layout.radius + gap;
        let mut rng = <RobotRng as rand::SeedableRng>::seed_from_u64(7);
        let run = (0..ticks)
            .map(|i| {
                let pose = pose(i);
                let mut lights = vec![0.0; layout.light_angles.len()];
                if let Some(b) = light(&pose) {
                    model.spread_light(b, 1.0, &mut lights);
                }
                let r = Readings {
                    time_s: i as f32 * 0.1,
                    pose,
                    light: lights,
                    proximity: vec![0.0; layout.proximity_angles.len()],
                    scan_color: scan_color.clone(),
                    scan_range: scan_range.clone(),
                    beacon: beacon(i),
                    ..Readings::default()
                };
                let a = c.step(&r, &mut rng);
                (a, c.state())
            })
            .collect();
        (layout, run)
    }

    /// Turn rates (rad/s) a pusher commands, tick by tick for 20 s, pressed against an object
    /// dead ahead that does not move, the goal hidden.
    fn stuck_push_turns(slide_after_s: Option<f32>) -> Vec<f32> {
        let p = Params {
            slide_after_s,
            spread_s: 0.0,
            ..Params::default()
        };
        let (layout, run) = dark_goal_run(p, 0.0, 0.005, 200, |_| Pose::default());
        run.iter()
            .map(|(a, _)| (a.right - a.left) / layout.wheel_distance)
            .collect()
    }

    /// The scan of a flat object face whose inward normal lies at `normal` (robot frame),
    /// `gap` from the body, ranges rounded to the preset's 2 cm as the sensor gives them.
    fn flat_face_scan(layout: &crate::sensors::SensorLayout, normal: f32, gap: f32) -> Readings {
        let dist = layout.radius + gap;
        let (scan_color, scan_range) = layout
            .scan_angles
            .iter()
            .map(|a| {
                let c = ops::cos(wrap_angle(a - normal));
                let d = if c > 0.0 { dist / c } else { f32::INFINITY };
                if d <= layout.scan_range {
                    (Color::Green, (d / 0.02).round() * 0.02)
                } else {
                    (Color::Off, layout.scan_range)
                }
            })
            .unzip();
        Readings {
            scan_color,
            scan_range,
            ..Readings::default()
        }
    }

    #[test]
    fn the_scan_finds_a_flat_face_where_it_is_whichever_side_it_lies() {
        let layout = crate::sensors::SensorLayout::of(
            &RobotModel::khepera4(),
            &crate::scenario::SensorConfig::default(),
        );
        let half_bin = PI / layout.scan_angles.len() as f32;
        for k in -36..36 {
            // Normals on and between bins, all the way round.
            let normal = k as f32 * 0.087 + 0.01;
            for gap in [0.0, 0.03, 0.06] {
                let green = |c: Color| c == Color::Green;
                let (b, _) = nearest_in_scan(
                    &flat_face_scan(&layout, normal, gap),
                    &layout.scan_angles,
                    green,
                )
                .unwrap();
                assert!(
                    wrap_angle(b - normal).abs() <= half_bin + 1e-4,
                    "normal {normal}, gap {gap}: bearing {b}"
                );
                // The mirror image reads the mirror bearing: going round either way, a robot
                // sees the object alike.
                let (m, _) = nearest_in_scan(
                    &flat_face_scan(&layout, -normal, gap),
                    &layout.scan_angles,
                    green,
                )
                .unwrap();
                assert!(
                    wrap_angle(m + b).abs() < 1e-4,
                    "normal {normal}: {b} and {m}"
                );
            }
        }
    }

    /// States of a robot going round an object on its left (camera perception) with the goal
    /// hidden, tick by tick: it moves 1 cm a tick for `moving` ticks, then stands still.
    fn hidden_side_states(spread_s: f32, moving: usize, ticks: usize) -> Vec<&'static str> {
        let p = Params {
            spread_s,
            ..Params::default()
        };
        let pose = |i: usize| Pose::new(0.01 * i.min(moving) as f32, 0.0, 0.0);
        let (_, run) = dark_goal_run(p, FRAC_PI_2, 0.03, ticks, pose);
        run.into_iter().map(|(_, s)| s).collect()
    }

    #[test]
    fn spreading_pushers_go_on_through_the_hidden_side_until_they_stop() {
        // Without spreading it pushes once the goal has been hidden for `hidden_s` (0.3 s).
        let plain = hidden_side_states(0.0, 100, 100);
        assert_eq!(plain[1], "circle");
        assert!(plain[10..].iter().all(|s| *s == "push"), "{plain:?}");
        // Spreading, it goes on round while it moves (5 s), and pushes within 3 s of stopping.
        let spread = hidden_side_states(1.0, 50, 100);
        assert!(spread[..50].iter().all(|s| *s == "circle"), "{spread:?}");
        assert!(spread[80..].iter().all(|s| *s == "push"), "{spread:?}");
    }

    /// States of a spreading robot (object on its left, the goal on its left beyond the
    /// object when lit) at poses `x(i)` along the x axis; `lit(x)` tells whether the goal is
    /// in sight there; the beacon reads `beacon(i)`.
    fn spread_states(
        spread_return: f32,
        x: impl Fn(usize) -> f32,
        lit: impl Fn(f32) -> bool,
        beacon: impl Fn(usize) -> Option<Vec2>,
    ) -> Vec<&'static str> {
        let p = Params {
            spread_return,
            ..Params::default()
        };
        let light = |p: &Pose| lit(p.x).then_some(FRAC_PI_2);
        let (_, run) = goal_run(
            p,
            FRAC_PI_2,
            0.03,
            300,
            |i| Pose::new(x(i), 0.0, 0.0),
            light,
            beacon,
        );
        run.into_iter().map(|(_, s)| s).collect()
    }

    /// From x = -0.3 m out 1 cm a tick to x = 1.05 m (tick 135), where a robot that turned
    /// back on coming out into the goal's sight would be, then back; the goal hidden while
    /// 0 <= x < 1 m.
    fn out_and_back(spread_return: f32) -> Vec<&'static str> {
        let x = |i: usize| 0.01 * (i.min(135) as f32 - i.saturating_sub(135) as f32) - 0.3;
        spread_states(spread_return, x, |x| !(0.0..1.0).contains(&x), |_| None)
    }

    #[test]
    fn a_spreading_pusher_that_comes_out_on_the_far_side_pushes_back_in_the_middle() {
        // Through the hidden metre (ticks 30 to 130) without pushing; out at x = 1 m it turns
        // back, and pushes half a metre back (x = 0.5 m at tick 190), not at the edge (tick 140);
        // the script walks on, out of the hidden side at tick 270.
        let middle = out_and_back(0.5);
        assert!(middle[..175].iter().all(|s| *s == "circle"), "{middle:?}");
        assert!(middle[200..240].iter().all(|s| *s == "push"), "{middle:?}");
        // `spread_return = 0`: at the edge, as soon as the goal is hidden again.
        let edge = out_and_back(0.0);
        assert!(edge[..135].iter().all(|s| *s == "circle"), "{edge:?}");
        assert!(edge[150..240].iter().all(|s| *s == "push"), "{edge:?}");
    }

    #[test]
    fn behind_an_object_that_moves_a_robot_pushes_at_once() {
        // On round 1 cm a tick; the goal in sight for the first half metre, then hidden.
        let forward = |i: usize| 0.01 * i as f32;
        let states =
            |beacon: fn(usize) -> Option<Vec2>| spread_states(0.5, forward, |x| x < 0.5, beacon);
        // The beacon moves 1 cm a tick (0.1 m/s): it pushes within a second of the goal going
        // dark at tick 50, as without spreading...
        let moving = states(|i| Some(Vec2::new(0.01 * i as f32, 1.0)));
        assert!(moving[..50].iter().all(|s| *s == "circle"), "{moving:?}");
        assert!(moving[60..].iter().all(|s| *s == "push"), "{moving:?}");
        // ... and behind one that stands still it goes on round, as without a beacon.
        let still = states(|_| Some(Vec2::new(0.0, 1.0)));
        assert!(still[..300].iter().all(|s| *s == "circle"), "{still:?}");
        assert_eq!(still, states(|_| None));
    }

    #[test]
    fn a_robot_that_never_saw_the_goal_does_not_push_in_the_dark() {
        // On round 1 cm a tick with the object on its left and the goal dark throughout: a
        // neighbour may be what hides the goal, so it circles.
        let run = |p: Params, light: fn(&Pose) -> Option<f32>| -> Vec<&'static str> {
            let pose = |i: usize| Pose::new(0.01 * i as f32, 0.0, 0.0);
            let (_, run) = goal_run(p, FRAC_PI_2, 0.03, 100, pose, light, |_| None);
            run.into_iter().map(|(_, s)| s).collect()
        };
        let plain = Params {
            spread_s: 0.0,
            ..Params::default()
        };
        let never = run(plain.clone(), |_| None);
        assert!(never.iter().all(|s| *s == "circle"), "{never:?}");
        // Having seen the goal beyond the object for its first 20 cm, it pushes once the goal
        // has been hidden for `hidden_s`.
        let seen = run(plain.clone(), |p| (p.x < 0.2).then_some(FRAC_PI_2));
        assert!(seen[..20].iter().all(|s| *s == "circle"), "{seen:?}");
        assert!(seen[30..].iter().all(|s| *s == "push"), "{seen:?}");
        // Chen's rule alone (no check of what hides the goal) and results format 31 push in
        // the dark at once.
        for p in [
            Params {
                occluder_angle_deg: 180.0,
                ..plain.clone()
            },
            Params {
                push_needs_goal: false,
                ..plain
            },
        ] {
            let dark = run(p, |_| None);
            assert!(dark[10..].iter().all(|s| *s == "push"), "{dark:?}");
        }
    }

    #[test]
    fn a_pusher_that_makes_no_progress_slides() {
        // Circling for `hidden_s` (0.3 s), then without sliding it pushes straight at the
        // object until it escapes at `push_stuck_s` = 30 s.
        let straight = stuck_push_turns(Some(0.0));
        assert!(straight[5..].iter().all(|t| t.abs() < 1.0), "{straight:?}");
        // With `slide_after_s = 5` it turns 45 degrees off the normal from 5 s on.
        let slide = stuck_push_turns(Some(5.0));
        assert!(slide[5..45].iter().all(|t| t.abs() < 1.0), "{slide:?}");
        assert!(slide[55..].iter().all(|t| t.abs() > 1.0), "{slide:?}");
        // The default: never without relays.
        assert_eq!(stuck_push_turns(None), straight);
    }

    #[test]
    fn light_bearing_finds_the_light_on_every_model() {
        for model in [
            RobotModel::khepera4(),
            RobotModel::footbot(),
            RobotModel::epuck(),
        ] {
            for k in -36..36 {
                let b = k as f32 * 5.0_f32.to_radians() + 0.01;
                let mut out = vec![0.0; model.light_angles.len()];
                model.spread_light(wrap_angle(b), 0.6, &mut out);
                for v in &mut out {
                    *v += 0.05;
                }
                let got = light_bearing(&out, &model.light_angles).unwrap_or(f32::NAN);
                assert!(
                    wrap_angle(got - b).abs() < 0.08,
                    "{:?}: light at {b}, estimated {got}",
                    model.kind
                );
            }
        }
    }

    /// The general path of `light_contrast` (the standard sort), for comparison.
    fn contrast_by_std_sort(light: &[f32]) -> f32 {
        let mut v = light.to_vec();
        v.sort_by(f32::total_cmp);
        contrast_of_sorted(&v)
    }

    #[test]
    fn the_sorting_network_sorts_every_zero_one_ring() {
        // The 0-1 principle: a comparator network that sorts all 2^8 rings of zeros and ones
        // sorts every ring.
        for bits in 0u32..256 {
            let mut v = [0.0f32; 8];
            for (i, x) in v.iter_mut().enumerate() {
                *x = ((bits >> i) & 1) as f32;
            }
            let mut want = v;
            want.sort_by(f32::total_cmp);
            sort8_total(&mut v);
            assert_eq!(v, want, "ring {bits:08b}");
        }
    }

    #[test]
    fn the_sorting_network_orders_signed_zeros_infinities_and_nans_as_total_cmp() {
        let mut v = [
            0.5,
            -0.0,
            0.0,
            f32::NAN,
            -f32::NAN,
            f32::INFINITY,
            -1.0,
            f32::NEG_INFINITY,
        ];
        let mut want = v;
        want.sort_by(f32::total_cmp);
        sort8_total(&mut v);
        let bits = |a: [f32; 8]| a.map(f32::to_bits);
        assert_eq!(bits(v), bits(want));
    }

    proptest::proptest! {
        #[test]
        fn light_contrast_of_eight_readings_is_the_standard_sorts_to_the_bit(
            light in proptest::array::uniform8(-0.2f32..1.2),
        ) {
            proptest::prop_assert_eq!(
                light_contrast(&light).to_bits(),
                contrast_by_std_sort(&light).to_bits()
            );
            let angles: Vec<f32> = (0..8).map(|i| i as f32 * std::f32::consts::TAU / 8.0).collect();
            let with = light_bearing_with(&light, &angles, contrast_by_std_sort(&light));
            proptest::prop_assert_eq!(
                with.map(f32::to_bits),
                light_bearing(&light, &angles).map(f32::to_bits)
            );
        }
    }
}
