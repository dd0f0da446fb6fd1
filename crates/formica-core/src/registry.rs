//! What the names in a scenario file mean: controllers, loop functions and robot models.
//!
//! A [`Registry`] maps each `controller = "..."` to a builder of controllers (which parses and
//! checks the group's `params` and says which sensors it reads), each `model = "..."` to a
//! [`RobotModel`], and holds the loop functions every run gets (per-tick metrics, stop rules and
//! end-of-run fields). The built-ins are registered through the same calls as a user's
//! ([`Registry::builtin`]); nothing else in the simulator knows their names.
//!
//! A scenario resolves its names in the registry it was loaded with: [`Registry::parse`] and
//! [`Registry::load`] take this one, [`Scenario::parse`] and [`Scenario::load`] take the
//! process-wide one ([`Registry::global`], the built-ins unless [`Registry::install`] or
//! [`Registry::update_global`] changed it). A registry is a cheap handle: cloning it shares the
//! entries, and changing a clone copies them first, so a scenario already loaded keeps what it
//! was checked against.
//!
//! ```
//! use formica::controller::{parse_params, Actuation, Controller, ControllerFactory, RobotRng};
//! use formica::sensors::{Readings, SensorLayout, SensorNeeds};
//! use formica::{Outcome, Registry};
//!
//! /// Drives in circles: `speed` m/s, turning at `turn` rad/s.
//! #[derive(serde::Deserialize, Clone, Copy)]
//! #[serde(deny_unknown_fields)]
//! struct Params { speed: f32, turn: f32 }
//!
//! struct Circle(Params, SensorLayout);
//!
//! impl Controller for Circle {
//!     fn step(&mut self, _r: &Readings, _rng: &mut RobotRng) -> Actuation {
//!         Actuation::from_twist(self.0.speed, self.0.turn, &self.1)
//!     }
//!     fn state(&self) -> &'static str { "circling" }
//! }
//!
//! let mut registry = Registry::builtin();
//! registry.controller("circle", |params: Option<&toml::Table>, layout: &SensorLayout| {
//!     let p: Params = parse_params(params)?;
//!     if !(p.speed > 0.0) {
//!         return Err(format!("`speed` must be positive, got {}", p.speed));
//!     }
//!     let layout = layout.clone();
//!     Ok(ControllerFactory::new(SensorNeeds::default(), move || {
//!         Box::new(Circle(p, layout.clone()))
//!     }))
//! })?;
//!
//! let text = r#"
//! [arena]
//! size = [2.0, 2.0]
//! [[robots]]
//! controller = "circle"
//! params = { speed = 0.1, turn = 1.0 }
//! placement = { poses = [[0.0, 0.0, 0.0]] }
//! [run]
//! duration_s = 2
//! "#;
//! let scenario = registry.parse(text, "circle.toml")?;
//! let (result, _) = formica::run(&scenario, &Default::default())?;
//! assert_eq!((result.controller.as_str(), result.outcome), ("circle", Outcome::Timeout));
//!
//! // The process-wide registry does not know it, and says what it has.
//! let err = formica::Scenario::parse(text, "circle.toml").unwrap_err().to_string();
//! assert!(err.starts_with("circle.toml:5:14: robots[0].controller: unknown controller `circle`"));
//! assert!(err.contains("random-walk"));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use crate::controller::ControllerFactory;
use crate::experiment::LoopFunctions;
use crate::robot::{ProximityCurve, RobotModel};
use crate::scenario::{Scenario, ScenarioError};
use crate::sensors::SensorLayout;
use crate::world::World;
use std::fmt;
use std::sync::{Arc, PoisonError, RwLock};

/// Builds the controllers of one robot group from its `params` (absent: `None`) and its model's
/// sensor layout, or says what is wrong with the parameters (the scenario error adds the file,
/// line and column).
pub type BuildController =
    dyn Fn(Option<&toml::Table>, &SensorLayout) -> Result<ControllerFactory, String> + Send + Sync;

/// Builds one run's loop functions from its scenario and freshly built world, or `None` when
/// they have nothing to do in this run.
pub type BuildLoopFunctions =
    dyn Fn(&Scenario, &World) -> Option<Box<dyn LoopFunctions>> + Send + Sync;

