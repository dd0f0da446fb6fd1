//! Sub-goal relays (Queiroz and MacRae, Swarm Intelligence 2024): transport around obstacles
//! by robots that stand in for a goal that the others cannot see.
//!
//! The goal is a coloured region (a light with a `color`, seen by the blob camera); a relay
//! shows the same colour on its LEDs, so other robots cannot tell it from the goal and push the
//! object toward it. Everything here reads the camera ([`Readings::blobs`]), the colour scan
//! ([`Readings::scan_color`]) and the light ring; nothing knows where anything is.
//!
//! - **Goals** are the blobs of `goal_color`: the real goal and every relay.
//! - **Becoming a relay.** A free robot (searching, or on its way to the object: not
//!   circling or pushing) that saw a goal on the last tick and sees none now becomes a relay
//!   if a wall hid it (`behind_wall`: the scan shows a wall, nearer than the goal was, where
//!   the goal was), the goal and the object were more than `angle_deg` (90, Queiroz and
//!   MacRae's test) apart the last time both were in sight (or the goal was seen alone),
//!   and, with `needs_object`, it sees the object now or has not seen it for `blind_after_s`
//!   (the object is in another compartment: the first relays of a chain toward it form where
//!   nothing can see it); with `lost_window_s`, also if the object comes into sight within
//!   that many seconds of losing the goal.
//! - **A relay** stops and shows `goal_color`. It leaves when its light sensors see the real
//!   goal (the goal is a lamp, relays are only LEDs), when the object comes within `release_m`
//!   of its body, when the object has come no closer by `progress_m` for `patience_s` (a relay
//!   the object does not follow misleads), or after `timeout_s`; then it may not relay again
//!   for a random 0 to `wait_s` seconds.
//! - **Approaching** the object needs both the object and a goal in sight ([`Relay::gate`]);
//!   with `gate_memory_s`, a goal seen within that many seconds will do.
//! - **Pushing**: with no goal in sight, a circling robot pushes only where the colour scan
//!   shows the object toward where it last saw the goal ([`Relay::object_hides`]): behind a
//!   wall, or facing a dissolved relay's empty place, it keeps circling.
//!
//! Where this departs from Queiroz and MacRae's code (`simulation/src/pusherCommon.cpp`,
//! `pusherScript.cpp` in github.com/brenocq/object-transportation), see
//! `docs/src/results/obstacles.md`.

use crate::controller::RobotRng;
use crate::controllers::occlusion::nearest_in_scan;
use crate::geometry::{wrap_angle, Vec2};
use crate::ops;
use crate::scenario::Color;
use crate::sensors::{Readings, SensorLayout};
use rand::Rng;
use serde::{Deserialize, Serialize};

