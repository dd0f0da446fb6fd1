//! Scenario files: one readable TOML file describes an experiment (arena, lights, objects,
//! robots, run settings and stop rules).
//!
//! Every error names the file, the line and what was expected. See the README for the full
//! reference; `scenarios/` holds worked examples.

use crate::geometry::{Part, Primitive};
use crate::limits;
use crate::noise::{self, NoiseModel, NoisePreset};
use crate::registry::Registry;
use crate::robot::ModelKind;
use serde::{Deserialize, Serialize};
use std::fmt;
use std::ops::Range;
use toml::Spanned;

/// A scenario file that failed to load or validate.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ScenarioError {
    /// The file could not be read.
    #[error("{file}: cannot read: {message}")]
    Io {
        /// File name.
        file: String,
        /// What went wrong.
        message: String,
    },
    /// The file is malformed or describes something impossible.
    #[error("{file}:{line}:{column}: {message}")]
    Invalid {
        /// File name.
        file: String,
        /// 1-based line.
        line: usize,
        /// 1-based column.
        column: usize,
        /// What was wrong and what was expected.
        message: String,
    },
}

/// An LED / body colour, as cameras see it.
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum Color {
    /// LED off (invisible to cameras).
    #[default]
    Off,
    /// Red.
    Red,
    /// Green.
    Green,
    /// Blue.
    Blue,
    /// Yellow.
    Yellow,
    /// Magenta.
    Magenta,
    /// Cyan.
    Cyan,
    /// Orange.
    Orange,
    /// White.
    White,
    /// Grey (walls, as the colour scan sees them).
    Grey,
    /// Black (a robot's body with its LEDs off, as the colour scan sees it).
    Black,
}

impl Color {
    /// Every colour, in declaration order (Python's `formica.COLORS` and LED codes use it).
    pub const ALL: [Color; 11] = [
        Color::Off,
        Color::Red,
        Color::Green,
        Color::Blue,
        Color::Yellow,
        Color::Magenta,
        Color::Cyan,
        Color::Orange,
        Color::White,
        Color::Grey,
        Color::Black,
    ];

    /// 8-bit RGB for drawing.
    pub fn rgb(self) -> [u8; 3] {
        match self {
            Color::Off => [40, 40, 40],
            Color::Red => [220, 40, 40],
            Color::Green => [40, 170, 60],
            Color::Blue => [40, 90, 230],
            Color::Yellow => [230, 200, 30],
            Color::Magenta => [200, 50, 200],
            Color::Cyan => [40, 200, 210],
            Color::Orange => [240, 140, 30],
            Color::White => [245, 245, 245],
            Color::Grey => [128, 128, 128],
            Color::Black => [20, 20, 20],
        }
    }
    /// Lower-case name.
    pub fn name(self) -> &'static str {
        match self {
            Color::Off => "off",
            Color::Red => "red",
            Color::Green => "green",
            Color::Blue => "blue",
            Color::Yellow => "yellow",
            Color::Magenta => "magenta",
            Color::Cyan => "cyan",
            Color::Orange => "orange",
            Color::White => "white",
            Color::Grey => "grey",
            Color::Black => "black",
        }
    }
}

/// The rectangular arena, walled on all four sides.
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Arena {
    /// Usable size `[x, y]` in metres; walls are centred on its border.
    #[cfg_attr(feature = "schema", schemars(inner(range(min = limits::MIN_SIZE_M, max = limits::MAX_ARENA_M))))]
    pub size: [f32; 2],
    /// Centre of the arena.
    #[serde(default)]
    #[cfg_attr(feature = "schema", schemars(inner(range(min = -limits::MAX_ARENA_M, max = limits::MAX_ARENA_M))))]
    pub center: [f32; 2],
    /// Wall thickness (m).
    #[serde(default = "default_wall_thickness")]
    #[cfg_attr(feature = "schema", schemars(range(min = limits::MIN_SIZE_M, max = limits::MAX_HEIGHT_M)))]
    pub wall_thickness: f32,
    /// Wall height (m).
    #[serde(default = "default_wall_height")]
    #[cfg_attr(feature = "schema", schemars(range(min = limits::MIN_SIZE_M, max = limits::MAX_HEIGHT_M)))]
    pub wall_height: f32,
}

fn default_wall_thickness() -> f32 {
    0.1
}
fn default_wall_height() -> f32 {
    0.5
}

/// An extra static wall or obstacle: a box of `size`, or any `shape` an object can have (a
/// disc for a pillar, a polygon, concave allowed).
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WallSpec {
    /// Centre (the origin of `shape`).
    #[cfg_attr(feature = "schema", schemars(inner(range(min = -limits::MAX_COORD_M, max = limits::MAX_COORD_M))))]
    pub at: [f32; 2],
    /// Size `[x, y]` of a box wall before rotation (use this or `shape`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[cfg_attr(feature = "schema", schemars(inner(range(min = limits::MIN_SIZE_M, max = limits::MAX_COORD_M))))]
    pub size: Option<[f32; 2]>,
    /// Any other shape, as an object's `shape` takes it: `{ disc = 0.1 }` (a pillar),
    /// `{ polygon = [[x, y], ...] }` or `{ regular = { sides, radius } }`, in the wall's frame
    /// (use this or `size`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[cfg_attr(feature = "schema", schemars(with = "Option<PartSpec>"))]
    pub shape: Option<Spanned<PartSpec>>,
    /// Rotation in degrees.
    #[serde(default)]
    #[cfg_attr(feature = "schema", schemars(range(min = -limits::MAX_ANGLE_DEG, max = limits::MAX_ANGLE_DEG)))]
    pub yaw_deg: f32,
    /// Height (m).
    #[serde(default = "default_wall_height")]
    #[cfg_attr(feature = "schema", schemars(range(min = limits::MIN_SIZE_M, max = limits::MAX_HEIGHT_M)))]
    pub height: f32,
}

/// A light: the goal of transport, or the object beacon of filling.
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LightSpec {
    /// Floor position.
    #[cfg_attr(feature = "schema", schemars(inner(range(min = -limits::MAX_COORD_M, max = limits::MAX_COORD_M))))]
    pub at: [f32; 2],
    /// Height above the floor (m).
    #[serde(default = "default_light_height")]
    #[cfg_attr(feature = "schema", schemars(range(min = 0.0, max = limits::MAX_HEIGHT_M)))]
    pub height: f32,
    /// Intensity (ARGoS units; readings fall to zero at 2.5 x intensity metres).
    #[serde(default = "default_intensity")]
    #[cfg_attr(feature = "schema", schemars(range(min = limits::MIN_SIZE_M, max = limits::MAX_INTENSITY)))]
    pub intensity: f32,
    /// Whether this light marks the transport goal (default: the first light).
    #[serde(default)]
    pub goal: Option<bool>,
    /// Colour the blob camera sees it in (a coloured goal region, as Queiroz and MacRae's);
    /// default `off`: light sensors only.
    #[serde(default, skip_serializing_if = "is_off")]
    pub color: Color,
    /// A moving light: waypoints `[t_s, x, y]` in increasing time. It starts at `at`, moves
    /// in a straight line at constant speed to each waypoint in turn, reaching it at its time,
    /// and stays at the last one.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub path: Vec<[f32; 3]>,
}

fn is_off(c: &Color) -> bool {
    *c == Color::Off
}

impl LightSpec {
    /// Floor position at time `t` (s): `at`, or where `path` has moved it by then.
    pub fn position_at(&self, t: f32) -> [f32; 2] {
        let mut from = (0.0f32, self.at);
        for w in &self.path {
            let to = (w[0], [w[1], w[2]]);
            if t < to.0 {
                let span = to.0 - from.0;
                let k = if span > 0.0 {
                    ((t - from.0) / span).clamp(0.0, 1.0)
                } else {
                    1.0
                };
                return [
                    from.1[0] + (to.1[0] - from.1[0]) * k,
                    from.1[1] + (to.1[1] - from.1[1]) * k,
                ];
            }
            from = to;
        }
        from.1
    }
}

fn default_light_height() -> f32 {
    0.5
}
fn default_intensity() -> f32 {
    10.0
}

/// `{ sides = 6, radius = 0.3 }`.
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RegularSpec {
    /// Number of sides.
    #[cfg_attr(feature = "schema", schemars(range(min = 3, max = limits::MAX_REGULAR_SIDES)))]
    pub sides: u32,
    /// Circumradius (m).
    #[cfg_attr(feature = "schema", schemars(range(min = limits::MIN_SIZE_M, max = limits::MAX_SIZE_M)))]
    pub radius: f32,
}

/// One shape: exactly one of `box`, `disc`, `polygon`, `regular`, optionally placed with
/// `at` and `yaw_deg` in the object's frame.
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PartSpec {
    /// Box `[width, depth]`.
    #[serde(rename = "box", default, skip_serializing_if = "Option::is_none")]
    #[cfg_attr(feature = "schema", schemars(inner(range(min = limits::MIN_SIZE_M, max = limits::MAX_SIZE_M))))]
    pub box_: Option<[f32; 2]>,
    /// Disc radius.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[cfg_attr(feature = "schema", schemars(range(min = limits::MIN_SIZE_M, max = limits::MAX_SIZE_M)))]
    pub disc: Option<f32>,
    /// Simple polygon (concave allowed), vertices in order (either way round); a vertex that
    /// repeats the one before it or lies on the straight edge between its neighbours is dropped.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[cfg_attr(feature = "schema", schemars(length(min = 3, max = limits::MAX_POLYGON_VERTICES)))]
    pub polygon: Option<Vec<[f32; 2]>>,
    /// Regular polygon.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub regular: Option<RegularSpec>,
    /// Offset from the object's origin.
    #[serde(default)]
    #[cfg_attr(feature = "schema", schemars(inner(range(min = -limits::MAX_SIZE_M, max = limits::MAX_SIZE_M))))]
    pub at: [f32; 2],
    /// Rotation (degrees).
    #[serde(default)]
    #[cfg_attr(feature = "schema", schemars(range(min = -limits::MAX_ANGLE_DEG, max = limits::MAX_ANGLE_DEG)))]
    pub yaw_deg: f32,
}

