//! The controller interface: readings in; wheel speeds, LEDs and attach out.
//!
//! A controller sees only its own [`Readings`] and its [`SensorLayout`], and draws randomness
//! only from the per-robot generator it is handed. It never sees the world.

use crate::geometry::{wrap_angle, Vec2};
use crate::noise::{self, NoiseModel};
use crate::scenario::Color;
use crate::sensors::{Readings, SensorLayout, SensorNeeds};

/// The random generator each robot owns (portable and seeded per robot).
pub type RobotRng = rand_pcg::Pcg64Mcg;

/// Attach / detach command.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum AttachCommand {
    /// Leave as is.
    #[default]
    Keep,
    /// Fix the robot to the body it touches (an object, or a robot already attached to one).
    Attach,
    /// Release the attachment.
    Detach,
}

/// What a controller asks of its actuators for the next tick.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Actuation {
    /// Left wheel speed (m/s), clamped to the model's maximum.
    pub left: f32,
    /// Right wheel speed (m/s).
    pub right: f32,
    /// LED colour.
    pub led: Color,
    /// Attach or detach.
    pub attach: AttachCommand,
    /// Motors off: the wheel speeds are ignored and the wheels roll freely along the heading
    /// (against a small rolling resistance) while sideways they skid, as
    /// [`Physics::drive`](crate::physics::Physics::drive) says. Commanding zero wheel speed
    /// instead brakes with the drive force.
    pub coast: bool,
}

impl Actuation {
    /// Wheel speeds from a forward speed (m/s) and a turn rate (rad/s).
    pub fn from_twist(forward: f32, turn: f32, layout: &SensorLayout) -> Self {
        let half = turn * layout.wheel_distance / 2.0;
        Self {
            left: forward - half,
            right: forward + half,
            ..Self::default()
        }
    }
    /// Motors off (see [`Actuation::coast`](Actuation#structfield.coast)).
    pub fn coasting() -> Self {
        Self {
            coast: true,
            ..Self::default()
        }
    }
    /// Same actuation with another LED colour.
    pub fn with_led(mut self, led: Color) -> Self {
        self.led = led;
        self
    }
}

/// A complementary filter of a robot's own heading, as a real robot fuses odometry with a noisy
/// tracker: each tick it predicts with the turn rate its wheels were last told
/// ([`HeadingFilter::commanded`]) and moves toward the positioning sensor's heading by `gain`.
/// With independent heading noise of spread s and wheels that do what they are told, the
/// estimate's spread is s * sqrt(gain / (2 - gain)) (0.42 s at gain 0.3); where the wheels
/// skid (pushing, attached to a turning object) it follows the tracker within about 1 / gain
/// ticks. Gain 1 passes the sensor's heading through unchanged.
#[derive(Debug, Clone)]
pub struct HeadingFilter {
    gain: f32,
    estimate: Option<(f32, f32)>,
    turn: f32,
}

impl HeadingFilter {
    /// A filter that moves `gain` (0 to 1) of the way to each reading.
    pub fn new(gain: f32) -> Self {
        Self {
            gain: gain.clamp(0.0, 1.0),
            estimate: None,
            turn: 0.0,
        }
    }

    /// The filtered heading (rad) after this tick's reading `measured` at `time_s`.
    pub fn update(&mut self, measured: f32, time_s: f32) -> f32 {
        let e = match self.estimate {
            Some((e, t)) if self.gain < 1.0 => {
                let predicted = e + self.turn * (time_s - t).max(0.0);
                wrap_angle(predicted + self.gain * wrap_angle(measured - predicted))
            }
            _ => measured,
        };
        self.estimate = Some((e, time_s));
        e
    }

    /// Tells the filter what the wheels were told this tick (speeds clamped to the model's).
    pub fn commanded(&mut self, act: &Actuation, layout: &SensorLayout) {
        let v = |w: f32| w.clamp(-layout.max_speed, layout.max_speed);
        self.turn = if act.coast || layout.wheel_distance <= 0.0 {
            0.0
        } else {
            (v(act.right) - v(act.left)) / layout.wheel_distance
        };
    }
}