/// Parameters of the relay behaviour (the `relay` table of `occlusion`; all optional).
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct Params {
    /// Colour of the goal as the camera sees it, and of a relay's LEDs. Default `cyan`.
    pub goal_color: Color,
    /// Queiroz and MacRae's test: smallest angle (deg) between goal and object, the last time
    /// both were in sight, for a robot that loses the goal to relay. Default 90, theirs (0
    /// switches it off, the default before results format 12): a robot that has the goal
    /// and the object on one side does not relay, so two relays at the two ends of a wall
    /// seldom pull the object against its middle (obstacle wall, N = 20: 9 of 50 without the
    /// test, 37 with it).
    pub angle_deg: f32,
    /// Relay only where a wall hid the goal: the scan shows a wall, nearer than the goal was,
    /// within a bin and a half of the goal's last bearing. Default true.
    pub behind_wall: bool,
    /// Leave when the light sensors see the goal light (`"light"`, default), or when the camera
    /// sees any goal colour, the goal or another relay (`"any"`, Queiroz and MacRae's code).
    pub leave_on: LeaveOn,
    /// A relay leaves when the object comes this close to its body (m). Default 0.1.
    pub release_m: f32,
    /// After leaving, a robot waits a random 0 to `wait_s` seconds before it may relay again.
    /// Default 5.
    pub wait_s: f32,
    /// A relay leaves after this many seconds (default: never, as Queiroz and MacRae).
    pub timeout_s: Option<f32>,
    /// A relay leaves when the object has come no closer by `progress_m` for this many
    /// seconds (or has been out of sight that long). Default 60; 300 for `fill-transport`'s
    /// pushers, whose relays form while the others fill, minutes before the object moves.
    /// `inf`-like large values switch it off.
    pub patience_s: Option<f32>,
    /// Progress (m) that counts for `patience_s`. Default 0.05.
    pub progress_m: f32,
    /// Relay only with the object in sight (default true). `false` is Queiroz and MacRae's
    /// code, where a robot that saw the goal without the object relays wherever it loses it.
    pub needs_object: bool,
    /// With `needs_object`: a robot that has not seen the object for this many seconds (since
    /// the start, if never) relays without it in sight. Where the object lies in a closed
    /// compartment, nothing that sees the goal or a relay can see it; the robots there have
    /// long lost sight of it, while those near the object see it every few seconds. Default
    /// 120; large values switch it off.
    pub blind_after_s: f32,
    /// A robot that lost the goal behind a wall relays if the object comes into sight (or it
    /// turns blind) within this many seconds, seeing no goal meanwhile. Default 0: only at
    /// the moment it loses the goal, as Queiroz and MacRae.
    pub lost_window_s: f32,
    /// With the goal out of sight, a circling robot pushes only where its colour scan shows
    /// the object within this many scan bins of the goal's last bearing: the object, not a
    /// wall or nothing, is what hides the goal there. Default 1 (the bin toward the goal and
    /// its neighbours). 0 uses `occluder_angle_deg` instead (the angle between the goal and
    /// the object's direction: the beacon's centre, or with camera perception the middle of
    /// what the scan shows of the object; this also counts a goal hidden by a wall).
    pub occlusion_bins: f32,
    /// A free robot approaches the object if it sees it and has seen a goal (the real one or
    /// a relay) within this many seconds. Default 0: only with a goal in sight now, as Queiroz
    /// and MacRae; for `fill-transport`'s pushers, any goal seen since the run began (they
    /// have been round the object, and know where it is).
    pub gate_memory_s: Option<f32>,
}

impl Default for Params {
    fn default() -> Self {
        Self {
            goal_color: Color::Cyan,
            angle_deg: 90.0,
            behind_wall: true,
            leave_on: LeaveOn::Light,
            release_m: 0.1,
            wait_s: 5.0,
            timeout_s: None,
            patience_s: None,
            progress_m: 0.05,
            needs_object: true,
            blind_after_s: 120.0,
            lost_window_s: 0.0,
            occlusion_bins: 1.0,
            gate_memory_s: None,
        }
    }
}

impl Params {
    /// Rejects angles outside 0-180 degrees and negative distances or times.
    pub fn validate(&self) -> Result<(), String> {
        if !(0.0..=180.0).contains(&self.angle_deg) {
            return Err(format!(
                "relay.angle_deg must be 0 to 180, got {}",
                self.angle_deg
            ));
        }
        if matches!(self.goal_color, Color::Off | Color::Grey | Color::Black) {
            return Err(format!(
                "relay.goal_color must be a colour LEDs can show, got {}",
                self.goal_color.name()
            ));
        }
        crate::controller::check_params(
            &[],
            &[
                ("relay.release_m", self.release_m),
                ("relay.wait_s", self.wait_s),
                ("relay.timeout_s", self.timeout_s.unwrap_or(0.0)),
                ("relay.patience_s", self.patience_s.unwrap_or(0.0)),
                ("relay.blind_after_s", self.blind_after_s),
                ("relay.lost_window_s", self.lost_window_s),
                ("relay.progress_m", self.progress_m),
                ("relay.occlusion_bins", self.occlusion_bins),
                ("relay.gate_memory_s", self.gate_memory_s.unwrap_or(0.0)),
            ],
        )
    }
}

/// `Params::patience_s` unless set (s).
pub const PATIENCE_S: f32 = 60.0;