impl PartSpec {
    /// The validated part.
    pub fn to_part(&self) -> Result<Part, String> {
        let mut shapes = Vec::new();
        if let Some(b) = self.box_ {
            shapes.push(Primitive::Box(b));
        }
        if let Some(r) = self.disc {
            shapes.push(Primitive::Disc(r));
        }
        if let Some(p) = &self.polygon {
            shapes.push(Primitive::Polygon(p.clone()));
        }
        if let Some(r) = &self.regular {
            shapes.push(Primitive::Regular {
                sides: r.sides,
                radius: r.radius,
            });
        }
        if shapes.len() != 1 {
            return Err(format!(
                "expected exactly one of `box`, `disc`, `polygon`, `regular`, found {}",
                shapes.len()
            ));
        }
        let shape = shapes.remove(0);
        shape.validate().map_err(|e| e.0)?;
        Ok(Part {
            shape,
            at: self.at,
            yaw_deg: self.yaw_deg,
        })
    }
}

/// An object: static or movable, any polygonal shape.
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObjectSpec {
    /// Name, for reports.
    #[serde(default)]
    pub name: Option<String>,
    /// Position of the object's origin.
    #[serde(default)]
    #[cfg_attr(feature = "schema", schemars(inner(range(min = -limits::MAX_COORD_M, max = limits::MAX_COORD_M))))]
    pub at: [f32; 2],
    /// Rotation (degrees) about `at`.
    #[serde(default)]
    #[cfg_attr(feature = "schema", schemars(range(min = -limits::MAX_ANGLE_DEG, max = limits::MAX_ANGLE_DEG)))]
    pub yaw_deg: f32,
    /// A single shape (use this or `parts`).
    #[serde(default)]
    #[cfg_attr(feature = "schema", schemars(with = "Option<PartSpec>"))]
    pub shape: Option<Spanned<PartSpec>>,
    /// A union of shapes in the object's frame (use this or `shape`).
    #[serde(default)]
    #[cfg_attr(feature = "schema", schemars(with = "Vec<PartSpec>", length(max = limits::MAX_ITEMS)))]
    pub parts: Vec<Spanned<PartSpec>>,
    /// Height (m): decides what it hides from light sensors.
    #[serde(default = "default_object_height")]
    #[cfg_attr(feature = "schema", schemars(range(min = limits::MIN_SIZE_M, max = limits::MAX_HEIGHT_M)))]
    pub height: f32,
    /// Mass (kg).
    #[serde(default = "default_mass")]
    #[cfg_attr(feature = "schema", schemars(range(min = limits::MIN_SIZE_M, max = limits::MAX_MASS_KG)))]
    pub mass: f32,
    /// Whether robots can push it.
    #[serde(default = "default_true")]
    pub movable: bool,
    /// Floor friction coefficient: the floor resists with up to `floor_mu * mass * 9.81` N.
    #[serde(default = "default_floor_mu")]
    #[cfg_attr(feature = "schema", schemars(range(min = 0.0, max = limits::MAX_FLOOR_MU)))]
    pub floor_mu: f32,
    /// Colour seen by cameras.
    #[serde(default = "default_object_color")]
    pub color: Color,
}

fn default_object_height() -> f32 {
    0.3
}
fn default_mass() -> f32 {
    5.0
}
fn default_true() -> bool {
    true
}
/// Default floor friction coefficient of objects (a 5 kg object then needs 4 Khepera IVs).
pub const DEFAULT_FLOOR_MU: f32 = 0.1;
fn default_floor_mu() -> f32 {
    DEFAULT_FLOOR_MU
}
fn default_object_color() -> Color {
    Color::Green
}

/// Where a group's robots start.
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum Placement {
    /// Uniformly random, non-overlapping, in a rectangle.
    Random {
        /// Lower corner.
        #[cfg_attr(feature = "schema", schemars(inner(range(min = -limits::MAX_COORD_M, max = limits::MAX_COORD_M))))]
        min: [f32; 2],
        /// Upper corner.
        #[cfg_attr(feature = "schema", schemars(inner(range(min = -limits::MAX_COORD_M, max = limits::MAX_COORD_M))))]
        max: [f32; 2],
        /// Fixed heading in degrees (default: random).
        #[serde(default)]
        #[cfg_attr(feature = "schema", schemars(range(min = -limits::MAX_ANGLE_DEG, max = limits::MAX_ANGLE_DEG)))]
        heading_deg: Option<f32>,
    },
    /// A grid of `columns` along x, rows along y, centred on `center`.
    Grid {
        /// Centre of the grid.
        #[cfg_attr(feature = "schema", schemars(inner(range(min = -limits::MAX_COORD_M, max = limits::MAX_COORD_M))))]
        center: [f32; 2],
        /// Distance between neighbours (m).
        #[cfg_attr(feature = "schema", schemars(range(min = limits::MIN_SIZE_M, max = limits::MAX_SIZE_M)))]
        spacing: f32,
        /// Robots per row along x (default: a square-ish grid).
        #[serde(default)]
        #[cfg_attr(feature = "schema", schemars(range(min = 1, max = limits::MAX_ROBOTS)))]
        columns: Option<usize>,
        /// Heading in degrees.
        #[serde(default)]
        #[cfg_attr(feature = "schema", schemars(range(min = -limits::MAX_ANGLE_DEG, max = limits::MAX_ANGLE_DEG)))]
        heading_deg: f32,
    },
    /// Explicit `[x, y, heading_deg]` per robot.
    Poses(Vec<[f32; 3]>),
}

/// What serde derives for [`Placement`], behind [`Placement`]'s own `Deserialize`, which
/// first checks the outer table so that a slip gets a message in the file's terms (serde's
/// own read `wanted exactly 1 element, more than 1 element`).
#[derive(Deserialize)]
#[serde(remote = "Placement", rename_all = "snake_case", deny_unknown_fields)]
enum PlacementDef {
    Random {
        min: [f32; 2],
        max: [f32; 2],
        #[serde(default)]
        heading_deg: Option<f32>,
    },
    Grid {
        center: [f32; 2],
        spacing: f32,
        #[serde(default)]
        columns: Option<usize>,
        #[serde(default)]
        heading_deg: f32,
    },
    Poses(Vec<[f32; 3]>),
}

impl<'de> Deserialize<'de> for Placement {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        use serde::de::Error;
        const KINDS: [&str; 3] = ["random", "grid", "poses"];
        const EXAMPLE: &str = "placement = { random = { min = [-1.0, -1.0], max = [1.0, 1.0] } }";
        let v = toml::Value::deserialize(d)?;
        let Some(t) = v.as_table() else {
            return Err(D::Error::custom(format!(
                "expected a table with one of `random`, `grid` or `poses`, found {} ({EXAMPLE})",
                describe_value(&v)
            )));
        };
        let (kinds, others): (Vec<&str>, Vec<&str>) = t
            .keys()
            .map(String::as_str)
            .partition(|k| KINDS.contains(k));
        if !others.is_empty() {
            // A key of a kind's own table written beside it (an ARGoS habit for the heading).
            let inside = others
                .iter()
                .find(|k| ["heading_deg", "min", "max", "center", "spacing", "columns"].contains(k))
                .map_or(String::new(), |k| {
                    format!(
                        " (`{k}` goes inside the kind's own table, as in placement = {{ random = \
                         {{ min = [-1.0, -1.0], max = [1.0, 1.0], heading_deg = 0.0 }} }})"
                    )
                });
            return Err(D::Error::custom(format!(
                "unknown key{} {} in a placement: expected exactly one of `random`, `grid` or \
                 `poses`{inside}",
                if others.len() > 1 { "s" } else { "" },
                others
                    .iter()
                    .map(|k| format!("`{k}`"))
                    .collect::<Vec<_>>()
                    .join(", ")
            )));
        }
        if kinds.len() != 1 {
            return Err(D::Error::custom(format!(
                "a placement has exactly one of `random`, `grid` or `poses`, found {} ({EXAMPLE})",
                if kinds.is_empty() {
                    "none".to_string()
                } else {
                    kinds
                        .iter()
                        .map(|k| format!("`{k}`"))
                        .collect::<Vec<_>>()
                        .join(" and ")
                }
            )));
        }
        let kind = kinds[0].to_string();
        PlacementDef::deserialize(v).map_err(|e| {
            let m = plain_message(&e.to_string()).replace('\n', " ");
            D::Error::custom(format!("placement.{kind}: {m}"))
        })
    }
}

/// A TOML value's kind in words, for messages.
fn describe_value(v: &toml::Value) -> String {
    match v {
        toml::Value::String(s) => format!("the string \"{s}\""),
        toml::Value::Integer(_) | toml::Value::Float(_) => "a number".into(),
        toml::Value::Boolean(_) => "a boolean".into(),
        toml::Value::Datetime(_) => "a date".into(),
        toml::Value::Array(_) => "an array".into(),
        toml::Value::Table(_) => "a table".into(),
    }
}

/// A serde message in a scenario file's terms: Rust type names (`struct WheelOptions`,
/// `usize`, `f32`) become "a table", "a whole number", "a number".
pub(crate) fn plain_message(m: &str) -> String {
    let mut out = String::with_capacity(m.len());
    let mut rest = m.trim();
    while let Some(i) = rest.find("expected ") {
        out.push_str(&rest[..i + "expected ".len()]);
        rest = &rest[i + "expected ".len()..];
        let word_end = |s: &str| {
            s.find(|c: char| !(c.is_alphanumeric() || c == '_'))
                .unwrap_or(s.len())
        };
        if let Some(after) = rest.strip_prefix("struct ") {
            out.push_str("a table");
            rest = &after[word_end(after)..];
            continue;
        }
        let w = word_end(rest);
        let plain = match &rest[..w] {
            // Unsigned: "-3" is refused for its sign, so say so.
            "usize" | "u8" | "u16" | "u32" | "u64" => Some("a whole number, 0 or more"),
            "isize" | "i8" | "i16" | "i32" | "i64" => Some("a whole number"),
            "f32" | "f64" => Some("a number"),
            _ => None,
        };
        if let Some(p) = plain {
            out.push_str(p);
            rest = &rest[w..];
        }
    }
    out.push_str(rest);
    out
}

