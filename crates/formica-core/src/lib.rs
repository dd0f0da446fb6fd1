//! # Formica
//!
//! A deterministic 2D simulator for cooperative transport by robot swarms: differential-drive
//! robots with IR proximity, occludable light sensors, positioning and a colour-blob camera;
//! movable polygonal objects (concave included) pushed against Coulomb floor friction; walls;
//! and lights as goals.
//!
//! Data takes one way: [`scenario`] file -> [`world::World`] -> tick (act, physics, sense,
//! control) -> [`experiment`] stop rules and metrics -> [`experiment::RunResult`].
//!
//! The names a scenario uses (controllers, robot models) and the loop functions every run gets
//! come from a [`Registry`]: the built-ins, and whatever a user's program adds.
//!
//! ```no_run
//! use formica::{experiment, scenario::Scenario};
//! let sc = Scenario::load("scenarios/seed-transport.toml".as_ref()).unwrap();
//! let (result, _) = experiment::run(&sc, &Default::default()).unwrap();
//! println!("{:?} after {} s", result.outcome, result.sim_time_s);
//! ```

pub mod bench;
pub mod controller;
pub mod controllers;
pub mod experiment;
pub mod geometry;
pub mod limits;
pub mod metrics;
pub mod noise;
pub mod ops;
mod parallel;
pub mod physics;
pub mod registry;
pub mod robot;
pub mod scenario;
pub mod sensors;
pub mod timeseries;
pub mod visibility;
pub mod world;

pub use experiment::{run, LoopFunctions, Outcome, RunOptions, RunResult, Trajectories};
pub use registry::{Registry, RegistryError};
pub use scenario::{Scenario, ScenarioError};
pub use world::{Overrides, World};