/// What makes a relay give up standing in for the goal, besides the object arriving.
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum LeaveOn {
    /// Its light sensors see the goal light (relays are LEDs, not lamps).
    #[default]
    Light,
    /// Its camera sees anything in the goal's colour: the goal or another relay.
    Any,
}

/// What the camera and the scan show this tick.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct View {
    /// The nearest goal-coloured blob (the goal or a relay): bearing (robot frame, rad) and
    /// estimated distance (m).
    pub goal: Option<(f32, f32)>,
    /// The nearest bin of the scan that shows the object: bearing (rad) and gap between the
    /// robot's body and the object (m).
    pub object: Option<(f32, f32)>,
}

/// One robot's relay state.
#[derive(Debug, Clone)]
pub struct Relay {
    p: Params,
    /// Colours that count as the object in the scan (the object's, and for a pseudo object
    /// the attached robots' LEDs).
    object_colors: Vec<Color>,
    radius: f32,
    /// Relaying since (s).
    since: Option<f32>,
    /// While relaying: the object's nearest gap so far (m) and when it last shrank by
    /// `progress_m` (s).
    closest: (f32, f32),
    /// The goal seen on the last tick: its world-frame direction (rad) and distance (m).
    last_goal: Option<(f32, f32)>,
    /// Queiroz and MacRae's flag: the goal-object angle was wide when last seen together.
    wide: bool,
    /// No relaying before this time (s).
    wait_until: f32,
    /// The last goal seen (world frame): where the robot believes the goal is.
    goal_mem: Option<Vec2>,
    view: View,
    /// The scan shows a wall, nearer than the goal was, where the goal was last seen.
    wall_was: bool,
    /// When the object was last in sight (s; 0 if never).
    object_seen: f32,
    /// When a wall last hid the goal from this robot (s), until it sees a goal again.
    lost: Option<f32>,
    /// When a goal was last in sight (s), and the time now.
    goal_at: (f32, f32),
}

impl Relay {
    /// A robot that is not relaying, for robots with `layout`; the scan shows the object in
    /// `object_colors`.
    pub fn new(p: Params, layout: &SensorLayout, object_colors: Vec<Color>) -> Relay {
        Relay {
            p,
            object_colors,
            radius: layout.radius,
            since: None,
            closest: (f32::INFINITY, 0.0),
            last_goal: None,
            wide: true,
            wait_until: 0.0,
            goal_mem: None,
            view: View::default(),
            wall_was: false,
            object_seen: 0.0,
            lost: None,
            goal_at: (f32::NEG_INFINITY, 0.0),
        }
    }

    /// Its parameters.
    pub fn params(&self) -> &Params {
        &self.p
    }

    /// Reads this tick's camera and scan (call once per tick, before the other methods).
    pub fn observe(&mut self, r: &Readings, layout: &SensorLayout) {
        self.wall_was = self.last_goal.is_some_and(|(dir, dist)| {
            let b = wrap_angle(dir - r.pose.theta);
            let within = 1.5 * std::f32::consts::TAU / layout.scan_angles.len().max(1) as f32;
            r.scan_color
                .iter()
                .zip(&r.scan_range)
                .zip(&layout.scan_angles)
                .any(|((c, d), a)| {
                    *c == Color::Grey && *d < 0.9 * dist && wrap_angle(a - b).abs() <= within
                })
        });
        let goal = r
            .blobs
            .iter()
            .filter(|b| b.color == self.p.goal_color)
            .min_by(|a, b| a.distance.total_cmp(&b.distance))
            .map(|b| (b.bearing, b.distance));
        let object = nearest_in_scan(r, &layout.scan_angles, |c| self.object_colors.contains(&c))
            .map(|(a, d)| (a, (d - self.radius).max(0.0)));
        if let Some((b, d)) = goal {
            self.goal_mem = Some(r.pose.position() + ops::unit(r.pose.theta + b) * d);
            self.goal_at.0 = r.time_s;
        }
        self.goal_at.1 = r.time_s;
        self.view = View { goal, object };
    }