/// Wheel speed errors of a robot group: a wheel told to turn at `v` (after the model's speed
/// cap) turns at `v (1 + b) (1 + noise e)`, with `b` drawn once per wheel and robot from a
/// normal of spread `bias` (wheel diameter, motor calibration) and `e` a standard normal drawn
/// afresh every tick (slip, motor control). Off by default: no preset sets them.
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct WheelOptions {
    /// Relative spread of each wheel's speed, drawn every tick. Default 0.
    #[serde(default)]
    #[cfg_attr(feature = "schema", schemars(range(min = 0.0, max = limits::MAX_WHEEL_SPREAD)))]
    pub noise: f32,
    /// Relative spread of each wheel's fixed speed factor, drawn once per robot. Default 0.
    #[serde(default)]
    #[cfg_attr(feature = "schema", schemars(range(min = 0.0, max = limits::MAX_WHEEL_SPREAD)))]
    pub bias: f32,
}

impl WheelOptions {
    /// Whether every wheel turns exactly as commanded (both spreads zero).
    pub fn is_exact(&self) -> bool {
        self.noise == 0.0 && self.bias == 0.0
    }
}

/// When robots enter the arena.
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct Release {
    /// Seconds between releases (0: all at once). Robots enter in placement order.
    #[serde(default)]
    #[cfg_attr(feature = "schema", schemars(range(min = 0.0, max = limits::MAX_DURATION_S)))]
    pub interval_s: f32,
    /// Time of the first release.
    #[serde(default)]
    #[cfg_attr(feature = "schema", schemars(range(min = 0.0, max = limits::MAX_DURATION_S)))]
    pub start_s: f32,
}

/// What the colour-blob camera returns.
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum CameraKind {
    /// As ARGoS's colour-blob camera: lit LEDs in range and in line of sight, with bearing and
    /// a noisy distance; no object bodies, no identity.
    #[default]
    Blob,
    /// An ablation, never a default: also every coloured body (objects) with the exact
    /// distance to its nearest surface point. `formica check` warns about it.
    Oracle,
}

impl CameraKind {
    /// Lower-case name, as in scenario files.
    pub fn name(self) -> &'static str {
        match self {
            CameraKind::Blob => "blob",
            CameraKind::Oracle => "oracle",
        }
    }
}

/// Sensor options of a robot group. `noise` picks a preset (default `"realistic"`, see
/// [`crate::noise`]); every noise key set here overrides the preset's value.
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct SensorOptions {
    /// Noise preset: `"realistic"` (default) or `"none"`.
    #[serde(default)]
    pub noise: NoisePreset,
    /// Proximity: relative spread (fraction of the reading).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[cfg_attr(feature = "schema", schemars(range(min = 0.0, max = limits::MAX_SPREAD)))]
    pub proximity_noise: Option<f32>,
    /// Proximity: additive spread (reading units).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[cfg_attr(feature = "schema", schemars(range(min = 0.0, max = limits::MAX_SPREAD)))]
    pub proximity_floor: Option<f32>,
    /// Light: relative spread (fraction of the reading).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[cfg_attr(feature = "schema", schemars(range(min = 0.0, max = limits::MAX_SPREAD)))]
    pub light_noise: Option<f32>,
    /// Light: additive spread (reading units).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[cfg_attr(feature = "schema", schemars(range(min = 0.0, max = limits::MAX_SPREAD)))]
    pub light_floor: Option<f32>,
    /// Ambient light added to every light sensor (reading units, below 1).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[cfg_attr(feature = "schema", schemars(range(min = 0.0, max = 0.999)))]
    pub ambient_light: Option<f32>,
    /// Positioning: spread per coordinate (m).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[cfg_attr(feature = "schema", schemars(range(min = 0.0, max = limits::MAX_SIZE_M)))]
    pub position_noise: Option<f32>,
    /// Positioning: heading spread (rad).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[cfg_attr(feature = "schema", schemars(range(min = 0.0, max = limits::MAX_SPREAD)))]
    pub heading_noise: Option<f32>,
    /// Object beacon: spread per coordinate (m).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[cfg_attr(feature = "schema", schemars(range(min = 0.0, max = limits::MAX_SIZE_M)))]
    pub beacon_noise: Option<f32>,
    /// Object beacon: largest distance (m) at which the robot gets it (default: any).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[cfg_attr(feature = "schema", schemars(range(min = limits::MIN_SIZE_M, max = 2.0 * limits::MAX_COORD_M)))]
    pub beacon_range: Option<f32>,
    /// What the colour-blob camera returns: `"blob"` (default) or `"oracle"` (ablation).
    #[serde(default)]
    pub camera: CameraKind,
    /// Blob camera: bearing spread (rad).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[cfg_attr(feature = "schema", schemars(range(min = 0.0, max = limits::MAX_SPREAD)))]
    pub camera_noise: Option<f32>,
    /// Blob camera: relative distance spread.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[cfg_attr(feature = "schema", schemars(range(min = 0.0, max = limits::MAX_SPREAD)))]
    pub camera_distance_noise: Option<f32>,
    /// Range of the colour-blob camera (m). Default 1.5.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[cfg_attr(feature = "schema", schemars(range(min = limits::MIN_SIZE_M, max = limits::MAX_RANGE_M)))]
    pub camera_range: Option<f32>,
    /// Colour scan: number of bearing bins round the robot. Default 36.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[cfg_attr(feature = "schema", schemars(range(min = 4, max = 360)))]
    pub scan_bins: Option<u32>,
    /// Colour scan: range (m). Default 1.0.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[cfg_attr(feature = "schema", schemars(range(min = limits::MIN_SIZE_M, max = limits::MAX_RANGE_M)))]
    pub scan_range: Option<f32>,
    /// Colour scan: ranges are rounded to multiples of this (m). Default 0.02.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[cfg_attr(feature = "schema", schemars(range(min = 0.0, max = limits::MAX_RANGE_M)))]
    pub scan_step: Option<f32>,
    /// Colour scan: relative range spread.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[cfg_attr(feature = "schema", schemars(range(min = 0.0, max = limits::MAX_SPREAD)))]
    pub scan_noise: Option<f32>,
}

/// A group's sensor settings, resolved: the preset with the file's overrides applied.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SensorConfig {
    /// Noise levels.
    pub noise: NoiseModel,
    /// The preset they started from.
    pub preset: NoisePreset,
    /// Blob camera kind.
    pub camera: CameraKind,
    /// Blob camera range (m).
    pub camera_range: f32,
    /// Beacon range (m; infinite: any).
    pub beacon_range: f32,
    /// Colour scan bins.
    pub scan_bins: usize,
    /// Colour scan range (m).
    pub scan_range: f32,
    /// Colour scan range resolution (m).
    pub scan_step: f32,
}

impl Default for SensorConfig {
    fn default() -> Self {
        SensorOptions {
            noise: NoisePreset::None,
            ..SensorOptions::default()
        }
        .resolve(ModelKind::Khepera4)
    }
}

impl SensorOptions {
    /// The preset for `kind` with this file's overrides applied.
    pub fn resolve(&self, kind: ModelKind) -> SensorConfig {
        let mut n = noise::preset(kind, self.noise);
        let set = |slot: &mut f32, v: Option<f32>| {
            if let Some(v) = v {
                *slot = v;
            }
        };
        set(&mut n.proximity_noise, self.proximity_noise);
        set(&mut n.proximity_floor, self.proximity_floor);
        set(&mut n.light_noise, self.light_noise);
        set(&mut n.light_floor, self.light_floor);
        set(&mut n.ambient_light, self.ambient_light);
        set(&mut n.position_noise, self.position_noise);
        set(&mut n.heading_noise, self.heading_noise);
        set(&mut n.beacon_noise, self.beacon_noise);
        set(&mut n.camera_noise, self.camera_noise);
        set(&mut n.camera_distance_noise, self.camera_distance_noise);
        set(&mut n.scan_noise, self.scan_noise);
        SensorConfig {
            noise: n,
            preset: self.noise,
            camera: self.camera,
            camera_range: self.camera_range.unwrap_or(1.5),
            beacon_range: self.beacon_range.unwrap_or(f32::INFINITY),
            scan_bins: self.scan_bins.unwrap_or(36) as usize,
            scan_range: self.scan_range.unwrap_or(1.0),
            scan_step: self.scan_step.unwrap_or(0.02),
        }
    }

    /// Rejects negative spreads, an ambient level of 1 or more and empty ranges.
    pub fn validate(&self) -> Result<(), String> {
        let spreads = [
            ("proximity_noise", self.proximity_noise),
            ("proximity_floor", self.proximity_floor),
            ("light_noise", self.light_noise),
            ("light_floor", self.light_floor),
            ("ambient_light", self.ambient_light),
            ("position_noise", self.position_noise),
            ("heading_noise", self.heading_noise),
            ("beacon_noise", self.beacon_noise),
            ("camera_noise", self.camera_noise),
            ("camera_distance_noise", self.camera_distance_noise),
            ("scan_noise", self.scan_noise),
            ("scan_step", self.scan_step),
        ];
        for (k, v) in spreads {
            if let Some(v) = v {
                if !(v >= 0.0) {
                    return Err(format!("sensors.{k}: expected a number >= 0, got {v}"));
                }
            }
        }
        if self.ambient_light.is_some_and(|a| a >= 1.0) {
            return Err("sensors.ambient_light: expected a level below 1".into());
        }
        for (k, v) in [
            ("camera_range", self.camera_range),
            ("scan_range", self.scan_range),
            ("beacon_range", self.beacon_range),
        ] {
            if let Some(v) = v {
                if !(v > 0.0) {
                    return Err(format!("sensors.{k}: expected a positive range, got {v}"));
                }
            }
        }
        if let Some(b) = self.scan_bins {
            if !(4..=360).contains(&b) {
                return Err(format!("sensors.scan_bins: expected 4 to 360, got {b}"));
            }
        }
        Ok(())
    }
}