/// A registration the registry refused.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum RegistryError {
    /// The name is empty or has characters other than ASCII letters, digits, `-`, `_` and `.`.
    #[error(
        "invalid {kind} name `{name}`: expected ASCII letters, digits, `-`, `_` or `.`, not empty"
    )]
    InvalidName {
        /// What was named: `controller`, `loop functions` or `robot model`.
        kind: &'static str,
        /// The name given.
        name: String,
    },
    /// A robot model with a non-finite or impossible figure.
    #[error("robot model `{name}`: {message}")]
    InvalidModel {
        /// The model's name.
        name: String,
        /// Which figure is wrong and what was expected.
        message: String,
    },
}

/// Controllers, loop functions and robot models by name (see the [module docs](self)).
#[derive(Clone)]
pub struct Registry {
    inner: Arc<Entries>,
}

#[derive(Clone, Default)]
struct Entries {
    controllers: Vec<(String, Arc<BuildController>)>,
    loop_functions: Vec<(String, Arc<BuildLoopFunctions>)>,
    models: Vec<(String, RobotModel)>,
    /// Whether loop functions were registered after the built-ins (new ones, or replacements
    /// of a built-in under its name).
    own_loop_functions: bool,
}

/// The process-wide registry; `None` until first used or installed (then: the built-ins).
static GLOBAL: RwLock<Option<Registry>> = RwLock::new(None);

fn check_name(kind: &'static str, name: &str) -> Result<(), RegistryError> {
    let ok = !name.is_empty()
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.'));
    if ok {
        Ok(())
    } else {
        Err(RegistryError::InvalidName {
            kind,
            name: name.to_string(),
        })
    }
}

/// Inserts or replaces (in place) the entry named `name`.
fn upsert<T>(list: &mut Vec<(String, T)>, name: &str, value: T) {
    match list.iter_mut().find(|(n, _)| n == name) {
        Some(slot) => slot.1 = value,
        None => list.push((name.to_string(), value)),
    }
}

fn unknown(kind: &str, name: &str, known: &[&str]) -> String {
    if known.is_empty() {
        format!("unknown {kind} `{name}`: this registry has none")
    } else {
        format!(
            "unknown {kind} `{name}`, expected one of {}",
            known.join(", ")
        )
    }
}

fn names<T>(list: &[(String, T)]) -> Vec<&str> {
    list.iter().map(|(n, _)| n.as_str()).collect()
}

/// Checks that every figure of a model is finite and physically possible.
fn check_model(m: &RobotModel) -> Result<(), String> {
    let positive = [
        ("radius", m.radius),
        ("height", m.height),
        ("mass", m.mass),
        ("wheel_distance", m.wheel_distance),
        ("max_speed", m.max_speed),
        ("max_force", m.max_force),
        ("max_torque", m.max_torque),
        ("proximity_range", m.proximity_range),
    ];
    for (what, v) in positive {
        if !(v > 0.0 && v.is_finite()) {
            return Err(format!("`{what}` must be a positive number, got {v}"));
        }
    }
    let heights = [
        ("proximity_height", m.proximity_height),
        ("light_height", m.light_height),
        ("camera_height", m.camera_height),
        ("led_height", m.led_height),
    ];
    for (what, v) in heights {
        if !(v >= 0.0 && v.is_finite()) {
            return Err(format!("`{what}` must be zero or more, got {v}"));
        }
    }
    let angles = m.proximity_angles.iter().chain(&m.light_angles);
    if let Some(a) = angles.into_iter().find(|a| !a.is_finite()) {
        return Err(format!("sensor angles must be finite, got {a}"));
    }
    let curve_ok = match m.proximity_curve {
        ProximityCurve::Exponential { near, a, b, c } => {
            [near, a, b, c].iter().all(|x| x.is_finite())
        }
        ProximityCurve::Inverse { near, k, e } => {
            [near, k, e].iter().all(|x| x.is_finite()) && e > 0.0
        }
        ProximityCurve::Linear => true,
    };
    if !curve_ok {
        return Err(
            "`proximity_curve` needs finite figures (and `e` > 0 for the inverse curve)".into(),
        );
    }
    Ok(())
}

impl Registry {
    /// A registry with nothing in it.
    pub fn empty() -> Registry {
        Registry {
            inner: Arc::new(Entries::default()),
        }
    }

    /// The built-ins: controllers `random-walk`, `constant`, `filling`, `fill-transport`,
    /// `occlusion`; loop functions `transport` (path length, goal distance, the goal and wall
    /// stop rules) and `fill` (filling metrics, `stop.on_filled`); robot models `khepera4`,
    /// `foot-bot`, `e-puck`.
    pub fn builtin() -> Registry {
        let mut r = Registry::empty();
        let added = crate::controllers::register(&mut r)
            .and_then(|()| crate::experiment::register(&mut r))
            .and_then(|()| crate::robot::register(&mut r));
        // Cannot fail: the built-in names are valid and the built-in models pass the checks
        // (the test `builtins_are_registered` registers them all).
        added.expect("built-in names and models are valid");
        Arc::make_mut(&mut r.inner).own_loop_functions = false;
        r
    }