/// A robot's decision-making, one instance per robot.
pub trait Controller: Send {
    /// Decides what to do this tick from this tick's readings.
    fn step(&mut self, readings: &Readings, rng: &mut RobotRng) -> Actuation;
    /// A short name of the current behaviour state, for viewers and metrics.
    fn state(&self) -> &'static str;
}

/// Builds controllers of one kind with one set of parameters.
pub struct ControllerFactory {
    /// Which sensors the controllers read.
    pub needs: SensorNeeds,
    make: Box<dyn Fn() -> Box<dyn Controller> + Send + Sync>,
    batch: Option<Box<MakeBatch>>,
}

/// Makes the [`BatchController`] of one robot group in one world.
type MakeBatch = dyn Fn() -> Box<dyn BatchController> + Send + Sync;

impl ControllerFactory {
    /// A factory from a constructor closure.
    pub fn new(
        needs: SensorNeeds,
        make: impl Fn() -> Box<dyn Controller> + Send + Sync + 'static,
    ) -> Self {
        Self {
            needs,
            make: Box::new(make),
            batch: None,
        }
    }

    /// A factory of batch controllers: each world gets one from `make` per robot group, which
    /// decides for all the group's robots at once (see [`BatchController`]).
    ///
    /// ```
    /// use formica::controller::{Actuation, BatchController, BatchRobot, ControllerFactory};
    /// use formica::sensors::{SensorLayout, SensorNeeds};
    ///
    /// /// Every robot drives forward at 0.05 m/s plus 0.01 m/s per robot in the group.
    /// struct Crowd;
    /// impl BatchController for Crowd {
    ///     fn step(&mut self, robots: &mut [BatchRobot<'_>]) {
    ///         let v = 0.05 + 0.01 * robots.len() as f32;
    ///         for r in robots.iter_mut() {
    ///             r.action = Actuation { left: v, right: v, ..Actuation::default() };
    ///             r.state = "crowd";
    ///         }
    ///     }
    /// }
    ///
    /// let mut registry = formica::Registry::builtin();
    /// registry.controller("crowd", |_params: Option<&toml::Table>, _layout: &SensorLayout| {
    ///     Ok(ControllerFactory::batched(SensorNeeds::default(), || Box::new(Crowd)))
    /// })?;
    /// let text = "[arena]\nsize = [2.0, 2.0]\n[[robots]]\ncontroller = \"crowd\"\n\
    ///             placement = { poses = [[0.0, 0.5, 0.0], [0.0, -0.5, 0.0]] }\n";
    /// let scenario = registry.parse(text, "crowd.toml")?;
    /// let mut world = formica::World::new(&scenario, &Default::default())?;
    /// world.step();
    /// assert_eq!(world.robots[1].action.left, 0.07);
    /// assert_eq!(world.robots[1].state, "crowd");
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn batched(
        needs: SensorNeeds,
        make: impl Fn() -> Box<dyn BatchController> + Send + Sync + 'static,
    ) -> Self {
        Self {
            needs,
            make: Box::new(|| Box::new(Batched)),
            batch: Some(Box::new(make)),
        }
    }

    /// A fresh controller (for a batch factory: a stand-in that is never stepped).
    pub fn make(&self) -> Box<dyn Controller> {
        (self.make)()
    }

    /// A fresh batch controller, if this is a batch factory ([`ControllerFactory::batched`]).
    pub fn make_batch(&self) -> Option<Box<dyn BatchController>> {
        self.batch.as_ref().map(|make| make())
    }
}

/// One released robot of a group, as its [`BatchController`] sees it.
pub struct BatchRobot<'a> {
    /// The robot's index in the world (`World::robots`).
    pub index: usize,
    /// This tick's readings.
    pub readings: &'a Readings,
    /// The robot's own random generator.
    pub rng: &'a mut RobotRng,
    /// In: what it asked for last tick; out: what it asks for next.
    pub action: Actuation,
    /// In: its state name so far; out: its new one.
    pub state: &'static str,
}