/// A group of identical robots.
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RobotGroup {
    /// Robot model: a name in the scenario's [`Registry`] (built in: `khepera4`, `foot-bot`,
    /// `e-puck`).
    #[serde(default = "default_model")]
    #[cfg_attr(feature = "schema", schemars(with = "String"))]
    pub model: Spanned<String>,
    /// Number of robots (default: the number of explicit poses).
    #[serde(default)]
    #[cfg_attr(feature = "schema", schemars(range(min = 1, max = limits::MAX_ROBOTS)))]
    pub count: Option<usize>,
    /// Controller: a name in the scenario's [`Registry`].
    #[cfg_attr(feature = "schema", schemars(with = "String"))]
    pub controller: Spanned<String>,
    /// Controller parameters.
    #[serde(default)]
    #[cfg_attr(
        feature = "schema",
        schemars(with = "Option<serde_json::Map<String, serde_json::Value>>")
    )]
    pub params: Option<Spanned<toml::Table>>,
    /// Start positions.
    #[cfg_attr(feature = "schema", schemars(with = "Placement"))]
    pub placement: Spanned<Placement>,
    /// Release schedule.
    #[serde(default)]
    pub release: Release,
    /// Sensor noise and ranges (default: the `"realistic"` noise preset).
    #[serde(default)]
    pub sensors: SensorOptions,
    /// Wheel speed errors (default: none, every wheel turns as commanded).
    #[serde(default, skip_serializing_if = "WheelOptions::is_exact")]
    pub wheels: WheelOptions,
}

fn default_model() -> Spanned<String> {
    Spanned::new(0..0, crate::robot::ModelKind::Khepera4.name().to_string())
}

/// Run settings.
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RunSpec {
    /// Control ticks per second.
    #[serde(default = "default_tick_hz")]
    #[cfg_attr(feature = "schema", schemars(range(min = limits::TICK_HZ.0, max = limits::TICK_HZ.1)))]
    pub tick_hz: f32,
    /// Physics steps per tick: `"auto"` (the default, see [`Substeps::Auto`]) or a number.
    #[serde(default)]
    pub substeps: Substeps,
    /// Simulated time limit (s).
    #[serde(default = "default_duration")]
    #[cfg_attr(
        feature = "schema",
        schemars(range(max = limits::MAX_DURATION_S), extend("exclusiveMinimum" = 0))
    )]
    pub duration_s: f32,
    /// Default seed.
    #[serde(default = "default_seed")]
    #[cfg_attr(feature = "schema", schemars(range(min = 0, max = limits::MAX_SEED)))]
    pub seed: u64,
}

fn default_tick_hz() -> f32 {
    10.0
}
/// Physics steps per control tick, as a scenario gives them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Substeps {
    /// Each tick, as few as keep every body to at most [`MAX_STEP_FRACTION`] of the smallest
    /// robot radius per step, from the fastest body or wheel command at the start of the tick:
    /// one step for Khepera IV at 0.1 m/s at 10 ticks/s, four at their top speed of 0.8 m/s.
    #[default]
    Auto,
    /// Exactly this many (1 to 100).
    Fixed(u32),
}

/// The most a body may move in one physics step, as a fraction of the smallest robot radius,
/// for contacts to hold (no robot passes through another).
pub const MAX_STEP_FRACTION: f32 = 1.0 / 3.0;

/// Physics steps per tick that keep a body moving at `speed` (m/s) to [`MAX_STEP_FRACTION`] of
/// `radius` per step, at `tick_hz` (1 to 100).
pub fn steps_for(speed: f32, radius: f32, tick_hz: f32) -> u32 {
    let per_tick = speed / tick_hz;
    let steps = (per_tick / (MAX_STEP_FRACTION * radius)).ceil();
    if steps.is_finite() {
        (steps as u32).clamp(1, 100)
    } else {
        1
    }
}

#[cfg(feature = "schema")]
impl schemars::JsonSchema for Substeps {
    fn schema_name() -> std::borrow::Cow<'static, str> {
        "Substeps".into()
    }
    fn json_schema(_: &mut schemars::SchemaGenerator) -> schemars::Schema {
        schemars::json_schema!({
            "description": "Physics steps per control tick: \"auto\" (as few as keep every body to a third of the smallest robot radius per step) or a fixed number.",
            "anyOf": [
                { "type": "string", "const": "auto" },
                { "type": "integer", "minimum": 1, "maximum": 100 }
            ]
        })
    }
}

impl Serialize for Substeps {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            Substeps::Auto => s.serialize_str("auto"),
            Substeps::Fixed(n) => s.serialize_u32(*n),
        }
    }
}

impl<'de> Deserialize<'de> for Substeps {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl serde::de::Visitor<'_> for V {
            type Value = Substeps;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("\"auto\" or an integer from 1 to 100")
            }
            fn visit_str<E: serde::de::Error>(self, v: &str) -> Result<Substeps, E> {
                if v == "auto" {
                    Ok(Substeps::Auto)
                } else {
                    Err(E::invalid_value(serde::de::Unexpected::Str(v), &self))
                }
            }
            fn visit_i64<E: serde::de::Error>(self, v: i64) -> Result<Substeps, E> {
                match u32::try_from(v) {
                    Ok(n) if (1..=100).contains(&n) => Ok(Substeps::Fixed(n)),
                    _ => Err(E::invalid_value(serde::de::Unexpected::Signed(v), &self)),
                }
            }
            fn visit_u64<E: serde::de::Error>(self, v: u64) -> Result<Substeps, E> {
                self.visit_i64(i64::try_from(v).unwrap_or(i64::MAX))
            }
        }
        d.deserialize_any(V)
    }
}
fn default_duration() -> f32 {
    1200.0
}
fn default_seed() -> u64 {
    1
}

impl Default for RunSpec {
    fn default() -> Self {
        Self {
            tick_hz: default_tick_hz(),
            substeps: Substeps::Auto,
            duration_s: default_duration(),
            seed: default_seed(),
        }
    }
}

/// Stop rules.
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StopSpec {
    /// Stop with `success` when the object's centre is within this distance of the goal's floor
    /// point. Default (Queiroz & MacRae): (goal_size + object size) / 2 + 0.05, object size being
    /// a lone disc's diameter, otherwise its bounding diagonal in its own frame, as its outline
    /// is written (an outline written turned has a larger box than the same outline turned by
    /// `yaw_deg`; `check` prints it).
    #[serde(default)]
    #[cfg_attr(feature = "schema", schemars(range(min = 0.0, max = limits::MAX_COORD_M)))]
    pub goal_radius: Option<f32>,
    /// Size of the goal region (m), for the default goal radius.
    #[serde(default = "default_goal_size")]
    #[cfg_attr(feature = "schema", schemars(range(min = 0.0, max = limits::MAX_SIZE_M)))]
    pub goal_size: f32,
    /// Stop with `success` when the object reaches the goal.
    #[serde(default = "default_true")]
    pub on_goal: bool,
    /// Stop with `wall` when the object touches a wall.
    #[serde(default = "default_true")]
    pub on_wall: bool,
    /// Stop with `success` once every robot is released and this fraction of them is attached
    /// to the object (filling experiments). Off unless set.
    #[serde(default)]
    #[cfg_attr(
        feature = "schema",
        schemars(range(max = 1.0), extend("exclusiveMinimum" = 0))
    )]
    pub on_filled: Option<f32>,
}

fn default_goal_size() -> f32 {
    0.2
}

impl Default for StopSpec {
    fn default() -> Self {
        Self {
            goal_radius: None,
            goal_size: default_goal_size(),
            on_goal: true,
            on_wall: true,
            on_filled: None,
        }
    }
}

/// The whole file, as written.
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ScenarioSpec {
    /// Name used in results (default: the file stem).
    #[serde(default)]
    pub name: Option<String>,
    /// Free text.
    #[serde(default)]
    pub description: Option<String>,
    /// The arena.
    pub arena: Arena,
    /// Extra walls.
    #[serde(default)]
    #[cfg_attr(feature = "schema", schemars(with = "Vec<WallSpec>", length(max = limits::MAX_ITEMS)))]
    pub walls: Vec<Spanned<WallSpec>>,
    /// Lights.
    #[serde(default)]
    #[cfg_attr(feature = "schema", schemars(with = "Vec<LightSpec>", length(max = limits::MAX_ITEMS)))]
    pub lights: Vec<Spanned<LightSpec>>,
    /// Objects.
    #[serde(default)]
    #[cfg_attr(feature = "schema", schemars(with = "Vec<ObjectSpec>", length(max = limits::MAX_ITEMS)))]
    pub objects: Vec<Spanned<ObjectSpec>>,
    /// Robot groups.
    #[serde(default)]
    #[cfg_attr(feature = "schema", schemars(with = "Vec<RobotGroup>", length(max = limits::MAX_ITEMS)))]
    pub robots: Vec<Spanned<RobotGroup>>,
    /// Run settings.
    #[serde(default)]
    pub run: RunSpec,
    /// Stop rules.
    #[serde(default)]
    pub stop: StopSpec,
}

/// A loaded, validated scenario together with its source text (for error positions) and the
/// registry its names were checked against (and resolve in when a world is built).
#[derive(Debug, Clone)]
pub struct Scenario {
    /// What the file says.
    pub spec: ScenarioSpec,
    /// File name, for messages.
    pub file: String,
    /// Name for results.
    pub name: String,
    text: String,
    registry: Registry,
    /// For a scenario made with overrides: what it was made from, so that an error found
    /// after parsing (building its world) points at the file or the override that wrote the
    /// key, not at the text written back with the overrides.
    overridden: Option<std::sync::Arc<Overridden>>,
}

/// A scenario's file text and the overrides applied to it ([`Scenario::parse_with_overrides`]).
#[derive(Debug)]
struct Overridden {
    base_text: std::sync::Arc<str>,
    overrides: Vec<(String, toml::Value)>,
    origin_file: String,
    origin_text: std::sync::Arc<str>,
}

thread_local! {
    /// The texts of the last few [`Overridden`] made on this thread: a sweep's parameter sets
    /// share their base scenarios' and the sweep file's texts instead of holding a copy each.
    static RECENT_TEXTS: std::cell::RefCell<Vec<std::sync::Arc<str>>> =
        const { std::cell::RefCell::new(Vec::new()) };
}