    /// Whether the goal at `bearing` (robot frame, rad) is hidden by the object: the colour
    /// scan shows the object within `occlusion_bins` bins of it. `None` with
    /// `occlusion_bins = 0` (the caller's angle test applies).
    pub fn object_hides(&self, r: &Readings, layout: &SensorLayout, bearing: f32) -> Option<bool> {
        if self.p.occlusion_bins <= 0.0 {
            return None;
        }
        let bin = std::f32::consts::TAU / layout.scan_angles.len().max(1) as f32;
        let within = self.p.occlusion_bins * bin + 1e-4;
        Some(r.scan_color.iter().zip(&layout.scan_angles).any(|(c, a)| {
            self.object_colors.contains(c) && wrap_angle(a - bearing).abs() <= within
        }))
    }

    /// This tick's view.
    pub fn view(&self) -> View {
        self.view
    }

    /// Whether a goal (the real one or a relay) is in sight.
    pub fn goal_seen(&self) -> bool {
        self.view.goal.is_some()
    }

    /// Direction (world frame, rad) from the robot to the goal it last saw.
    pub fn goal_direction(&self, r: &Readings) -> Option<f32> {
        let g = self.goal_mem?;
        let d = g - r.pose.position();
        (d.length() > 0.02).then(|| ops::angle_of(d))
    }

    /// Whether a free robot may approach the object: it sees the object, and a goal now (or
    /// within `gate_memory_s`).
    pub fn gate(&self) -> bool {
        let (seen, now) = self.goal_at;
        let memory = self.p.gate_memory_s.unwrap_or(0.0);
        let goal = self.view.goal.is_some() || now - seen <= memory;
        goal && self.view.object.is_some()
    }

    /// Whether the robot is a relay.
    pub fn is_relay(&self) -> bool {
        self.since.is_some()
    }