/// Decides for all released robots of one group at once, e.g. a neural network over the batch
/// or a function in another language called once per tick. It still sees only the robots'
/// readings, and draws randomness only from their generators. Registered like any controller,
/// through [`ControllerFactory::batched`].
pub trait BatchController: Send {
    /// Decides this tick's actions of `robots` (the group's released robots, in world order).
    fn step(&mut self, robots: &mut [BatchRobot<'_>]);
}

/// The per-robot stand-in of a batch-controlled robot (the group's batch controller decides).
struct Batched;

impl Controller for Batched {
    fn step(&mut self, _readings: &Readings, _rng: &mut RobotRng) -> Actuation {
        Actuation::default()
    }
    fn state(&self) -> &'static str {
        "batched"
    }
}

/// Readings as one vector of fixed length per sensor layout, for controllers that take arrays
/// (batched or written in another language): `proximity[0..P]`, `light[0..L]`, then `x`, `y`,
/// `theta` (positioning), `beacon_x`, `beacon_y`, `has_beacon` (1 or 0), `attached` (1 or 0)
/// and `time_s`. Sensors a controller does not read are zeros. Camera blobs are left out (their
/// number varies).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FlatReadings {
    proximity: usize,
    light: usize,
}

/// How far beyond the arena's usable area a body's centre can be (m): the walls stand there,
/// and a body pressed into one overlaps it by millimetres, not by this.
pub const BODY_SLACK_M: f32 = 0.1;

/// A named run of slots in a [`FlatReadings`] vector.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Slot {
    /// Name: `proximity`, `light`, or one of [`FlatReadings::TAIL`].
    pub name: &'static str,
    /// Index of its first value in the vector.
    pub offset: usize,
    /// Number of values.
    pub len: usize,
}

impl FlatReadings {
    /// Names of the scalar slots after the proximity and light readings.
    pub const TAIL: [&'static str; 8] = [
        "x",
        "y",
        "theta",
        "beacon_x",
        "beacon_y",
        "has_beacon",
        "attached",
        "time_s",
    ];

    /// The vector layout for robots with `layout`.
    pub fn of(layout: &SensorLayout) -> Self {
        Self {
            proximity: layout.proximity_angles.len(),
            light: layout.light_angles.len(),
        }
    }

    /// The vector's layout, in order: `proximity` (P values), `light` (L values), then one
    /// slot of one value per name in [`FlatReadings::TAIL`]. Readers that go by these names
    /// and offsets keep working when sensors are added.
    pub fn slots(&self) -> Vec<Slot> {
        let groups = [("proximity", self.proximity), ("light", self.light)];
        let sizes = groups
            .into_iter()
            .chain(Self::TAIL.iter().map(|&name| (name, 1)));
        let mut offset = 0;
        sizes
            .map(|(name, len)| {
                let slot = Slot { name, offset, len };
                offset += len;
                slot
            })
            .collect()
    }

    /// Length of the vector.
    pub fn len(&self) -> usize {
        self.proximity + self.light + Self::TAIL.len()
    }

    /// Whether the vector is empty (never: it always has the scalar slots).
    pub fn is_empty(&self) -> bool {
        false
    }

    /// Slot names: `proximity0`, ..., `light0`, ..., then [`FlatReadings::TAIL`] (a slot
    /// of one value keeps its name, longer ones get an index per value).
    pub fn names(&self) -> Vec<String> {
        let mut names = Vec::new();
        for s in self.slots() {
            if s.len == 1 && Self::TAIL.contains(&s.name) {
                names.push(s.name.to_string());
            } else {
                names.extend((0..s.len).map(|i| format!("{}{i}", s.name)));
            }
        }
        names
    }