/// `text` as a shared text: one of the recent ones if it is the same.
fn shared_text(text: &str) -> std::sync::Arc<str> {
    RECENT_TEXTS.with(|recent| {
        let mut recent = recent.borrow_mut();
        if let Some(t) = recent.iter().find(|t| ***t == *text) {
            return t.clone();
        }
        let t: std::sync::Arc<str> = std::sync::Arc::from(text);
        if recent.len() == 16 {
            recent.remove(0);
        }
        recent.push(t.clone());
        t
    })
}

/// An error at the override `key` (its position in the file the overrides come from).
fn override_error(
    origin_file: &str,
    origin_text: &str,
    key: &str,
    message: String,
) -> ScenarioError {
    let offset = origin_text
        .find(&format!("\"{key}\""))
        .or_else(|| origin_text.find(&format!("'{key}'")))
        .or_else(|| origin_text.find(key))
        .unwrap_or(0);
    let (line, column) = line_col(origin_text, offset);
    ScenarioError::Invalid {
        file: origin_file.to_string(),
        line,
        column,
        message,
    }
}

impl Overridden {
    /// An error found at byte `offset` of the written-back `text`: at the override that wrote
    /// the key there (the one whose path shares most steps with it), or else where the file
    /// `file` writes that key.
    fn error_at(&self, text: &str, file: &str, offset: usize, message: String) -> ScenarioError {
        let path = limits::path_at(text, offset);
        let shared = |key: &str| {
            let steps: Vec<&str> = key.split('.').collect();
            let n = steps.len().min(path.len());
            (n > 0 && steps[..n].iter().zip(&path[..n]).all(|(a, b)| a == b)).then_some(n)
        };
        let by = self
            .overrides
            .iter()
            .filter_map(|(k, v)| shared(k).map(|n| (n, k, v)))
            .max_by_key(|(n, _, _)| *n);
        let mut message = message;
        if let Some((_, key, value)) = by {
            // An override at or above what the error is about wrote it; one below it (a key of
            // the object the error is about) may have nothing to do with it (`objects.0.height`
            // for an object outside the arena), unless the message names its key.
            let last = key.rsplit('.').next().unwrap_or(key);
            if key.split('.').count() <= path.len() || message.contains(&format!("`{last}`")) {
                return override_error(
                    &self.origin_file,
                    &self.origin_text,
                    key,
                    format!("`{key}` = {value}: {file} rejects it: {message}"),
                );
            }
            message += &format!(" (with `{key}` = {value} from {})", self.origin_file);
        }
        // Not overridden: where the file writes it (`robots[0].count` as `span_of` spells it).
        let mut dotted = String::new();
        for step in &path {
            if step.parse::<usize>().is_ok() {
                dotted += &format!("[{step}]");
            } else {
                if !dotted.is_empty() {
                    dotted.push('.');
                }
                dotted += step;
            }
        }
        let at = limits::span_of(&self.base_text, &dotted).map_or(0, |s| s.start);
        let (line, column) = line_col(&self.base_text, at);
        ScenarioError::Invalid {
            file: file.to_string(),
            line,
            column,
            message,
        }
    }
}

impl fmt::Display for Scenario {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.name)
    }
}

/// 1-based line and column of a byte offset in `text`.
pub fn line_col(text: &str, offset: usize) -> (usize, usize) {
    let offset = offset.min(text.len());
    let before = &text[..offset];
    let line = before.matches('\n').count() + 1;
    let col = before.rfind('\n').map_or(offset, |p| offset - p - 1) + 1;
    (line, col)
}

impl Scenario {
    /// Reads and validates a scenario file against the process-wide [`Registry::global`].
    pub fn load(path: &std::path::Path) -> Result<Scenario, ScenarioError> {
        Self::load_in(path, &Registry::global())
    }

    pub(crate) fn load_in(
        path: &std::path::Path,
        registry: &Registry,
    ) -> Result<Scenario, ScenarioError> {
        let file = path.display().to_string();
        let text = limits::read_text(path).map_err(|e| limits::read_error(&file, &e))?;
        Self::parse_in(&text, &file, registry)
    }

    /// Parses and validates scenario text against the process-wide [`Registry::global`];
    /// `file` names it in errors.
    pub fn parse(text: &str, file: &str) -> Result<Scenario, ScenarioError> {
        Self::parse_in(text, file, &Registry::global())
    }

    pub(crate) fn parse_in(
        text: &str,
        file: &str,
        registry: &Registry,
    ) -> Result<Scenario, ScenarioError> {
        let invalid = |at: usize, message: String| {
            let (line, column) = line_col(text, at);
            ScenarioError::Invalid {
                file: file.to_string(),
                line,
                column,
                message,
            }
        };
        if text.len() > limits::MAX_FILE_BYTES {
            return Err(invalid(
                0,
                format!(
                    "the file has {} bytes, more than the {} a scenario may have",
                    text.len(),
                    limits::MAX_FILE_BYTES
                ),
            ));
        }
        if let Some((at, message)) = limits::too_large(text) {
            return Err(invalid(at, message));
        }
        if let Some((span, message)) = limits::wrong_length(text) {
            return Err(invalid(span.start, message));
        }
        if let Some((at, token)) = non_finite_literal(text) {
            let (line, column) = line_col(text, at);
            return Err(ScenarioError::Invalid {
                file: file.to_string(),
                line,
                column,
                message: format!("expected a finite number, found `{token}`"),
            });
        }
        let spec: ScenarioSpec = toml::from_str(text).map_err(|e| {
            let message = plain_message(e.message());
            // A whole-file error (a missing top-level key) has no span: point at the file's
            // first entry, where the key belongs, rather than at 1:1 (a comment, often).
            let at = e
                .span()
                .filter(|s| s.start > 0)
                .or_else(|| limits::span_of(text, ""))
                .map_or(0, |s| s.start);
            invalid(at, message)
        })?;
        let name = spec.name.clone().unwrap_or_else(|| {
            std::path::Path::new(file)
                .file_stem()
                .map_or_else(|| file.to_string(), |s| s.to_string_lossy().into_owned())
        });
        let sc = Scenario {
            spec,
            file: file.to_string(),
            name,
            text: text.to_string(),
            registry: registry.clone(),
            overridden: None,
        };
        sc.validate()?;
        Ok(sc)
    }

    /// Parses the scenario `text` (named `file`) with some of its keys replaced: the sweep's
    /// override mechanism. Each override is a dotted key path into the file (`"run.duration_s"`,
    /// array elements by index: `"robots.0.count"`, `"objects.0.shape"`) and the value to put
    /// there; missing tables on the way are created, later overrides win. The result is written
    /// back to TOML and goes through [`Scenario::parse`], so every check of a hand-written file
    /// applies.
    ///
    /// `origin` is `(file name, text)` of the file the overrides come from (a sweep file): errors
    /// name that file, the position of the offending key in it, the key and, for values the
    /// scenario rejects, what [`Scenario::parse`] said. Names resolve in [`Registry::global`].
    pub fn parse_with_overrides(
        text: &str,
        file: &str,
        overrides: &[(String, toml::Value)],
        origin: (&str, &str),
    ) -> Result<Scenario, ScenarioError> {
        Self::parse_with_overrides_in(text, file, overrides, origin, &Registry::global())
    }

    pub(crate) fn parse_with_overrides_in(
        text: &str,
        file: &str,
        overrides: &[(String, toml::Value)],
        origin: (&str, &str),
        registry: &Registry,
    ) -> Result<Scenario, ScenarioError> {
        let parse = |text: &str| Scenario::parse_in(text, file, registry);
        let (origin_file, origin_text) = origin;
        // Where the key is written in the origin file (quoted or bare), for the message.
        let at =
            |key: &str, message: String| override_error(origin_file, origin_text, key, message);
        // Sets `value` at the dotted `key` in `root`.
        fn set_path(root: &mut toml::Table, key: &str, value: toml::Value) -> Result<(), String> {
            let parts: Vec<&str> = key.split('.').collect();
            if parts.iter().any(|p| p.is_empty()) {
                return Err("expected a dotted key such as `robots.0.count`".into());
            }
            if parts.len() > limits::MAX_NESTING {
                return Err(format!(
                    "expected a key of at most {} dot-separated parts, found {}",
                    limits::MAX_NESTING,
                    parts.len()
                ));
            }
            let mut here: &mut toml::Value = match root.get_mut(parts[0]) {
                Some(v) if parts.len() > 1 => v,
                _ if parts.len() == 1 => {
                    root.insert(parts[0].to_string(), value);
                    return Ok(());
                }
                _ => root
                    .entry(parts[0].to_string())
                    .or_insert_with(|| toml::Value::Table(toml::Table::new())),
            };
            for (k, part) in parts.iter().enumerate().skip(1) {
                let last = k + 1 == parts.len();
                let so_far = parts[..k].join(".");
                here = match here {
                    toml::Value::Array(items) => {
                        let n = items.len();
                        let i: usize = part.parse().map_err(|_| {
                            format!("`{so_far}` is an array: expected an index (0 to {}) after it, found `{part}`", n.saturating_sub(1))
                        })?;
                        let slot = items.get_mut(i).ok_or_else(|| {
                            format!("`{so_far}` has {n} element(s): index {i} is out of range")
                        })?;
                        if last {
                            *slot = value;
                            return Ok(());
                        }
                        slot
                    }
                    toml::Value::Table(t) => {
                        if last {
                            t.insert((*part).to_string(), value);
                            return Ok(());
                        }
                        t.entry((*part).to_string())
                            .or_insert_with(|| toml::Value::Table(toml::Table::new()))
                    }
                    other => {
                        return Err(format!(
                            "`{so_far}` is {}, not a table or an array: cannot set `{part}` in it",
                            a_toml_type(other)
                        ))
                    }
                };
            }
            Ok(())
        }
        let mut root: toml::Table = toml::from_str(text).map_err(|e| {
            let (line, column) = line_col(text, e.span().map_or(0, |s| s.start));
            ScenarioError::Invalid {
                file: file.to_string(),
                line,
                column,
                message: e.message().trim().to_string(),
            }
        })?;
        let write = |root: &toml::Table| {
            toml::to_string(root).map_err(|e| ScenarioError::Invalid {
                file: origin_file.to_string(),
                line: 1,
                column: 1,
                message: format!("cannot write {file} back with the overrides: {e}"),
            })
        };
        let base = root.clone();
        for (key, value) in overrides {
            set_path(&mut root, key, value.clone())
                .map_err(|m| at(key, format!("`{key}`: {m} (in {file})")))?;
        }
        let full = match parse(&write(&root)?) {
            Ok(mut sc) => {
                if !overrides.is_empty() {
                    sc.overridden = Some(std::sync::Arc::new(Overridden {
                        base_text: shared_text(text),
                        overrides: overrides.to_vec(),
                        origin_file: origin_file.to_string(),
                        origin_text: shared_text(origin_text),
                    }));
                }
                return Ok(sc);
            }
            Err(e) => e,
        };
        let message_of = |e: &ScenarioError| match e {
            ScenarioError::Invalid { message, .. } | ScenarioError::Io { message, .. } => {
                message.clone()
            }
        };
        // Name the first override after which the scenario no longer validates; if the base
        // file is already invalid by itself, report it at its own position.
        let mut partial = base;
        if let Err(e) = parse(&write(&partial)?) {
            if message_of(&e) == message_of(&full) {
                parse(text)?;
            }
        }
        for (key, value) in overrides {
            // Cannot fail: the same path was set above.
            set_path(&mut partial, key, value.clone())
                .map_err(|m| at(key, format!("`{key}`: {m}")))?;
            if let Err(e) = parse(&write(&partial)?) {
                let mut m = format!("`{key}` = {value}: {file} rejects it: {}", message_of(&e));
                // `[set.robots.0]` in a sweep file makes a table keyed "0" where the scenario
                // has a list.
                if value.is_table() && m.contains("expected a sequence") {
                    m += " (a list element goes by its index in a quoted dotted key, \
                          \"robots.0.count\" = 3, not by a table such as [set.robots.0])";
                }
                return Err(at(key, m));
            }
        }
        Err(full)
    }