    /// One tick of the relay rule, after [`Relay::observe`]. `free`: the robot is searching
    /// or approaching (not circling, pushing or escaping); `real_goal`: its light sensors see
    /// the goal light. Returns whether it is a relay now.
    pub fn update(
        &mut self,
        r: &Readings,
        free: bool,
        real_goal: bool,
        rng: &mut RobotRng,
    ) -> bool {
        let now = r.time_s;
        let View { goal, object } = self.view;
        if object.is_some() {
            self.object_seen = now;
        }
        let wide_angle = self.p.angle_deg.to_radians();
        let last_goal = self.last_goal;
        self.last_goal = goal.map(|(g, d)| (wrap_angle(g + r.pose.theta), d));
        if let Some((g, _)) = goal {
            self.wide = match object {
                Some((o, _)) => wrap_angle(g - o).abs() > wide_angle,
                None => true,
            };
        }
        if let Some(since) = self.since {
            let gap = object.map_or(f32::INFINITY, |(_, gap)| gap);
            // Out of sight is no progress: an object never seen since the relay formed does
            // not keep it on (an infinite gap never counts as closer).
            if gap.is_finite() && gap <= self.closest.0 - self.p.progress_m {
                self.closest = (gap, now);
            }
            let arrived = gap <= self.p.release_m;
            let patience = self.p.patience_s.unwrap_or(PATIENCE_S);
            let stale = now - self.closest.1 >= patience;
            let old = self.p.timeout_s.is_some_and(|t| now - since >= t);
            let sees = match self.p.leave_on {
                LeaveOn::Light => real_goal,
                LeaveOn::Any => real_goal || goal.is_some(),
            };
            if sees || arrived || stale || old {
                self.since = None;
                self.wait_until = now + rng.random::<f32>() * self.p.wait_s;
                return false;
            }
            return true;
        }
        if goal.is_some() {
            self.lost = None;
            return false;
        }
        if last_goal.is_some() && self.wide && (self.wall_was || !self.p.behind_wall) {
            self.lost = Some(now);
        }
        let blind = now - self.object_seen >= self.p.blind_after_s;
        let trigger = free
            && now >= self.wait_until
            && self.lost.is_some_and(|t| now - t <= self.p.lost_window_s)
            && (object.is_some() || !self.p.needs_object || blind);
        if trigger {
            self.lost = None;
            self.since = Some(now);
            self.closest = (object.map_or(f32::INFINITY, |(_, gap)| gap), now);
        }
        trigger
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::geometry::Pose;
    use crate::robot::RobotModel;
    use crate::scenario::SensorConfig;
    use crate::sensors::Blob;
    use rand::SeedableRng;

    pub(crate) fn layout() -> SensorLayout {
        SensorLayout::of(&RobotModel::khepera4(), &SensorConfig::default())
    }

    /// Readings at time `t` with a goal blob at bearing `goal` (if any) and the object at
    /// bearing `object` (if any), 0.5 m away.
    pub(crate) fn readings(
        t: f32,
        goal: Option<f32>,
        object: Option<f32>,
        l: &SensorLayout,
    ) -> Readings {
        let mut scan_color = vec![Color::Off; l.scan_angles.len()];
        let mut scan_range = vec![l.scan_range; l.scan_angles.len()];
        if let Some(o) = object {
            let (i, _) = l
                .scan_angles
                .iter()
                .enumerate()
                .min_by(|a, b| {
                    wrap_angle(a.1 - o)
                        .abs()
                        .total_cmp(&wrap_angle(b.1 - o).abs())
                })
                .unwrap();
            scan_color[i] = Color::Green;
            scan_range[i] = 0.5;
        }
        Readings {
            time_s: t,
            pose: Pose::new(0.0, 0.0, 0.0),
            blobs: goal
                .map(|b| Blob {
                    bearing: b,
                    distance: 1.0,
                    color: Color::Cyan,
                })
                .into_iter()
                .collect(),
            scan_color,
            scan_range,
            ..Readings::default()
        }
    }

    /// As [`readings`] without the goal, with a wall (grey) 0.5 m ahead where the goal was:
    /// the goal lost behind an obstacle.
    pub(crate) fn lost(t: f32, object: Option<f32>, l: &SensorLayout) -> Readings {
        let mut r = readings(t, None, object, l);
        let (i, _) = l
            .scan_angles
            .iter()
            .enumerate()
            .min_by(|a, b| wrap_angle(*a.1).abs().total_cmp(&wrap_angle(*b.1).abs()))
            .unwrap();
        r.scan_color[i] = Color::Grey;
        r.scan_range[i] = 0.5;
        r
    }

    fn step(relay: &mut Relay, r: &Readings, free: bool, rng: &mut RobotRng) -> bool {
        relay.observe(r, &layout());
        relay.update(r, free, false, rng)
    }

    /// A free robot with parameters `p` sees the goal ahead at 0.1 s and not at 0.2 s, with
    /// the object at robot-frame bearing `object` (or out of sight) both times: the relay, and
    /// whether it became one.
    fn lose_goal(p: Params, object: Option<f32>, rng: &mut RobotRng) -> (Relay, bool) {
        let l = layout();
        let mut relay = Relay::new(p, &l, vec![Color::Green]);
        step(&mut relay, &readings(0.1, Some(0.0), object, &l), true, rng);
        let became = step(&mut relay, &lost(0.2, object, &l), true, rng);
        (relay, became)
    }

    #[test]
    fn losing_the_goal_with_the_object_in_sight_makes_a_relay() {
        let l = layout();
        let mut rng = RobotRng::seed_from_u64(1);
        let mut relay = Relay::new(Params::default(), &l, vec![Color::Green]);
        // Goal ahead, object behind: 180 degrees apart.
        assert!(!step(
            &mut relay,
            &readings(0.1, Some(0.0), Some(3.0), &l),
            true,
            &mut rng
        ));
        assert!(step(&mut relay, &lost(0.2, Some(3.0), &l), true, &mut rng));
        assert!(relay.is_relay());
        // It stays until the object comes near.
        assert!(step(
            &mut relay,
            &readings(5.0, None, Some(3.0), &l),
            true,
            &mut rng
        ));
    }

    #[test]
    fn no_relay_where_the_object_hides_the_goal_or_the_robot_is_busy() {
        let l = layout();
        let mut rng = RobotRng::seed_from_u64(2);
        // The object 20 degrees from the goal, no wall where the goal was: walking into the
        // object's shadow is not losing the goal behind an obstacle.
        let mut relay = Relay::new(Params::default(), &l, vec![Color::Green]);
        step(
            &mut relay,
            &readings(0.1, Some(0.0), Some(0.35), &l),
            true,
            &mut rng,
        );
        assert!(!step(
            &mut relay,
            &readings(0.2, None, Some(0.35), &l),
            true,
            &mut rng
        ));
        // A circling or pushing robot never relays.
        let mut relay = Relay::new(Params::default(), &l, vec![Color::Green]);
        step(
            &mut relay,
            &readings(0.1, Some(0.0), Some(3.0), &l),
            false,
            &mut rng,
        );
        assert!(!step(
            &mut relay,
            &lost(0.2, Some(3.0), &l),
            false,
            &mut rng
        ));
        // Without the object in sight, no relay (unless `needs_object = false`).
        assert!(!lose_goal(Params::default(), None, &mut rng).1);
        let p = Params {
            needs_object: false,
            ..Params::default()
        };
        assert!(lose_goal(p, None, &mut rng).1);
    }

    #[test]
    fn a_robot_long_out_of_sight_of_the_object_relays_without_it() {
        let l = layout();
        let mut rng = RobotRng::seed_from_u64(7);
        let p = Params {
            blind_after_s: 30.0,
            ..Params::default()
        };
        // Saw the object at 10 s, loses the goal behind a wall at 39 s and at 41 s: only the
        // second is `blind_after_s` after the last sight of the object.
        let lose_at = |t: f32, rng: &mut RobotRng| {
            let mut relay = Relay::new(p.clone(), &l, vec![Color::Green]);
            step(&mut relay, &readings(10.0, None, Some(3.0), &l), true, rng);
            step(
                &mut relay,
                &readings(t - 0.1, Some(0.0), None, &l),
                true,
                rng,
            );
            step(&mut relay, &lost(t, None, &l), true, rng)
        };
        assert!(!lose_at(39.0, &mut rng));
        assert!(lose_at(41.0, &mut rng));
        // One that has never seen it counts from the start.
        let (_, became) = lose_goal(p.clone(), None, &mut rng);
        assert!(!became);
        let mut relay = Relay::new(p, &l, vec![Color::Green]);
        step(
            &mut relay,
            &readings(30.0, Some(0.0), None, &l),
            true,
            &mut rng,
        );
        assert!(step(&mut relay, &lost(30.1, None, &l), true, &mut rng));
    }

    #[test]
    fn with_a_window_the_object_may_come_into_sight_after_the_goal_is_lost() {
        let l = layout();
        let mut rng = RobotRng::seed_from_u64(8);
        // Goal lost behind a wall at 1.0 s with the object out of sight; the object shows at
        // 3.0 s: a relay with a 3 s window, none without.
        let run = |window: f32, rng: &mut RobotRng| {
            let p = Params {
                lost_window_s: window,
                ..Params::default()
            };
            let mut relay = Relay::new(p, &l, vec![Color::Green]);
            step(&mut relay, &readings(0.9, Some(0.0), None, &l), true, rng);
            let at_loss = step(&mut relay, &lost(1.0, None, &l), true, rng);
            step(&mut relay, &readings(2.0, None, None, &l), true, rng);
            at_loss || step(&mut relay, &readings(3.0, None, Some(3.0), &l), true, rng)
        };
        assert!(!run(0.0, &mut rng));
        assert!(!run(1.5, &mut rng));
        assert!(run(3.0, &mut rng));
    }

    #[test]
    fn a_relay_leaves_when_the_object_arrives_then_waits() {
        let l = layout();
        let mut rng = RobotRng::seed_from_u64(3);
        let (mut relay, became) = lose_goal(Params::default(), Some(3.0), &mut rng);
        assert!(became);
        // The object 0.05 m from the body.
        let mut near = readings(10.0, None, Some(3.0), &l);
        for (c, d) in near.scan_color.iter().zip(near.scan_range.iter_mut()) {
            if *c == Color::Green {
                *d = l.radius + 0.05;
            }
        }
        assert!(!step(&mut relay, &near, true, &mut rng));
        assert!(relay.wait_until >= 10.0 && relay.wait_until <= 15.0);
        // Seeing the real goal also ends it.
        let (mut relay, became) = lose_goal(Params::default(), Some(3.0), &mut rng);
        assert!(became);
        let r = readings(0.3, None, Some(3.0), &l);
        relay.observe(&r, &l);
        assert!(!relay.update(&r, true, true, &mut rng));
    }

    #[test]
    fn a_relay_that_never_sees_the_object_gives_up_after_its_patience() {
        // `needs_object = false`: the relay forms without the object in sight. An object that
        // never shows is no progress, so it leaves after `patience_s` (here 60 s), not never.
        let l = layout();
        let mut rng = RobotRng::seed_from_u64(4);
        let p = Params {
            needs_object: false,
            patience_s: Some(60.0),
            ..Params::default()
        };
        let (mut relay, became) = lose_goal(p, None, &mut rng);
        assert!(became);
        assert!(step(
            &mut relay,
            &readings(59.0, None, None, &l),
            true,
            &mut rng
        ));
        assert!(!step(
            &mut relay,
            &readings(60.5, None, None, &l),
            true,
            &mut rng
        ));
    }

    #[test]
    fn only_the_object_in_the_scan_hides_the_goal() {
        let l = layout();
        let relay = Relay::new(Params::default(), &l, vec![Color::Green]);
        // The object 30 degrees to the left; the goal's last bearing there, one bin (10
        // degrees) off it, or two bins off it.
        let r = readings(0.1, None, Some(0.52), &l);
        assert_eq!(relay.object_hides(&r, &l, 0.52), Some(true));
        assert_eq!(relay.object_hides(&r, &l, 0.52 + 0.17), Some(true));
        assert_eq!(relay.object_hides(&r, &l, 0.52 + 0.35), Some(false));
        // A wall where the goal was (the object elsewhere): not hidden by the object.
        let r = lost(0.1, Some(2.0), &l);
        assert_eq!(relay.object_hides(&r, &l, 0.0), Some(false));
        // `occlusion_bins = 0`: the caller's angle test decides.
        let p = Params {
            occlusion_bins: 0.0,
            ..Params::default()
        };
        let relay = Relay::new(p, &l, vec![Color::Green]);
        assert_eq!(relay.object_hides(&r, &l, 0.0), None);
    }

    #[test]
    fn the_gate_remembers_a_goal_for_gate_memory_s() {
        let l = layout();
        let mut rng = RobotRng::seed_from_u64(3);
        for (memory, open_at_20s, open_at_45s) in [
            (None, false, false),
            (Some(0.0), false, false),
            (Some(30.0), true, false),
        ] {
            let p = Params {
                gate_memory_s: memory,
                ..Params::default()
            };
            let mut relay = Relay::new(p, &l, vec![Color::Green]);
            // Goal and object in sight at 10 s: the gate is open.
            step(
                &mut relay,
                &readings(10.0, Some(0.0), Some(3.0), &l),
                false,
                &mut rng,
            );
            assert!(relay.gate());
            // The goal out of sight since, the object still in sight.
            step(
                &mut relay,
                &readings(20.0, None, Some(3.0), &l),
                false,
                &mut rng,
            );
            assert_eq!(relay.gate(), open_at_20s, "memory {memory:?} at 20 s");
            step(
                &mut relay,
                &readings(45.0, None, Some(3.0), &l),
                false,
                &mut rng,
            );
            assert_eq!(relay.gate(), open_at_45s, "memory {memory:?} at 45 s");
            // Never without the object in sight.
            step(
                &mut relay,
                &readings(46.0, Some(0.0), None, &l),
                false,
                &mut rng,
            );
            assert!(!relay.gate());
        }
    }
}