    /// Writes `r` into `out`, whose length must be [`FlatReadings::len`] (else an error and
    /// `out` unchanged).
    pub fn write(&self, r: &Readings, out: &mut [f32]) -> Result<(), String> {
        if out.len() != self.len() {
            return Err(format!(
                "readings vector: expected length {}, got {}",
                self.len(),
                out.len()
            ));
        }
        let (prox, rest) = out.split_at_mut(self.proximity);
        let (light, tail) = rest.split_at_mut(self.light);
        for (i, v) in prox.iter_mut().enumerate() {
            *v = r.proximity.get(i).copied().unwrap_or(0.0);
        }
        for (i, v) in light.iter_mut().enumerate() {
            *v = r.light.get(i).copied().unwrap_or(0.0);
        }
        let beacon = r.beacon.unwrap_or(Vec2::new(0.0, 0.0));
        let flag = |b: bool| if b { 1.0 } else { 0.0 };
        tail.copy_from_slice(&[
            r.pose.x,
            r.pose.y,
            r.pose.theta,
            beacon.x,
            beacon.y,
            flag(r.beacon.is_some()),
            flag(r.attached),
            r.time_s,
        ]);
        Ok(())
    }

    /// Lower and upper bounds of every value [`FlatReadings::write`] can give a robot of a
    /// world whose arena has centre and size `arena`, with sensor noise `noise`, over a run of
    /// `duration_s`: proximity, light and the flags in [0, 1]; `theta` in [-pi, pi]; `x`, `y`,
    /// `beacon_x`, `beacon_y` within the arena (grown by its walls' reach, [`BODY_SLACK_M`],
    /// and by the largest noise draw, [`noise::MAX_NORMAL`] spreads), and 0 (what a robot not
    /// yet released reads); `time_s` in [0, `duration_s`].
    pub fn bounds(
        &self,
        arena: (Vec2, Vec2),
        noise: &NoiseModel,
        duration_s: f32,
    ) -> (Vec<f32>, Vec<f32>) {
        let (centre, size) = arena;
        let extent = |sd: f32, c: f32, half: f32| {
            let reach = half + BODY_SLACK_M + noise::MAX_NORMAL * sd.max(0.0);
            ((c - reach).min(0.0), (c + reach).max(0.0))
        };
        let span = |name: &str| -> (f32, f32) {
            match name {
                "x" => extent(noise.position_noise, centre.x, size.x / 2.0),
                "y" => extent(noise.position_noise, centre.y, size.y / 2.0),
                "beacon_x" => extent(noise.beacon_noise, centre.x, size.x / 2.0),
                "beacon_y" => extent(noise.beacon_noise, centre.y, size.y / 2.0),
                "theta" => (-std::f32::consts::PI, std::f32::consts::PI),
                "time_s" => (0.0, duration_s.max(0.0)),
                // proximity, light, has_beacon, attached
                _ => (0.0, 1.0),
            }
        };
        let (mut low, mut high) = (
            Vec::with_capacity(self.len()),
            Vec::with_capacity(self.len()),
        );
        for s in self.slots() {
            let (lo, hi) = span(s.name);
            low.extend(std::iter::repeat_n(lo, s.len));
            high.extend(std::iter::repeat_n(hi, s.len));
        }
        (low, high)
    }
}

/// Parses controller parameters from a TOML table into `P`, rejecting unknown keys.
pub fn parse_params<P: serde::de::DeserializeOwned>(
    params: Option<&toml::Table>,
) -> Result<P, String> {
    toml::Value::Table(params.cloned().unwrap_or_default())
        .try_into::<P>()
        .map_err(|e| with_key::<P>(params, e.message().trim()))
}