    /// The controller that robot group `g`'s `params` were written for: the file's controller
    /// of that group when the file gives the group params and no override replaced the whole
    /// table (an override of one key, `robots.0.params.speed`, merges into the file's);
    /// `None` otherwise. Lets an error about params that a replaced controller refuses say
    /// whose they are.
    pub fn params_written_for(&self, g: usize) -> Option<String> {
        let grp = self.spec.robots.get(g)?.get_ref();
        grp.params.as_ref()?;
        let Some(o) = &self.overridden else {
            return Some(grp.controller.get_ref().clone());
        };
        let replaced = o.overrides.iter().any(|(k, _)| {
            k == "robots" || *k == format!("robots.{g}") || *k == format!("robots.{g}.params")
        });
        if replaced {
            return None;
        }
        let base: toml::Table = o.base_text.parse().ok()?;
        let group = base.get("robots")?.as_array()?.get(g)?;
        group.get("params")?;
        Some(group.get("controller")?.as_str()?.to_string())
    }

    /// An error positioned at a span of the source (for a scenario made with overrides, at
    /// the override that wrote the key there, or where the file writes it).
    pub fn error_at(&self, span: Range<usize>, message: impl Into<String>) -> ScenarioError {
        if let Some(o) = &self.overridden {
            return o.error_at(&self.text, &self.file, span.start, message.into());
        }
        let (line, column) = line_col(&self.text, span.start);
        ScenarioError::Invalid {
            file: self.file.clone(),
            line,
            column,
            message: message.into(),
        }
    }

    /// An error at the key `path` (`run.tick_hz`, `objects[0].at[1]`) as the source writes it,
    /// or, for a key it leaves out, at the nearest table on the way that it writes.
    pub fn error_at_key(&self, path: &str, message: impl Into<String>) -> ScenarioError {
        let span = limits::span_of(&self.text, path).unwrap_or(0..0);
        self.error_at(span, message)
    }

    /// The source text.
    pub fn text(&self) -> &str {
        &self.text
    }

    /// The registry this scenario's names were checked against and resolve in.
    pub fn registry(&self) -> &Registry {
        &self.registry
    }

    /// The parts of object `i`, validated.
    pub fn object_parts(&self, i: usize) -> Result<Vec<Part>, ScenarioError> {
        let o = &self.spec.objects[i];
        let obj = o.get_ref();
        let label = format!("objects[{i}]{}", name_suffix(&obj.name));
        match (&obj.shape, obj.parts.is_empty()) {
            (Some(_), false) => Err(self.error_at(
                o.span(),
                format!("{label}: give either `shape` or `parts`, not both"),
            )),
            (None, true) => Err(self.error_at(
                o.span(),
                format!("{label}: expected a `shape` (box, disc, polygon or regular) or `parts`"),
            )),
            (Some(s), true) => Ok(vec![s
                .get_ref()
                .to_part()
                .map_err(|m| self.error_at(s.span(), format!("{label}.shape: {m}")))?]),
            (None, false) => obj
                .parts
                .iter()
                .enumerate()
                .map(|(k, p)| {
                    p.get_ref()
                        .to_part()
                        .map_err(|m| self.error_at(p.span(), format!("{label}.parts[{k}]: {m}")))
                })
                .collect(),
        }
    }

    /// The shape of wall `i` when it has one (`None`: a box of `size`); an error at the wall
    /// when it gives both `size` and `shape`, or neither.
    pub fn wall_part(&self, i: usize) -> Result<Option<Part>, ScenarioError> {
        let w = &self.spec.walls[i];
        match (&w.get_ref().size, &w.get_ref().shape) {
            (Some(_), None) => Ok(None),
            (None, Some(s)) => s
                .get_ref()
                .to_part()
                .map(Some)
                .map_err(|m| self.error_at(s.span(), format!("walls[{i}].shape: {m}"))),
            (Some(_), Some(_)) => Err(self.error_at(
                w.span(),
                format!("walls[{i}]: give either `size` (a box) or `shape`, not both"),
            )),
            (None, None) => Err(self.error_at(
                w.span(),
                format!(
                    "walls[{i}]: expected a `size` (a box) or a `shape` (box, disc, polygon or regular)"
                ),
            )),
        }
    }

    /// Number of robots in a group.
    pub fn group_count(&self, g: usize) -> usize {
        let grp = self.spec.robots[g].get_ref();
        match (&grp.count, &grp.placement.get_ref()) {
            (Some(n), _) => *n,
            (None, Placement::Poses(p)) => p.len(),
            (None, _) => 0,
        }
    }

    /// Total number of robots.
    pub fn robot_count(&self) -> usize {
        (0..self.spec.robots.len())
            .map(|g| self.group_count(g))
            .sum()
    }

    /// Index of the goal light, if any.
    pub fn goal_light(&self) -> Option<usize> {
        let l = &self.spec.lights;
        l.iter()
            .position(|x| x.get_ref().goal == Some(true))
            .or_else(|| (!l.is_empty() && l[0].get_ref().goal != Some(false)).then_some(0))
    }

    /// Whether a trial of this scenario can succeed: `stop.on_filled` is set, or `stop.on_goal`
    /// with a goal light and a movable object, or its registry holds loop functions of the
    /// user's own ([`Registry::has_own_loop_functions`]; theirs may end a run with success).
    /// One without
    /// (static filling, say) ends only by the wall rule or its time limit, and is judged by its
    /// metrics, not a success rate.
    pub fn has_success_rule(&self) -> bool {
        let stop = &self.spec.stop;
        self.registry.has_own_loop_functions()
            || stop.on_filled.is_some()
            || (stop.on_goal
                && self.goal_light().is_some()
                && self.spec.objects.iter().any(|o| o.get_ref().movable))
    }

    /// The robot models in use: the largest top speed and the smallest radius (m/s, m).
    pub fn speed_and_radius(&self) -> Option<(f32, f32)> {
        self.spec
            .robots
            .iter()
            .filter_map(|g| self.registry.robot_model(g.get_ref().model.get_ref()))
            .map(|m| (m.max_speed, m.radius))
            .reduce(|a, b| (a.0.max(b.0), a.1.min(b.1)))
    }

    /// The most physics steps a tick takes: the file's number, or for `"auto"` what a robot at
    /// its model's top speed needs (see [`Substeps::Auto`]).
    pub fn max_substeps(&self) -> u32 {
        match self.spec.run.substeps {
            Substeps::Fixed(n) => n,
            Substeps::Auto => self
                .speed_and_radius()
                .map_or(1, |(v, r)| steps_for(v, r, self.spec.run.tick_hz)),
        }
    }

    /// The physics guard: a warning if, with the tick rate and sub-steps in use, a robot at
    /// its model's top speed would move more than [`MAX_STEP_FRACTION`] of the smallest robot
    /// radius in one physics step (contacts are then not to be trusted: robots can pass
    /// through each other).
    pub fn physics_warning(&self) -> Option<String> {
        let (v, r) = self.speed_and_radius()?;
        let n = self.max_substeps();
        let step = v / (self.spec.run.tick_hz * n as f32);
        let limit = MAX_STEP_FRACTION * r;
        (step > limit * (1.0 + 1e-6)).then(|| {
            format!(
                "at {} ticks/s and {n} physics step(s) per tick a robot at its top speed ({v} m/s) \
                 moves {:.1} mm per step, more than a third of the smallest robot radius \
                 ({:.1} mm): contacts cannot be trusted (robots may pass through each other); \
                 leave run.substeps out (\"auto\") or set it to at least {}",
                self.spec.run.tick_hz,
                step * 1000.0,
                limit * 1000.0,
                steps_for(v, r, self.spec.run.tick_hz),
            )
        })
    }