    /// Registers (or replaces, keeping its place in [`Registry::controller_names`]) the
    /// controller `name`. `build` parses and checks a group's parameters and returns the
    /// factory of its robots' controllers, with the sensors they read.
    pub fn controller<F>(&mut self, name: &str, build: F) -> Result<&mut Self, RegistryError>
    where
        F: Fn(Option<&toml::Table>, &SensorLayout) -> Result<ControllerFactory, String>
            + Send
            + Sync
            + 'static,
    {
        check_name("controller", name)?;
        upsert(
            &mut Arc::make_mut(&mut self.inner).controllers,
            name,
            Arc::new(build),
        );
        Ok(self)
    }

    /// Registers (or replaces in place) the loop functions `name`. Every run gets them, after
    /// those registered before: each tick their `post_step` runs in this order, the first
    /// `is_finished` that answers ends the run, and at the end their `finish` fills in the
    /// result, including [`RunResult::extra`](crate::RunResult::extra) fields.
    pub fn loop_functions<F>(&mut self, name: &str, build: F) -> Result<&mut Self, RegistryError>
    where
        F: Fn(&Scenario, &World) -> Option<Box<dyn LoopFunctions>> + Send + Sync + 'static,
    {
        check_name("loop functions", name)?;
        let entries = Arc::make_mut(&mut self.inner);
        upsert(&mut entries.loop_functions, name, Arc::new(build));
        entries.own_loop_functions = true;
        Ok(self)
    }

    /// Registers (or replaces in place) the robot model `name`, for `model = "name"` in a
    /// scenario's robot group. Its figures must be finite; sizes, mass and limits positive.
    pub fn model(&mut self, name: &str, model: RobotModel) -> Result<&mut Self, RegistryError> {
        check_name("robot model", name)?;
        check_model(&model).map_err(|message| RegistryError::InvalidModel {
            name: name.to_string(),
            message,
        })?;
        upsert(&mut Arc::make_mut(&mut self.inner).models, name, model);
        Ok(self)
    }

    /// Controller names, in registration order.
    pub fn controller_names(&self) -> Vec<&str> {
        names(&self.inner.controllers)
    }

    /// Loop-function names, in the order they run.
    pub fn loop_function_names(&self) -> Vec<&str> {
        names(&self.inner.loop_functions)
    }

    /// Whether this registry holds loop functions of its user's own: any registered after the
    /// built-ins, including one that replaces a built-in under its name. (Their stop rules may
    /// end a run with success, so [`crate::Scenario::has_success_rule`] cannot judge by the
    /// scenario's `stop` table alone.)
    pub fn has_own_loop_functions(&self) -> bool {
        self.inner.own_loop_functions
    }

    /// Robot model names, in registration order.
    pub fn model_names(&self) -> Vec<&str> {
        names(&self.inner.models)
    }

    /// Whether controller `name` is registered.
    pub fn has_controller(&self, name: &str) -> bool {
        self.inner.controllers.iter().any(|(n, _)| n == name)
    }