/// `message` about `table`, prefixed with the key it is about (`` `push.spread_s`: ``) where
/// reading the table written out as text finds one (a value of the wrong type or range; an
/// unknown key is named by the message itself). Only on the error path: parameters that
/// read are read from the table as they are.
fn with_key<P: serde::de::DeserializeOwned>(table: Option<&toml::Table>, message: &str) -> String {
    let located = || {
        let text = toml::to_string(table?).ok()?;
        let span = toml::from_str::<P>(&text).err()?.span()?;
        // A missing key is reported at the whole table (an empty span at its start), which
        // is no key's place; the message names the key itself.
        if span.is_empty() || message.starts_with("missing field") {
            return None;
        }
        let path = crate::limits::path_at(&text, span.start);
        let last = path.last()?;
        (!message.contains(&format!("`{last}`"))).then(|| path.join("."))
    };
    match located() {
        Some(key) => format!("`{key}`: {message}"),
        None => message.to_string(),
    }
}

/// As [`parse_params`], but keys the table leaves out keep `P::default()`'s values in nested
/// tables too. Use it when `P`'s defaults set keys of a nested table that differ from the
/// nested type's own defaults (`fill-transport` sets `fill.object_reach`): with
/// [`parse_params`], a user who sets one key of that table would get the nested type's
/// defaults for all the others.
pub fn parse_params_with_defaults<P>(params: Option<&toml::Table>) -> Result<P, String>
where
    P: serde::de::DeserializeOwned + serde::Serialize + Default,
{
    let mut table = toml::Table::try_from(P::default()).map_err(|e| e.to_string())?;
    if let Some(user) = params {
        overlay(&mut table, user);
    }
    parse_params(Some(&table))
}

/// Writes `top`'s keys over `base`, merging tables that both hold.
fn overlay(base: &mut toml::Table, top: &toml::Table) {
    for (k, v) in top {
        match (base.get_mut(k), v) {
            (Some(toml::Value::Table(b)), toml::Value::Table(t)) => overlay(b, t),
            _ => {
                base.insert(k.clone(), v.clone());
            }
        }
    }
}