    fn validate(&self) -> Result<(), ScenarioError> {
        let s = &self.spec;
        if s.run.seed > limits::MAX_SEED {
            return Err(self.error_at_key(
                "run.seed",
                format!(
                    "run.seed: expected 0 to {} (TOML integers are 64-bit signed), got {}",
                    limits::MAX_SEED,
                    s.run.seed
                ),
            ));
        }
        // Fail closed: the checks below rely on every number being finite.
        let values = toml::Value::try_from(s).map_err(|e| {
            self.error_at_key("", format!("internal error re-reading the scenario: {e}"))
        })?;
        if let Some(path) = non_finite_path(&values, String::new()) {
            // Too large for 32 bits (a `nan` or `inf` literal is caught while parsing).
            return Err(self.error_at_key(&path, format!("{path}: expected a finite number")));
        }
        limits::check(self)?;
        for (i, w) in s.walls.iter().enumerate() {
            let ws = w.get_ref();
            // Every number is finite by now (checked above for the whole file).
            if !(ws.size.is_none_or(|s| s[0] > 0.0 && s[1] > 0.0) && ws.height > 0.0) {
                return Err(self.error_at(
                    w.span(),
                    format!("walls[{i}]: expected a positive `size` and `height`"),
                ));
            }
            self.wall_part(i)?;
        }
        // One goal: a second `goal = true` used to be taken for an ordinary light, silently.
        let goals: Vec<usize> = (0..s.lights.len())
            .filter(|&i| s.lights[i].get_ref().goal == Some(true))
            .collect();
        if let [first, second, ..] = goals[..] {
            return Err(self.error_at_key(
                &format!("lights[{second}].goal"),
                format!(
                    "lights[{second}]: a second goal light (lights[{first}] is the goal); a \
                     run has one goal: set goal = true on one light only"
                ),
            ));
        }
        for (i, l) in s.lights.iter().enumerate() {
            let ls = l.get_ref();
            if !(ls.height >= 0.0 && ls.intensity > 0.0) {
                return Err(self.error_at(
                    l.span(),
                    format!("lights[{i}]: expected `height` >= 0 and `intensity` > 0"),
                ));
            }
            let mut last = 0.0f32;
            for (k, w) in ls.path.iter().enumerate() {
                // Finite by now (limits::check).
                if w[0] < last {
                    return Err(self.error_at_key(
                        &format!("lights[{i}].path[{k}]"),
                        format!(
                            "lights[{i}].path[{k}]: expected times in increasing order from 0 \
                             (`[t_s, x, y]`), got t = {} after {last}",
                            w[0]
                        ),
                    ));
                }
                last = w[0];
            }
        }
        for (i, o) in s.objects.iter().enumerate() {
            self.object_parts(i)?;
            let obj = o.get_ref();
            let label = format!("objects[{i}]{}", name_suffix(&obj.name));
            if !(obj.mass > 0.0) || !(obj.height > 0.0) || !(obj.floor_mu >= 0.0) {
                return Err(self.error_at(
                    o.span(),
                    format!("{label}: expected mass > 0, height > 0 and floor_mu >= 0"),
                ));
            }
        }
        for (g, grp) in s.robots.iter().enumerate() {
            let gr = grp.get_ref();
            if gr.count == Some(0) {
                return Err(
                    self.error_at(grp.span(), format!("robots[{g}]: count must be at least 1"))
                );
            }
            match gr.placement.get_ref() {
                Placement::Poses(p) => {
                    if let Some(n) = gr.count {
                        if n != p.len() {
                            return Err(self.error_at(
                                gr.placement.span(),
                                format!("robots[{g}]: count = {n} but {} poses are given", p.len()),
                            ));
                        }
                    }
                }
                Placement::Random { min, max, .. } => {
                    if gr.count.is_none() {
                        return Err(self.error_at(
                            grp.span(),
                            format!("robots[{g}]: expected `count` for random placement"),
                        ));
                    }
                    if !(min[0] < max[0] && min[1] < max[1]) {
                        return Err(self.error_at(
                            gr.placement.span(),
                            format!(
                                "robots[{g}].placement.random: expected min < max on both axes"
                            ),
                        ));
                    }
                }
                Placement::Grid { spacing, .. } => {
                    if gr.count.is_none() {
                        return Err(self.error_at(
                            grp.span(),
                            format!("robots[{g}]: expected `count` for grid placement"),
                        ));
                    }
                    if !(*spacing > 0.0) {
                        return Err(self.error_at(
                            gr.placement.span(),
                            format!("robots[{g}].placement.grid: expected spacing > 0"),
                        ));
                    }
                }
            }
            if let Err(m) = gr.sensors.validate() {
                return Err(self.error_at(grp.span(), format!("robots[{g}].{m}")));
            }
            let model = gr.model.get_ref();
            if self.registry.robot_model(model).is_none() {
                // A defaulted model has no position of its own: point at the group.
                let span = Some(gr.model.span())
                    .filter(|s| !s.is_empty())
                    .unwrap_or_else(|| grp.span());
                return Err(self.error_at(
                    span,
                    format!("robots[{g}].model: {}", self.registry.unknown_model(model)),
                ));
            }
            let controller = gr.controller.get_ref();
            if !self.registry.has_controller(controller) {
                return Err(self.error_at(
                    gr.controller.span(),
                    format!(
                        "robots[{g}].controller: {}",
                        self.registry.unknown_controller(controller)
                    ),
                ));
            }
        }
        Ok(())
    }
}

fn name_suffix(name: &Option<String>) -> String {
    name.as_ref()
        .map_or(String::new(), |n| format!(" (\"{n}\")"))
}

/// Key path (`objects[0].at[1]`) of the first non-finite number in `v`, if any.
fn non_finite_path(v: &toml::Value, path: String) -> Option<String> {
    match v {
        toml::Value::Float(f) if !f.is_finite() => Some(path),
        toml::Value::Array(items) => items
            .iter()
            .enumerate()
            .find_map(|(i, x)| non_finite_path(x, format!("{path}[{i}]"))),
        toml::Value::Table(t) => t.iter().find_map(|(k, x)| {
            let p = if path.is_empty() {
                k.clone()
            } else {
                format!("{path}.{k}")
            };
            non_finite_path(x, p)
        }),
        _ => None,
    }
}

/// Byte offset and text of the first `nan` or `inf` (signed or not) written as a TOML value
/// (after `=`, `[` or `,`, outside strings and comments). No scenario number may be
/// non-finite: a NaN position or an infinite duration would make a run meaningless or endless.
fn non_finite_literal(text: &str) -> Option<(usize, &str)> {
    let b = text.as_bytes();
    let mut i = 0;
    let mut last = b'\n';
    while i < b.len() {
        let c = b[i];
        match c {
            b'#' => {
                while i < b.len() && b[i] != b'\n' {
                    i += 1;
                }
                continue;
            }
            b'"' | b'\'' => {
                let triple = b[i..].starts_with(if c == b'"' { b"\"\"\"" } else { b"\'\'\'" });
                let quote: &[u8] = match (c, triple) {
                    (b'"', true) => b"\"\"\"",
                    (b'"', false) => b"\"",
                    (_, true) => b"\'\'\'",
                    _ => b"\'",
                };
                i += quote.len();
                while i < b.len() && !b[i..].starts_with(quote) {
                    if c == b'"' && b[i] == b'\\' {
                        i += 1;
                    }
                    i += 1;
                }
                i += quote.len();
                last = b'"';
                continue;
            }
            b'+' | b'-' | b'i' | b'n' if matches!(last, b'=' | b'[' | b',') => {
                let start = i;
                let sign = usize::from(c == b'+' || c == b'-');
                let word = &b[i + sign..];
                let len = word
                    .iter()
                    .take_while(|x| x.is_ascii_alphanumeric() || **x == b'_')
                    .count();
                let rest = word[len..].iter().find(|x| !matches!(x, b' ' | b'\t'));
                if matches!(&word[..len], b"nan" | b"inf") && rest != Some(&b'=') {
                    return Some((start, &text[start..start + sign + len]));
                }
                i += sign + len.max(1);
                last = b'a';
                continue;
            }
            _ => {}
        }
        if !c.is_ascii_whitespace() {
            last = c;
        }
        i += 1;
    }
    None
}