    /// The robot model registered as `name`.
    pub fn robot_model(&self, name: &str) -> Option<&RobotModel> {
        self.inner
            .models
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, m)| m)
    }

    /// `unknown controller `name`, expected one of ...`: the message for a name not registered.
    pub fn unknown_controller(&self, name: &str) -> String {
        unknown("controller", name, &self.controller_names())
    }

    /// `unknown robot model `name`, expected one of ...`.
    pub fn unknown_model(&self, name: &str) -> String {
        unknown("robot model", name, &self.model_names())
    }

    /// The controller factory of controller `name` with `params`, for robots with `layout`.
    pub fn build_controller(
        &self,
        name: &str,
        params: Option<&toml::Table>,
        layout: &SensorLayout,
    ) -> Result<ControllerFactory, String> {
        match self.inner.controllers.iter().find(|(n, _)| n == name) {
            Some((_, build)) => build(params, layout),
            None => Err(self.unknown_controller(name)),
        }
    }

    /// One run's loop functions, with their names, in order (those that answered `None` left
    /// out).
    pub fn build_loop_functions(
        &self,
        sc: &Scenario,
        world: &World,
    ) -> Vec<(String, Box<dyn LoopFunctions>)> {
        self.inner
            .loop_functions
            .iter()
            .filter_map(|(n, build)| build(sc, world).map(|h| (n.clone(), h)))
            .collect()
    }

    /// Reads and validates a scenario file against this registry.
    pub fn load(&self, path: &std::path::Path) -> Result<Scenario, ScenarioError> {
        Scenario::load_in(path, self)
    }

    /// Parses and validates scenario text (named `file` in errors) against this registry.
    pub fn parse(&self, text: &str, file: &str) -> Result<Scenario, ScenarioError> {
        Scenario::parse_in(text, file, self)
    }

    /// [`Scenario::parse_with_overrides`] against this registry.
    pub fn parse_with_overrides(
        &self,
        text: &str,
        file: &str,
        overrides: &[(String, toml::Value)],
        origin: (&str, &str),
    ) -> Result<Scenario, ScenarioError> {
        Scenario::parse_with_overrides_in(text, file, overrides, origin, self)
    }

    /// Makes this the process-wide registry: scenarios loaded from now on through
    /// [`Scenario::load`] and [`Scenario::parse`] resolve their names in it.
    pub fn install(self) {
        *GLOBAL.write().unwrap_or_else(PoisonError::into_inner) = Some(self);
    }

    /// The process-wide registry (the built-ins unless changed): a snapshot, which later
    /// changes to the process-wide one do not affect.
    pub fn global() -> Registry {
        if let Some(r) = GLOBAL
            .read()
            .unwrap_or_else(PoisonError::into_inner)
            .as_ref()
        {
            return r.clone();
        }
        Self::update_global(|r| r.clone())
    }

    /// Changes the process-wide registry in place, e.g. to register a controller at run time:
    /// `Registry::update_global(|r| r.controller("mine", build).map(|_| ()))`. Scenarios
    /// loaded before keep the registry they were checked against. `f` must not call
    /// [`Registry::global`] or this function (the lock is held while it runs).
    pub fn update_global<R>(f: impl FnOnce(&mut Registry) -> R) -> R {
        let mut guard = GLOBAL.write().unwrap_or_else(PoisonError::into_inner);
        f(guard.get_or_insert_with(Registry::builtin))
    }
}

impl fmt::Debug for Registry {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Registry")
            .field("controllers", &self.controller_names())
            .field("loop_functions", &self.loop_function_names())
            .field("models", &self.model_names())
            .finish()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn builtins_are_registered() {
        let r = Registry::builtin();
        assert_eq!(
            r.controller_names(),
            [
                "random-walk",
                "constant",
                "filling",
                "fill-transport",
                "occlusion"
            ]
        );
        assert_eq!(r.loop_function_names(), ["transport", "fill"]);
        assert_eq!(r.model_names(), ["khepera4", "foot-bot", "e-puck"]);
        assert_eq!(r.robot_model("foot-bot"), Some(&RobotModel::footbot()));
    }

    #[test]
    fn bad_names_and_models_are_refused() {
        let mut r = Registry::empty();
        let build =
            |p: Option<&toml::Table>, l: &SensorLayout| crate::controllers::constant::factory(p, l);
        for bad in ["", "two words", "a,b", "émoji"] {
            assert!(matches!(
                r.controller(bad, build),
                Err(RegistryError::InvalidName { .. })
            ));
        }
        let model = RobotModel {
            radius: f32::NAN,
            ..RobotModel::epuck()
        };
        let e = r.model("nan-bot", model).unwrap_err().to_string();
        assert!(e.contains("`radius` must be a positive number"), "{e}");
        let model = RobotModel {
            led_height: -0.1,
            ..RobotModel::epuck()
        };
        let e = r.model("sunk-leds", model).unwrap_err().to_string();
        assert!(e.contains("`led_height` must be zero or more"), "{e}");
        assert!(r.model_names().is_empty());
    }

    #[test]
    fn replacing_keeps_the_place_and_clones_are_snapshots() {
        let mut r = Registry::builtin();
        let before = r.clone();
        r.model("khepera4", RobotModel::epuck()).unwrap();
        assert_eq!(r.model_names(), ["khepera4", "foot-bot", "e-puck"]);
        assert_eq!(r.robot_model("khepera4"), Some(&RobotModel::epuck()));
        assert_eq!(
            before.robot_model("khepera4"),
            Some(&RobotModel::khepera4())
        );
    }
}