/// Checks controller parameters: every `positive` value must be a finite number above zero,
/// every `non_negative` one a finite number at least zero. The error names the parameter.
pub fn check_params(positive: &[(&str, f32)], non_negative: &[(&str, f32)]) -> Result<(), String> {
    for &(name, v) in positive {
        if !(v > 0.0) || !v.is_finite() {
            return Err(format!("`{name}` must be a positive number, got {v}"));
        }
    }
    for &(name, v) in non_negative {
        if !(v >= 0.0) || !v.is_finite() {
            return Err(format!("`{name}` must be zero or more, got {v}"));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Pose;
    use crate::robot::RobotModel;

    #[test]
    fn a_parameter_of_the_wrong_type_is_named_with_its_table() {
        #[derive(serde::Deserialize, Debug)]
        #[serde(deny_unknown_fields)]
        struct Inner {
            #[allow(dead_code)]
            spread_s: f32,
        }
        #[derive(serde::Deserialize, Debug)]
        #[serde(deny_unknown_fields)]
        struct P {
            #[allow(dead_code)]
            speed: f32,
            #[allow(dead_code)]
            push: Option<Inner>,
        }
        let table = |t: &str| t.parse::<toml::Table>().unwrap();
        let err = parse_params::<P>(Some(&table("speed = \"fast\""))).unwrap_err();
        assert!(
            err.starts_with("`speed`: invalid type: string \"fast\""),
            "{err}"
        );
        let err = parse_params::<P>(Some(&table("speed = 1.0\npush = { spread_s = \"x\" }")))
            .unwrap_err();
        assert!(err.starts_with("`push.spread_s`: invalid type"), "{err}");
        // An unknown key names itself once; parameters that read are read as they are.
        let err = parse_params::<P>(Some(&table("speed = 1.0\nsped = 2.0"))).unwrap_err();
        assert!(err.starts_with("unknown field `sped`"), "{err}");
        // A missing one is no other key's fault.
        let err = parse_params::<P>(Some(&table("push = { spread_s = 1.0 }"))).unwrap_err();
        assert!(err.starts_with("missing field `speed`"), "{err}");
        assert_eq!(
            parse_params::<P>(Some(&table("speed = 0.1")))
                .unwrap()
                .speed,
            0.1
        );
    }

    #[test]
    fn the_heading_filter_narrows_noise_and_follows_commanded_turns() {
        use rand::SeedableRng;
        let layout = SensorLayout::of(
            &RobotModel::khepera4(),
            &crate::scenario::SensorConfig::default(),
        );
        let mut rng = RobotRng::seed_from_u64(3);
        let mut gauss = crate::noise::Gauss::new(&mut rng);
        // A robot turning at 0.5 rad/s, as commanded, under heading noise of 0.2 rad: the
        // estimate's error has spread 0.2 * sqrt(0.3 / 1.7) (within 5 % over 10^5 ticks) and
        // no bias.
        let (sd, gain, turn, dt) = (0.2f32, 0.3f32, 0.5f32, 0.1f32);
        let mut f = HeadingFilter::new(gain);
        let act = Actuation::from_twist(0.05, turn, &layout);
        let (mut sum, mut sum2, n) = (0.0f64, 0.0f64, 100_000);
        for k in 0..n {
            let t = k as f32 * dt;
            let truth = wrap_angle(turn * t);
            let e = f.update(gauss.angle(truth, sd), t);
            f.commanded(&act, &layout);
            if k >= 100 {
                let err = f64::from(wrap_angle(e - truth));
                sum += err;
                sum2 += err * err;
            }
        }
        let m = (n - 100) as f64;
        let mean = sum / m;
        let spread = (sum2 / m - mean * mean).sqrt();
        let expect = f64::from(sd * (gain / (2.0 - gain)).sqrt());
        assert!(mean.abs() < 0.01, "bias {mean}");
        assert!(
            (spread / expect - 1.0).abs() < 0.05,
            "spread {spread}, expected {expect}"
        );
        // Gain 1 passes the reading through.
        let mut through = HeadingFilter::new(1.0);
        assert_eq!(through.update(0.7, 0.0), 0.7);
        assert_eq!(through.update(-2.0, 0.1), -2.0);
    }

    #[test]
    fn flat_readings_have_a_fixed_layout() {
        let layout = SensorLayout::of(
            &RobotModel::khepera4(),
            &crate::scenario::SensorConfig::default(),
        );
        let flat = FlatReadings::of(&layout);
        assert_eq!(flat.len(), 8 + 8 + 8);
        let names = flat.names();
        assert_eq!(
            (names[0].as_str(), names[8].as_str()),
            ("proximity0", "light0")
        );
        assert_eq!(names[16..], FlatReadings::TAIL);
        let slots = flat.slots();
        assert_eq!(
            (slots[0], slots[1], slots[2]),
            (
                Slot {
                    name: "proximity",
                    offset: 0,
                    len: 8
                },
                Slot {
                    name: "light",
                    offset: 8,
                    len: 8
                },
                Slot {
                    name: "x",
                    offset: 16,
                    len: 1
                },
            )
        );
        let last = slots[slots.len() - 1];
        assert_eq!(last.offset + last.len, flat.len());
        let r = Readings {
            time_s: 2.5,
            proximity: vec![0.5; 8],
            light: Vec::new(), // not read by this controller
            pose: Pose::new(1.0, -1.0, 0.25),
            beacon: Some(Vec2::new(3.0, 4.0)),
            blobs: Vec::new(),
            scan_color: Vec::new(),
            scan_range: Vec::new(),
            attached: true,
        };
        let mut out = vec![9.0; flat.len()];
        flat.write(&r, &mut out).unwrap();
        assert_eq!(out[..8], [0.5; 8]);
        assert_eq!(out[8..16], [0.0; 8]);
        assert_eq!(out[16..], [1.0, -1.0, 0.25, 3.0, 4.0, 1.0, 1.0, 2.5]);
        assert!(flat.write(&r, &mut out[1..]).is_err());
    }
}