/// A TOML value's type with its article, for messages: `an integer`, `a string`, `an array`.
pub fn a_toml_type(v: &toml::Value) -> &'static str {
    match v {
        toml::Value::String(_) => "a string",
        toml::Value::Integer(_) => "an integer",
        toml::Value::Float(_) => "a float",
        toml::Value::Boolean(_) => "a boolean",
        toml::Value::Datetime(_) => "a datetime",
        toml::Value::Array(_) => "an array",
        toml::Value::Table(_) => "a table",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_colour_is_listed_once_and_parses_by_its_name() {
        // A colour missing from `Color::ALL` has no LED code in Python (black had none).
        let names: std::collections::BTreeSet<&str> = Color::ALL.iter().map(|c| c.name()).collect();
        assert_eq!(names.len(), Color::ALL.len());
        for c in Color::ALL {
            // A name that does not parse back is the failure this test exists to report.
            let parsed: Color = toml::Value::String(c.name().into()).try_into().unwrap();
            assert_eq!(parsed, c);
        }
        // Exhaustive: a new variant fails to compile here until it is listed.
        for c in Color::ALL {
            match c {
                Color::Off
                | Color::Red
                | Color::Green
                | Color::Blue
                | Color::Yellow
                | Color::Magenta
                | Color::Cyan
                | Color::Orange
                | Color::White
                | Color::Grey
                | Color::Black => {}
            }
        }
    }

    const MIN: &str = r#"
[arena]
size = [6.0, 4.0]

[[objects]]
at = [-1.0, 0.0]
shape = { box = [0.5, 0.5] }

[[robots]]
count = 3
controller = "random-walk"
placement = { random = { min = [0.0, -1.0], max = [2.0, 1.0] } }
"#;

    fn err(text: &str) -> (usize, String) {
        match Scenario::parse(text, "t.toml").unwrap_err() {
            ScenarioError::Invalid {
                line,
                message,
                file,
                ..
            } => {
                assert_eq!(file, "t.toml");
                (line, message)
            }
            e => panic!("unexpected {e}"),
        }
    }

    #[test]
    fn minimal_file_loads() {
        let s = Scenario::parse(MIN, "t.toml").unwrap();
        assert_eq!(s.robot_count(), 3);
        assert_eq!(s.name, "t");
    }

    #[test]
    fn a_success_rule_needs_a_goal_and_a_movable_object_or_on_filled() {
        // Test code (this module is cfg(test)): every text below is MIN, a valid file, plus
        // valid keys, and "mine" and "transport" are valid names, so the unwraps and the
        // expect cannot fail unless the parser broke, which is the test failing.
        let parse = |t: &str| Scenario::parse(t, "t.toml").unwrap();
        // No light: nothing to reach.
        assert!(!parse(MIN).has_success_rule());
        let lit = format!("{MIN}\n[[lights]]\nat = [2.5, 0.0]\n");
        assert!(parse(&lit).has_success_rule());
        // A static object never reaches the goal; a light that is no goal is no goal.
        assert!(
            !parse(&lit.replace("at = [-1.0", "movable = false\nat = [-1.0")).has_success_rule()
        );
        assert!(!parse(&format!("{lit}goal = false\n")).has_success_rule());
        assert!(!parse(&format!("{lit}\n[stop]\non_goal = false\n")).has_success_rule());
        // Filling to a fraction is a success rule of its own.
        assert!(parse(&format!("{MIN}\n[stop]\non_filled = 0.8\n")).has_success_rule());
        // Loop functions of one's own may end a run with success.
        let mut registry = Registry::builtin();
        registry
            .loop_functions("mine", |_, _| None)
            .expect("a new name");
        assert!(registry.parse(MIN, "t.toml").unwrap().has_success_rule());
        // So may one that replaces a built-in under its name; the built-ins alone do not count.
        assert!(!Registry::builtin().has_own_loop_functions());
        let mut registry = Registry::builtin();
        registry
            .loop_functions("transport", |_, _| None)
            .expect("a built-in name");
        assert!(registry.parse(MIN, "t.toml").unwrap().has_success_rule());
    }

    #[test]
    fn unknown_key_names_line_and_expected_keys() {
        let text = MIN.replace("shape = {", "colour = \"red\"\nshape = {");
        let (line, msg) = err(&text);
        assert_eq!(line, 7);
        assert!(msg.contains("unknown field `colour`"), "{msg}");
        assert!(msg.contains("color"), "{msg}");
    }

    #[test]
    fn wrong_type_names_line() {
        let text = MIN.replace("count = 3", "count = \"three\"");
        let (line, msg) = err(&text);
        assert_eq!(line, 10);
        assert!(msg.contains("invalid type"), "{msg}");
    }

    #[test]
    fn self_intersecting_polygon_is_rejected_at_its_line() {
        let text = MIN.replace(
            "shape = { box = [0.5, 0.5] }",
            "shape = { polygon = [[0, 0], [1, 1], [1, 0], [0, 1]] }",
        );
        let (line, msg) = err(&text);
        assert_eq!(line, 7);
        assert!(msg.contains("self-intersecting"), "{msg}");
    }

    #[test]
    fn non_finite_numbers_are_rejected_where_written() {
        // In an array over two lines, signed, and as an inline-table value.
        let text = MIN.replace("size = [6.0, 4.0]", "size = [6.0,\n  -inf]");
        let (line, msg) = err(&text);
        assert_eq!(line, 4);
        assert!(
            msg.contains("expected a finite number, found `-inf`"),
            "{msg}"
        );
        let text = MIN.replace(
            "count = 3",
            "count = 3\nsensors = { proximity_noise = nan }",
        );
        let (line, msg) = err(&text);
        assert_eq!(line, 11);
        assert!(msg.contains("found `nan`"), "{msg}");
        // Words in strings and comments, and keys named like them, are not numbers.
        let text = format!("name = \"inf nan\" # nan\n{MIN}");
        assert!(Scenario::parse(&text, "t.toml").is_ok());
        assert_eq!(non_finite_literal("x = { inf = 1.0, nan= 2 }"), None);
        // Finite in the file, infinite as a 32-bit number: named by its key path, where written.
        let text = MIN.replace("at = [-1.0, 0.0]", "at = [1e39, 0.0]");
        let (line, msg) = err(&text);
        assert_eq!(line, 6);
        assert!(
            msg.contains("objects[0].at[0]: expected a finite number"),
            "{msg}"
        );
        let multi = "x = '''\nnan'''\ny = [1, +nan]";
        assert_eq!(non_finite_literal(multi).map(|p| p.1), Some("+nan"));
    }

    #[test]
    fn bad_lights_and_walls_are_rejected_at_their_line() {
        let light = "[[lights]]\nat = [1.0, 0.0]\nintensity = -2.0\n";
        let (line, msg) = err(&format!("{MIN}\n{light}"));
        assert_eq!(line, MIN.lines().count() + 4);
        assert!(
            msg.contains("lights[0]") && msg.contains("intensity"),
            "{msg}"
        );
        let goal = "[[lights]]\nat = [1.0, 0.0]\ngoal = true\n";
        let (line, msg) = err(&format!("{MIN}\n{goal}{goal}"));
        assert_eq!(line, MIN.lines().count() + 7);
        assert!(
            msg.contains("lights[1]: a second goal light (lights[0] is the goal)"),
            "{msg}"
        );
        let wall = "[[walls]]\nat = [1.0, 0.0]\nsize = [0.0, 1.0]\n";
        let (line, msg) = err(&format!("{MIN}\n{wall}"));
        assert_eq!(line, MIN.lines().count() + 4);
        assert!(
            msg.contains("walls[0].size[0]") && msg.contains("expected 0.001 to 2000 m"),
            "{msg}"
        );
    }

    fn ov(pairs: &[(&str, &str)]) -> Vec<(String, toml::Value)> {
        pairs
            .iter()
            .map(|(k, v)| {
                let t: toml::Table = toml::from_str(&format!("v = {v}")).unwrap();
                ((*k).to_string(), t["v"].clone())
            })
            .collect()
    }

    #[test]
    fn overrides_set_dotted_paths_and_array_elements() {
        let o = ov(&[
            ("robots.0.count", "7"),
            ("objects.0.shape", "{ disc = 0.2 }"),
            ("run.duration_s", "30"),
            ("stop.goal_radius", "0.4"),
        ]);
        let s = Scenario::parse_with_overrides(MIN, "t.toml", &o, ("sweep.toml", "")).unwrap();
        assert_eq!(s.robot_count(), 7);
        assert_eq!(s.spec.run.duration_s, 30.0);
        assert_eq!(s.spec.stop.goal_radius, Some(0.4));
        assert_eq!(s.object_parts(0).unwrap()[0].shape, Primitive::Disc(0.2));
        assert_eq!(s.name, "t");
        assert_eq!(s.file, "t.toml");
    }

    #[test]
    fn parameter_sets_share_the_texts_they_were_made_from() {
        // A sweep of 100,000 sets would otherwise hold 100,000 copies of its base scenario and
        // of itself, kept only to place errors.
        let sweep = "[vary]\n\"run.seed\" = [1, 2]\n".to_string();
        let make = |seed: i64| {
            Scenario::parse_with_overrides(
                MIN,
                "t.toml",
                &[("run.seed".to_string(), toml::Value::Integer(seed))],
                ("sweep.toml", &sweep),
            )
            .unwrap()
        };
        let (a, b) = (make(1), make(2));
        let (a, b) = (a.overridden.unwrap(), b.overridden.unwrap());
        assert!(std::sync::Arc::ptr_eq(&a.base_text, &b.base_text));
        assert!(std::sync::Arc::ptr_eq(&a.origin_text, &b.origin_text));
    }

    #[test]
    fn override_errors_name_the_sweep_file_and_the_key() {
        let sweep = "seeds = \"1..2\"\n[vary]\n\"robots.0.cuont\" = [1]\n";
        let e = Scenario::parse_with_overrides(
            MIN,
            "t.toml",
            &ov(&[("run.duration_s", "5"), ("robots.0.cuont", "1")]),
            ("sweep.toml", sweep),
        )
        .unwrap_err()
        .to_string();
        assert!(e.starts_with("sweep.toml:3:1: `robots.0.cuont`"), "{e}");
        assert!(e.contains("unknown field `cuont`"), "{e}");
        let e = Scenario::parse_with_overrides(
            MIN,
            "t.toml",
            &ov(&[("robots.3.count", "1")]),
            ("sweep.toml", ""),
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("index 3 is out of range"), "{e}");
        let e = Scenario::parse_with_overrides(
            MIN,
            "t.toml",
            &ov(&[("robots.0.count", "0")]),
            ("sweep.toml", ""),
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("count must be at least 1"), "{e}");
        assert!(e.contains("`robots.0.count` = 0"), "{e}");
    }

    #[test]
    fn substeps_are_auto_or_a_number_and_the_guard_checks_them() {
        let with = |run: &str| Scenario::parse(&format!("{MIN}[run]\n{run}\n"), "t.toml");
        let sc = Scenario::parse(MIN, "t.toml").unwrap();
        assert_eq!(sc.spec.run.substeps, Substeps::Auto);
        // Khepera IV at 0.8 m/s, 10 ticks/s: 8 cm per tick, a third of 7.04 cm per step.
        assert_eq!(sc.max_substeps(), 4);
        assert!(sc.physics_warning().is_none());
        let sc = with("substeps = \"auto\"").unwrap();
        assert_eq!(sc.spec.run.substeps, Substeps::Auto);
        let sc = with("substeps = 1").unwrap();
        assert_eq!(sc.max_substeps(), 1);
        let w = sc.physics_warning().unwrap();
        assert!(
            w.contains("80.0 mm per step") && w.contains("at least 4"),
            "{w}"
        );
        assert!(with("substeps = 4").unwrap().physics_warning().is_none());
        assert!(with("substeps = 1\ntick_hz = 100")
            .unwrap()
            .physics_warning()
            .is_none());
        for bad in [
            "substeps = 0",
            "substeps = 101",
            "substeps = 2.5",
            "substeps = \"fast\"",
        ] {
            let e = with(bad).unwrap_err().to_string();
            assert!(
                e.contains("\"auto\" or an integer from 1 to 100"),
                "{bad}: {e}"
            );
        }
        // Written back as the file says, so sweeps can override it.
        let sc = Scenario::parse_with_overrides(
            MIN,
            "t.toml",
            &[("run.substeps".into(), toml::Value::Integer(8))],
            ("sweep.toml", ""),
        )
        .unwrap();
        assert_eq!(sc.spec.run.substeps, Substeps::Fixed(8));
    }

    #[test]
    fn unknown_controller_lists_known_ones() {
        let text = MIN.replace("random-walk", "teleport");
        let (line, msg) = err(&text);
        assert_eq!(line, 11);
        assert!(msg.contains("unknown controller `teleport`"), "{msg}");
    }
}
