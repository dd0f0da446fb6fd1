//! Controllers written in Python, and what they are handed: the robot's generator ([`PyRng`]),
//! its readings ([`PyReadings`]) and its sensor layout ([`PyLayout`]).
//!
//! - Per robot: `formica.register_controller(name, cls)` makes `cls(layout, **params)` for each
//!   robot and calls its `step(readings)` every tick ([`RobotAdapter`]).
//! - Batched: `formica.register_batched(name, fn)` calls one function per group and tick with
//!   all the group's readings as one `[N, L]` array ([`BatchAdapter`]).
//!
//! Both go into the process-wide registry, so scenario files name them like built-ins, in
//! `run`, `sweep` and `World`. The built-in `external` controller does nothing: robots that run
//! it are driven from outside (`World.set_actions`, the environments in `formica.env`).

use crate::{raise, world::color_of_code};
use formica::controller::{
    Actuation, AttachCommand, BatchController, BatchRobot, Controller, ControllerFactory,
    FlatReadings, RobotRng, Slot,
};
use formica::robot::ProximityCurve;
use formica::scenario::Color;
use formica::sensors::{Readings, SensorLayout, SensorNeeds};
use formica::Registry;
use numpy::{AllowTypeChange, PyArray1, PyArrayLike1, PyArrayLike2, PyArrayMethods};
use pyo3::exceptions::{PyRuntimeError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};
use pyo3::{intern, IntoPyObjectExt};
use rand::Rng;
use std::collections::{HashMap, HashSet};
use std::sync::{Arc, Mutex, PoisonError};

/// Names registered from Python: worlds that use one keep the interpreter attached while they
/// step, and the registry generation tells loaded scenarios to resolve their names again.
static PYTHON_NAMES: Mutex<Option<HashSet<String>>> = Mutex::new(None);
static GENERATION: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);

/// How many times controllers were registered from Python (scenarios parsed before then are
/// parsed again, so that they see the new names).
pub(crate) fn generation() -> u64 {
    GENERATION.load(std::sync::atomic::Ordering::SeqCst)
}

/// Whether `name` is a controller registered from Python.
pub(crate) fn is_python(name: &str) -> bool {
    PYTHON_NAMES
        .lock()
        .unwrap_or_else(PoisonError::into_inner)
        .as_ref()
        .is_some_and(|s| s.contains(name))
}

fn note_python(name: &str) {
    PYTHON_NAMES
        .lock()
        .unwrap_or_else(PoisonError::into_inner)
        .get_or_insert_with(HashSet::new)
        .insert(name.to_string());
    GENERATION.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
}

/// State names are `&'static str` in the core; names a Python controller reports are kept
/// here, once each (at most [`MAX_STATES`] distinct ones; later new names read `other`).
static STATES: Mutex<Option<HashMap<String, &'static str>>> = Mutex::new(None);
const MAX_STATES: usize = 4096;

fn intern_state(name: &str) -> &'static str {
    let mut guard = STATES.lock().unwrap_or_else(PoisonError::into_inner);
    let map = guard.get_or_insert_with(HashMap::new);
    if let Some(s) = map.get(name) {
        return s;
    }
    if map.len() >= MAX_STATES {
        return "other";
    }
    let leaked: &'static str = Box::leak(name.to_string().into_boxed_str());
    map.insert(name.to_string(), leaked);
    leaked
}

/// The sensors named in `needs` (`proximity`, `light`, `beacon`, `camera`, `scan`). A batched
/// controller reads the flat readings `[N, L]`, which hold neither camera blobs nor the colour
/// scan: it may not ask for them (it would pay for sensors it cannot read).
fn parse_needs(needs: &[String], batched: bool) -> PyResult<SensorNeeds> {
    let mut n = SensorNeeds::default();
    for s in needs {
        match s.as_str() {
            "proximity" => n.proximity = true,
            "light" => n.light = true,
            "beacon" => n.beacon = true,
            "camera" | "scan" if batched => {
                return Err(PyValueError::new_err(format!(
                    "needs: a batched controller reads the readings array, which has no \
                     `{s}`: read it from a per-robot controller (register_controller)"
                )))
            }
            "camera" => n.camera = true,
            "scan" => n.scan = true,
            other => {
                return Err(PyValueError::new_err(format!(
                    "needs: unknown sensor `{other}`, expected proximity, light, beacon, camera \
                     or scan"
                )))
            }
        }
    }
    Ok(n)
}

/// The sensor behind an attribute of `Readings` (a slot of the readings vector, `beacon`,
/// `blobs`, `scan`), when one must be asked for, and whether `needs` asks for it.
fn sensor_of(attr: &str, needs: &SensorNeeds) -> Option<(&'static str, bool)> {
    Some(match attr {
        "proximity" => ("proximity", needs.proximity),
        "light" => ("light", needs.light),
        "beacon" | "beacon_x" | "beacon_y" | "has_beacon" => ("beacon", needs.beacon),
        "blobs" => ("camera", needs.camera),
        "scan" => ("scan", needs.scan),
        _ => return None,
    })
}

/// A TOML value as a Python object (datetimes as their TOML text).
pub(crate) fn toml_to_py(py: Python<'_>, v: &toml::Value) -> PyResult<Py<PyAny>> {
    Ok(match v {
        toml::Value::String(s) => s.into_py_any(py)?,
        toml::Value::Integer(i) => i.into_py_any(py)?,
        toml::Value::Float(f) => f.into_py_any(py)?,
        toml::Value::Boolean(b) => b.into_py_any(py)?,
        toml::Value::Datetime(d) => d.to_string().into_py_any(py)?,
        toml::Value::Array(items) => {
            let list = PyList::empty(py);
            for item in items {
                list.append(toml_to_py(py, item)?)?;
            }
            list.into_any().unbind()
        }
        toml::Value::Table(t) => table_to_py(py, t)?.into_any().unbind(),
    })
}

fn table_to_py<'py>(py: Python<'py>, t: &toml::Table) -> PyResult<Bound<'py, PyDict>> {
    let dict = PyDict::new(py);
    for (k, item) in t {
        dict.set_item(k, toml_to_py(py, item)?)?;
    }
    Ok(dict)
}

/// Slot layout of a readings vector, shared by every readings object of a group.
#[derive(Debug)]
pub(crate) struct Shape {
    pub(crate) flat: FlatReadings,
    pub(crate) slots: Vec<Slot>,
    pub(crate) names: Vec<String>,
}

impl Shape {
    pub(crate) fn of(layout: &SensorLayout) -> Shape {
        let flat = FlatReadings::of(layout);
        Shape {
            flat,
            slots: flat.slots(),
            names: flat.names(),
        }
    }

    fn slot(&self, name: &str) -> Option<Slot> {
        self.slots.iter().copied().find(|s| s.name == name)
    }
}

/// A random generator, deterministic per seed. A controller's `self.rng` is its robot's own
/// generator (the same stream a Rust controller gets), so runs stay reproducible per seed as
/// long as controllers draw only from it.
#[pyclass(module = "formica", name = "Rng")]
pub struct PyRng {
    pub(crate) inner: RobotRng,
}

#[pymethods]
impl PyRng {
    /// A stand-alone generator from `seed` (controllers get their robot's one instead).
    #[new]
    #[pyo3(signature = (seed = crate::NotBool(0)))]
    fn new(seed: crate::NotBool<u64>) -> Self {
        let seed = seed.0;
        Self {
            inner: formica::world::rng_stream(seed, 0x5059, 0),
        }
    }

    /// A float in [0, 1).
    fn random(&mut self) -> f64 {
        self.inner.random::<f64>()
    }

    /// A float in [low, high).
    fn uniform(&mut self, low: f64, high: f64) -> PyResult<f64> {
        check_uniform(low, high)?;
        Ok(low + (high - low) * self.inner.random::<f64>())
    }

    /// A Gaussian draw with mean `mean` and standard deviation `sd`.
    #[pyo3(signature = (mean = 0.0, sd = 1.0))]
    fn normal(&mut self, mean: f64, sd: f64) -> PyResult<f64> {
        check_normal(mean, sd)?;
        Ok(mean + sd * f64::from(formica::ops::standard_normal(&mut self.inner)))
    }

    /// An integer in [low, high).
    fn integers(&mut self, low: i64, high: i64) -> PyResult<i64> {
        if low >= high {
            return Err(PyValueError::new_err(format!(
                "integers: expected low < high, got {low}, {high}"
            )));
        }
        Ok(self.inner.random_range(low..high))
    }

    /// True with probability one half (the draw a Rust controller's `rng.random::<bool>()`
    /// makes).
    fn coin(&mut self) -> bool {
        self.inner.random::<bool>()
    }

    /// True with probability `p`.
    #[pyo3(signature = (p = 0.5))]
    fn random_bool(&mut self, p: f64) -> PyResult<bool> {
        if !(0.0..=1.0).contains(&p) {
            return Err(PyValueError::new_err(format!(
                "random_bool: expected 0 <= p <= 1, got {p}"
            )));
        }
        Ok(self.inner.random_bool(p))
    }
}

/// The generators of a batch's robots, one per row: each draw gives an array with one value per
/// robot, each from its own robot's generator.
#[pyclass(module = "formica", name = "Rngs")]
pub struct PyRngs {
    pub(crate) inner: Vec<RobotRng>,
}

#[pymethods]
impl PyRngs {
    fn __len__(&self) -> usize {
        self.inner.len()
    }

    /// Floats in [0, 1), shape `[N]`.
    fn random<'py>(&mut self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        let v: Vec<f64> = self.inner.iter_mut().map(|r| r.random::<f64>()).collect();
        PyArray1::from_vec(py, v)
    }

    /// Floats in [low, high), shape `[N]`.
    fn uniform<'py>(
        &mut self,
        py: Python<'py>,
        low: f64,
        high: f64,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        check_uniform(low, high)?;
        let v = self
            .inner
            .iter_mut()
            .map(|r| low + (high - low) * r.random::<f64>())
            .collect();
        Ok(PyArray1::from_vec(py, v))
    }

    /// Gaussian draws, shape `[N]`.
    #[pyo3(signature = (mean = 0.0, sd = 1.0))]
    fn normal<'py>(
        &mut self,
        py: Python<'py>,
        mean: f64,
        sd: f64,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        check_normal(mean, sd)?;
        let v = self
            .inner
            .iter_mut()
            .map(|r| mean + sd * f64::from(formica::ops::standard_normal(r)))
            .collect();
        Ok(PyArray1::from_vec(py, v))
    }

    /// Fair coins, shape `[N]`.
    fn coin<'py>(&mut self, py: Python<'py>) -> Bound<'py, PyArray1<bool>> {
        let v = self.inner.iter_mut().map(|r| r.random::<bool>()).collect();
        PyArray1::from_vec(py, v)
    }
}

/// A Gaussian's parameters: a finite mean and a finite standard deviation of 0 or more.
fn check_normal(mean: f64, sd: f64) -> PyResult<()> {
    if mean.is_finite() && sd.is_finite() && sd >= 0.0 {
        Ok(())
    } else {
        Err(PyValueError::new_err(format!(
            "normal: expected a finite mean and a finite sd >= 0, got {mean}, {sd}"
        )))
    }
}

/// What a controller knows of its robot before the first tick: sensor bearings, speed limit,
/// size, and the layout of its readings vector.
#[pyclass(module = "formica", name = "Layout", frozen)]
pub struct PyLayout {
    /// Proximity sensor bearings (rad, counter-clockwise from straight ahead).
    #[pyo3(get)]
    proximity_angles: Vec<f32>,
    /// Light sensor bearings (rad).
    #[pyo3(get)]
    light_angles: Vec<f32>,
    /// Largest wheel speed (m/s).
    #[pyo3(get)]
    max_speed: f32,
    /// Body radius (m).
    #[pyo3(get)]
    radius: f32,
    /// Distance between the wheels (m).
    #[pyo3(get)]
    wheel_distance: f32,
    /// Proximity range beyond the body (m).
    #[pyo3(get)]
    proximity_range: f32,
    /// Largest radius (m) of the objects the beacon tracks, as the positioning system knows
    /// them (`None` without such an object).
    #[pyo3(get)]
    beacon_radius: Option<f32>,
    /// Control period (s): `1 / run.tick_hz`.
    #[pyo3(get)]
    tick_s: f32,
    /// Bearing of each colour-scan bin (rad, robot frame, counterclockwise from ahead).
    #[pyo3(get)]
    scan_angles: Vec<f32>,
    /// Range of the colour scan (m).
    #[pyo3(get)]
    scan_range: f32,
    proximity_curve: ProximityCurve,
    shape: Arc<Shape>,
}

impl PyLayout {
    pub(crate) fn new(layout: &SensorLayout, shape: Arc<Shape>) -> Self {
        Self {
            proximity_angles: layout.proximity_angles.clone(),
            light_angles: layout.light_angles.clone(),
            max_speed: layout.max_speed,
            radius: layout.radius,
            wheel_distance: layout.wheel_distance,
            proximity_range: layout.proximity_range,
            beacon_radius: layout.beacon_radius,
            tick_s: layout.tick_s,
            scan_angles: layout.scan_angles.clone(),
            scan_range: layout.scan_range,
            proximity_curve: layout.proximity_curve,
            shape,
        }
    }
}

#[pymethods]
impl PyLayout {
    /// Names of the readings vector's values, in order (`proximity0`, ..., `light0`, ...,
    /// `x`, `y`, `theta`, `beacon_x`, `beacon_y`, `has_beacon`, `attached`, `time_s`).
    #[getter]
    fn names(&self) -> Vec<String> {
        self.shape.names.clone()
    }

    /// `{slot: (offset, length)}` of the readings vector, e.g. `{"proximity": (0, 8), ...}`.
    #[getter]
    fn slots<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        slots_dict(py, &self.shape)
    }

    /// Length of the readings vector.
    #[getter]
    fn size(&self) -> usize {
        self.shape.flat.len()
    }

    /// Wheel speeds `(left, right)` (m/s) for a forward speed (m/s) and a turn rate (rad/s), as
    /// the Rust controllers' `Actuation::from_twist`.
    fn twist(&self, forward: f32, turn: f32) -> (f32, f32) {
        let half = turn * self.wheel_distance / 2.0;
        (forward - half, forward + half)
    }

    /// The distance beyond the body (m) that a proximity reading stands for, through the
    /// model's own curve (the Khepera IV's exponential, the foot-bot's inverse law, the
    /// e-puck's line): 0 for a saturated reading, `proximity_range` for none.
    fn proximity_distance(&self, reading: f32) -> f32 {
        self.proximity_curve.distance(reading, self.proximity_range)
    }

    fn __repr__(&self) -> String {
        format!(
            "Layout({} proximity, {} light sensors, max_speed={} m/s, radius={} m, {} readings)",
            self.proximity_angles.len(),
            self.light_angles.len(),
            self.max_speed,
            self.radius,
            self.shape.flat.len()
        )
    }
}

pub(crate) fn slots_dict<'py>(py: Python<'py>, shape: &Shape) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    for s in &shape.slots {
        d.set_item(s.name, (s.offset, s.len))?;
    }
    Ok(d)
}

/// One robot's readings in one tick. Every slot of the layout is an attribute: one value as a
/// float (`r.x`, `r.time_s`, `r.has_beacon`), several as a tuple (`r.proximity`, `r.light`).
/// Also: `vector` (the whole float32 vector), `pose`, `beacon`, `attached`, `blobs`, `scan`.
/// A sensor the controller's `needs` leave out is not computed, and reading it raises
/// `AttributeError` (in `vector` its values are zeros).
#[pyclass(module = "formica", name = "Readings", frozen)]
pub struct PyReadings {
    values: Vec<f32>,
    shape: Arc<Shape>,
    needs: SensorNeeds,
    blobs: Vec<(f32, f32, &'static str)>,
    scan: Vec<(&'static str, f32)>,
}

impl PyReadings {
    /// An error when attribute `attr` is a sensor's that the controller's `needs` leave out.
    fn readable(&self, attr: &str) -> PyResult<()> {
        match sensor_of(attr, &self.needs) {
            Some((sensor, false)) => Err(pyo3::exceptions::PyAttributeError::new_err(format!(
                "`{sensor}` is not read: this controller's needs leave it out (it is not \
                 computed); add \"{sensor}\" to needs where the controller is registered"
            ))),
            _ => Ok(()),
        }
    }

    fn get(&self, name: &str) -> Option<&[f32]> {
        self.shape
            .slot(name)
            .and_then(|s| self.values.get(s.offset..s.offset + s.len))
    }

    fn scalar(&self, name: &str) -> PyResult<f32> {
        self.readable(name)?;
        match self.get(name) {
            Some([v]) => Ok(*v),
            _ => Err(pyo3::exceptions::PyAttributeError::new_err(format!(
                "these readings have no `{name}`"
            ))),
        }
    }

    fn value<'py>(&self, py: Python<'py>, name: &str) -> PyResult<Option<Bound<'py, PyAny>>> {
        self.readable(name)?;
        Ok(match self.get(name) {
            Some([v]) => Some(PyFloat::new(py, f64::from(*v)).into_any()),
            Some(vs) => Some(PyTuple::new(py, vs.iter().map(|v| f64::from(*v)))?.into_any()),
            None => None,
        })
    }
}

#[pymethods]
impl PyReadings {
    fn __getattr__<'py>(&self, py: Python<'py>, name: &str) -> PyResult<Bound<'py, PyAny>> {
        // Python comes here too when a getter (`beacon`, `blobs`, `scan`) raised
        // AttributeError: `value` says why, not that there is no such attribute.
        self.value(py, name)?.ok_or_else(|| {
            pyo3::exceptions::PyAttributeError::new_err(format!(
                "Readings has no `{name}`; slots: {}",
                self.shape
                    .slots
                    .iter()
                    .map(|s| s.name)
                    .collect::<Vec<_>>()
                    .join(", ")
            ))
        })
    }

    fn __getitem__<'py>(&self, py: Python<'py>, name: &str) -> PyResult<Bound<'py, PyAny>> {
        self.value(py, name)?
            .ok_or_else(|| pyo3::exceptions::PyKeyError::new_err(name.to_string()))
    }

    fn __len__(&self) -> usize {
        self.values.len()
    }

    /// The whole readings vector (float32, shape `[L]`, named by `Layout.names`).
    #[getter]
    fn vector<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f32>> {
        PyArray1::from_vec(py, self.values.clone())
    }

    /// Own pose from the positioning sensor: `(x m, y m, theta rad)`.
    #[getter]
    fn pose(&self) -> PyResult<(f32, f32, f32)> {
        Ok((self.scalar("x")?, self.scalar("y")?, self.scalar("theta")?))
    }

    /// The object's centre `(x, y)` (m, world frame), or None without the beacon.
    #[getter]
    fn beacon(&self) -> PyResult<Option<(f32, f32)>> {
        if self.scalar("has_beacon")? > 0.5 {
            Ok(Some((self.scalar("beacon_x")?, self.scalar("beacon_y")?)))
        } else {
            Ok(None)
        }
    }

    /// Whether the robot is attached to a body.
    #[getter]
    fn attached(&self) -> PyResult<bool> {
        Ok(self.scalar("attached")? > 0.5)
    }

    /// Camera blobs `(bearing rad, distance m, colour name)`, nearest first (the controller
    /// needs the camera).
    #[getter]
    fn blobs(&self) -> PyResult<Vec<(f32, f32, &'static str)>> {
        self.readable("blobs")?;
        Ok(self.blobs.clone())
    }

    /// The colour scan, one `(colour name, range m)` per bin, bins at `Layout.scan_angles`:
    /// the colour of the first body the bin's ray meets (`"off"` for nothing in range, `"grey"`
    /// a wall, `"black"` a robot with its LEDs off, else an object's or a lit LED's colour) and
    /// a coarse, noisy range (`Layout.scan_range` where nothing is met). The controller needs
    /// `scan`.
    #[getter]
    fn scan(&self) -> PyResult<Vec<(&'static str, f32)>> {
        self.readable("scan")?;
        Ok(self.scan.clone())
    }

    fn __repr__(&self) -> String {
        format!("Readings({} values)", self.values.len())
    }
}

fn readings_object(
    py: Python<'_>,
    r: &Readings,
    shape: &Arc<Shape>,
    needs: SensorNeeds,
) -> PyResult<Py<PyReadings>> {
    let mut values = vec![0.0; shape.flat.len()];
    shape
        .flat
        .write(r, &mut values)
        .map_err(PyRuntimeError::new_err)?;
    let scan = r
        .scan_color
        .iter()
        .zip(&r.scan_range)
        .map(|(c, d)| (c.name(), *d))
        .collect();
    let blobs = if needs.camera {
        r.blobs
            .iter()
            .map(|b| (b.bearing, b.distance, b.color.name()))
            .collect()
    } else {
        Vec::new()
    };
    Py::new(
        py,
        PyReadings {
            values,
            shape: shape.clone(),
            needs,
            blobs,
            scan,
        },
    )
}

/// The context a batched function may take as its second argument: which robots the rows are,
/// their generators, the layout and the time.
#[pyclass(module = "formica", name = "Batch", frozen)]
pub struct PyBatch {
    /// World index of each row's robot (int64, `[N]`).
    #[pyo3(get)]
    index: Py<PyArray1<i64>>,
    /// The rows' robots' own generators.
    #[pyo3(get)]
    rng: Py<PyRngs>,
    /// The group's layout.
    #[pyo3(get)]
    layout: Py<PyLayout>,
    /// Simulated time (s).
    #[pyo3(get)]
    time_s: f32,
}

/// A colour from a Python value: None (off), a name, or an index into `formica.COLORS`.
fn led_of(v: &Bound<'_, PyAny>) -> PyResult<Color> {
    if v.is_none() {
        return Ok(Color::Off);
    }
    if let Ok(s) = v.cast::<PyString>() {
        let name = s.to_str()?;
        return crate::world::color_of_name(name).ok_or_else(|| {
            PyValueError::new_err(format!(
                "unknown LED colour `{name}`, expected one of {}",
                crate::world::color_names().join(", ")
            ))
        });
    }
    if v.is_instance_of::<PyInt>() && !v.is_instance_of::<PyBool>() {
        let code: i64 = v.extract()?;
        return color_of_code(code);
    }
    Err(PyTypeError::new_err(format!(
        "LED colour: expected None, a colour name or a code, got {}",
        v.get_type().name()?
    )))
}

/// An attach command from a Python value: None / "keep" / 0 keep, True / "attach" / 1 attach,
/// False / "detach" / -1 detach.
fn attach_of(v: &Bound<'_, PyAny>) -> PyResult<AttachCommand> {
    if v.is_none() {
        return Ok(AttachCommand::Keep);
    }
    if let Ok(b) = v.cast::<PyBool>() {
        return Ok(if b.is_true() {
            AttachCommand::Attach
        } else {
            AttachCommand::Detach
        });
    }
    if let Ok(s) = v.cast::<PyString>() {
        return match s.to_str()? {
            "keep" => Ok(AttachCommand::Keep),
            "attach" => Ok(AttachCommand::Attach),
            "detach" => Ok(AttachCommand::Detach),
            other => Err(PyValueError::new_err(format!(
                "attach: expected keep, attach or detach, got `{other}`"
            ))),
        };
    }
    if v.is_instance_of::<PyInt>() {
        return attach_of_code(v.extract()?);
    }
    Err(PyTypeError::new_err(format!(
        "attach: expected None, a bool, keep / attach / detach or -1 / 0 / 1, got {}",
        v.get_type().name()?
    )))
}

pub(crate) fn attach_of_code(code: i64) -> PyResult<AttachCommand> {
    match code {
        0 => Ok(AttachCommand::Keep),
        1 => Ok(AttachCommand::Attach),
        -1 => Ok(AttachCommand::Detach),
        other => Err(PyValueError::new_err(format!(
            "attach: expected -1 (detach), 0 (keep) or 1 (attach), got {other}"
        ))),
    }
}

/// Checks wheel speeds: finite numbers (`who` names the culprit, made only on failure).
pub(crate) fn check_wheels(left: f32, right: f32, who: impl FnOnce() -> String) -> PyResult<()> {
    if left.is_finite() && right.is_finite() {
        Ok(())
    } else {
        Err(PyValueError::new_err(format!(
            "{}: wheel speeds must be finite numbers (m/s), got ({left}, {right})",
            who()
        )))
    }
}

/// What a per-robot `step` returned: `(left, right[, led[, attach[, coast]]])`.
fn action_of(out: &Bound<'_, PyAny>, who: &str) -> PyResult<Actuation> {
    let items = out.cast::<PyTuple>().map(|t| t.to_list()).or_else(|_| {
        out.cast::<PyList>().cloned().map_err(|_| {
            PyTypeError::new_err(format!(
                "{who}: step must return (left, right, led, attach, coast) (led, attach and coast optional), got {}",
                crate::type_name(out)
            ))
        })
    })?;
    let n = items.len();
    if !(2..=5).contains(&n) {
        return Err(PyValueError::new_err(format!(
            "{who}: step must return 2 to 5 values (left, right, led, attach, coast), got {n}"
        )));
    }
    let speed = |i: usize, which: &str| -> PyResult<f64> {
        let v = items.get_item(i)?;
        let number = if v.is_instance_of::<PyBool>() {
            None
        } else {
            v.extract::<f64>().ok()
        };
        number.ok_or_else(|| {
            PyTypeError::new_err(format!(
                "{who}: the {which} wheel speed must be a number (m/s), got {}",
                crate::type_name(&v)
            ))
        })
    };
    let (left, right) = (speed(0, "left")?, speed(1, "right")?);
    let (left, right) = (left as f32, right as f32);
    check_wheels(left, right, || who.to_string())?;
    let led = if n > 2 {
        led_of(&items.get_item(2)?).map_err(|e| prefix(out.py(), e, who))?
    } else {
        Color::Off
    };
    let attach = if n > 3 {
        attach_of(&items.get_item(3)?).map_err(|e| prefix(out.py(), e, who))?
    } else {
        AttachCommand::Keep
    };
    let coast = if n > 4 {
        let c = items.get_item(4)?;
        c.extract::<bool>().map_err(|_| {
            PyTypeError::new_err(format!(
                "{who}: coast (the fifth value) must be True or False, got {}",
                crate::type_name(&c)
            ))
        })?
    } else {
        false
    };
    Ok(Actuation {
        left,
        right,
        led,
        attach,
        coast,
    })
}

/// The same exception type, its message prefixed with who raised it.
pub(crate) fn prefix(py: Python<'_>, e: PyErr, who: &str) -> PyErr {
    let msg = e.value(py).to_string();
    if e.is_instance_of::<PyTypeError>(py) {
        PyTypeError::new_err(format!("{who}: {msg}"))
    } else {
        PyValueError::new_err(format!("{who}: {msg}"))
    }
}

/// A Python controller of one robot.
struct RobotAdapter {
    obj: Py<PyAny>,
    rng: Py<PyRng>,
    shape: Arc<Shape>,
    needs: SensorNeeds,
    read_state: bool,
    state: &'static str,
    who: Arc<str>,
}

impl RobotAdapter {
    fn step_py(&mut self, py: Python<'_>, r: &Readings, rng: &mut RobotRng) -> PyResult<Actuation> {
        let readings = readings_object(py, r, &self.shape, self.needs)?;
        std::mem::swap(&mut self.rng.bind(py).borrow_mut().inner, rng);
        let out = self
            .obj
            .bind(py)
            .call_method1(intern!(py, "step"), (readings,));
        std::mem::swap(&mut self.rng.bind(py).borrow_mut().inner, rng);
        let action = action_of(&out?, &self.who)?;
        // A `state` first set in a later `step` counts from then on.
        if self.read_state || self.obj.bind(py).hasattr(intern!(py, "state"))? {
            self.read_state = true;
            let s = self.obj.bind(py).getattr(intern!(py, "state"))?;
            if let Ok(s) = s.cast::<PyString>() {
                let s = s.to_str()?;
                if s != self.state {
                    self.state = intern_state(s);
                }
            }
        }
        Ok(action)
    }
}

impl Controller for RobotAdapter {
    fn step(&mut self, r: &Readings, rng: &mut RobotRng) -> Actuation {
        match Python::attach(|py| self.step_py(py, r, rng)) {
            Ok(a) => a,
            Err(e) => raise(e),
        }
    }

    fn state(&self) -> &'static str {
        self.state
    }
}

/// A controller whose construction raised: it raises the error on its first step.
struct Failed(Mutex<Option<PyErr>>);

impl Failed {
    fn raise(&self) -> ! {
        let e = self
            .0
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .take()
            .unwrap_or_else(|| PyRuntimeError::new_err("a Python controller failed to build"));
        raise(e)
    }
}

impl Controller for Failed {
    fn step(&mut self, _r: &Readings, _rng: &mut RobotRng) -> Actuation {
        self.raise()
    }
    fn state(&self) -> &'static str {
        "failed"
    }
}

impl BatchController for Failed {
    fn step(&mut self, _robots: &mut [BatchRobot<'_>]) {
        self.raise()
    }
}

/// The text of a Python exception, for a scenario error (which adds `file:line:column`).
fn describe(py: Python<'_>, e: &PyErr) -> String {
    let kind = e
        .get_type(py)
        .name()
        .map(|n| n.to_string())
        .unwrap_or_else(|_| "Exception".into());
    format!("{kind}: {}", e.value(py))
}

/// What a Python controller's factory is built from: the layout's shape, the scenario's
/// parameters as keyword arguments and the layout as Python sees it.
type FactoryArgs = (Arc<Shape>, Py<PyDict>, Py<PyLayout>);

/// [`FactoryArgs`] for `params` and `layout`; an error says what Python raised.
fn factory_args(
    py: Python<'_>,
    params: Option<&toml::Table>,
    layout: &SensorLayout,
) -> Result<FactoryArgs, String> {
    let shape = Arc::new(Shape::of(layout));
    let kwargs = match params {
        Some(t) => table_to_py(py, t),
        None => Ok(PyDict::new(py)),
    }
    .map_err(|e| describe(py, &e))?
    .unbind();
    let py_layout =
        Py::new(py, PyLayout::new(layout, shape.clone())).map_err(|e| describe(py, &e))?;
    Ok((shape, kwargs, py_layout))
}

/// Registers the per-robot Python controller class `cls` as `name`.
#[pyfunction]
pub fn register_robot(name: String, cls: Py<PyAny>, needs: Vec<String>) -> PyResult<()> {
    let needs = parse_needs(&needs, false)?;
    let who: Arc<str> = Arc::from(format!("controller `{name}`"));
    let build = move |params: Option<&toml::Table>,
                      layout: &SensorLayout|
          -> Result<ControllerFactory, String> {
        Python::attach(|py| {
            let (shape, kwargs, py_layout) = factory_args(py, params, layout)?;
            // Build one now, so that bad parameters fail where the scenario is checked.
            cls.bind(py)
                .call((py_layout.clone_ref(py),), Some(kwargs.bind(py)))
                .map_err(|e| describe(py, &e))?;
            let cls = cls.clone_ref(py);
            let who = who.clone();
            Ok(ControllerFactory::new(needs, move || {
                Python::attach(|py| -> Box<dyn Controller> {
                    let made = (|| -> PyResult<RobotAdapter> {
                        let obj = cls
                            .bind(py)
                            .call((py_layout.clone_ref(py),), Some(kwargs.bind(py)))?;
                        let rng = Py::new(py, PyRng::new(crate::NotBool(0)))?;
                        obj.setattr(intern!(py, "rng"), rng.clone_ref(py))?;
                        let read_state = obj.hasattr(intern!(py, "state"))?;
                        Ok(RobotAdapter {
                            obj: obj.unbind(),
                            rng,
                            shape: shape.clone(),
                            needs,
                            read_state,
                            state: "python",
                            who: who.clone(),
                        })
                    })();
                    match made {
                        Ok(a) => Box::new(a),
                        Err(e) => Box::new(Failed(Mutex::new(Some(e)))),
                    }
                })
            }))
        })
    };
    Registry::update_global(|r| r.controller(&name, build).map(|_| ()))
        .map_err(|e| PyValueError::new_err(e.to_string()))?;
    note_python(&name);
    Ok(())
}

/// A batched Python controller of one group in one world.
struct BatchAdapter {
    step: Py<PyAny>,
    layout: Py<PyLayout>,
    shape: Arc<Shape>,
    pass_context: bool,
    who: Arc<str>,
}

impl BatchAdapter {
    fn step_py(&mut self, py: Python<'_>, robots: &mut [BatchRobot<'_>]) -> PyResult<()> {
        let n = robots.len();
        let l = self.shape.flat.len();
        let mut buf = vec![0.0f32; n * l];
        for (row, r) in buf.chunks_exact_mut(l.max(1)).zip(robots.iter()) {
            self.shape
                .flat
                .write(r.readings, row)
                .map_err(PyRuntimeError::new_err)?;
        }
        let readings = PyArray1::from_vec(py, buf).reshape([n, l])?;
        let out = if self.pass_context {
            let rngs = Py::new(
                py,
                PyRngs {
                    inner: robots.iter().map(|r| r.rng.clone()).collect(),
                },
            )?;
            let index = PyArray1::from_vec(py, robots.iter().map(|r| r.index as i64).collect());
            let time_s = robots.first().map_or(0.0, |r| r.readings.time_s);
            let ctx = PyBatch {
                index: index.unbind(),
                rng: rngs.clone_ref(py),
                layout: self.layout.clone_ref(py),
                time_s,
            };
            let out = self.step.bind(py).call1((readings, ctx))?;
            let drawn = rngs.bind(py).borrow();
            for (r, g) in robots.iter_mut().zip(&drawn.inner) {
                *r.rng = g.clone();
            }
            out
        } else {
            self.step.bind(py).call1((readings,))?
        };
        apply_batch(&out, robots, &self.who)
    }
}

impl BatchController for BatchAdapter {
    fn step(&mut self, robots: &mut [BatchRobot<'_>]) {
        if robots.is_empty() {
            return;
        }
        if let Err(e) = Python::attach(|py| self.step_py(py, robots)) {
            raise(e)
        }
    }
}

/// Applies what a batched function returned: wheel speeds `[N, 2]`, or a tuple `(wheels,
/// leds, attach)` with `leds` and `attach` optional (None, or one code per row).
fn apply_batch(out: &Bound<'_, PyAny>, robots: &mut [BatchRobot<'_>], who: &str) -> PyResult<()> {
    let py = out.py();
    let n = robots.len();
    let (wheels, leds, attach) = match out.cast::<PyTuple>() {
        Ok(t) => {
            if t.is_empty() || t.len() > 3 {
                return Err(PyValueError::new_err(format!(
                    "{who}: return wheel speeds [N, 2], or a tuple (wheels, leds, attach); got a tuple of {}",
                    t.len()
                )));
            }
            let get = |i: usize| t.get_item(i).ok().filter(|v| !v.is_none());
            (t.get_item(0)?, get(1), get(2))
        }
        Err(_) => (out.clone(), None, None),
    };
    let wheels: PyArrayLike2<'_, f32, AllowTypeChange> = numbers(&wheels, who, "wheel speeds")?
        .extract()
        .map_err(|_| {
            PyValueError::new_err(format!(
                "{who}: wheel speeds must be a float array of shape ({n}, 2)"
            ))
        })?;
    let w = wheels.as_array();
    if w.shape() != [n, 2] {
        return Err(PyValueError::new_err(format!(
            "{who}: wheel speeds must have shape ({n}, 2), got {:?}",
            w.shape()
        )));
    }
    for (k, r) in robots.iter_mut().enumerate() {
        let (left, right) = (w[[k, 0]], w[[k, 1]]);
        check_wheels(left, right, || format!("{who}, row {k}"))?;
        r.action.left = left;
        r.action.right = right;
        r.state = "batched";
    }
    if let Some(leds) = leds {
        let codes = codes_of(&leds, n, who, "leds")?;
        for (k, (r, c)) in robots.iter_mut().zip(codes).enumerate() {
            r.action.led =
                color_of_code(c).map_err(|e| prefix(py, e, &format!("{who}, row {k}")))?;
        }
    }
    for r in robots.iter_mut() {
        r.action.attach = AttachCommand::Keep;
    }
    if let Some(attach) = attach {
        let codes = codes_of(&attach, n, who, "attach")?;
        for (k, (r, c)) in robots.iter_mut().zip(codes).enumerate() {
            r.action.attach =
                attach_of_code(c).map_err(|e| prefix(py, e, &format!("{who}, row {k}")))?;
        }
    }
    Ok(())
}

/// `uniform(low, high)`'s bounds: finite, in order, and no farther apart than a float can say.
fn check_uniform(low: f64, high: f64) -> PyResult<()> {
    if low.is_finite() && high.is_finite() && low <= high && (high - low).is_finite() {
        Ok(())
    } else {
        Err(PyValueError::new_err(format!(
            "uniform: expected finite low <= high with a finite high - low, got {low}, {high}"
        )))
    }
}

/// `v` as a numpy array of numbers (bool, integer or float), for the numeric extractions that
/// follow: numpy would otherwise turn strings such as `"1.5"` into numbers without a word.
pub(crate) fn numbers<'py>(
    v: &Bound<'py, PyAny>,
    who: &str,
    what: &str,
) -> PyResult<Bound<'py, PyAny>> {
    let arr = v
        .py()
        .import("numpy")?
        .call_method1("asarray", (v,))
        .map_err(|_| PyValueError::new_err(format!("{who}: {what} must be an array of numbers")))?;
    let kind: String = arr.getattr("dtype")?.getattr("kind")?.extract()?;
    if !matches!(kind.as_str(), "b" | "i" | "u" | "f") {
        let dtype = arr.getattr("dtype")?.str()?.to_string();
        return Err(PyValueError::new_err(format!(
            "{who}: {what} must be numbers, got an array of dtype {dtype}"
        )));
    }
    Ok(arr)
}

/// One integer code per row.
pub(crate) fn codes_of(
    v: &Bound<'_, PyAny>,
    n: usize,
    who: &str,
    what: &str,
) -> PyResult<Vec<i64>> {
    // Read as float64 and checked, so that 1.7 or NaN is refused rather than cast to 1 or
    // to i64::MIN (as numpy's integer cast would).
    let nums = numbers(v, who, what)?;
    let kind: String = nums.getattr("dtype")?.getattr("kind")?.extract()?;
    if kind == "b" {
        // True / False would read 1 / 0, where a per-robot controller's False detaches.
        return Err(PyValueError::new_err(format!(
            "{who}: {what} must be integer codes, got booleans (attach: -1 detach, 0 keep, 1 \
             attach; leds: indices into formica.COLORS)"
        )));
    }
    let arr: PyArrayLike1<'_, f64, AllowTypeChange> = nums.extract().map_err(|_| {
        PyValueError::new_err(format!(
            "{who}: {what} must be an integer array of shape ({n},)"
        ))
    })?;
    let a = arr.as_array();
    if a.len() != n {
        return Err(PyValueError::new_err(format!(
            "{who}: {what} must have shape ({n},), got {:?}",
            a.shape()
        )));
    }
    a.iter()
        .enumerate()
        .map(|(k, &x)| {
            if x.is_finite() && x.fract() == 0.0 && x.abs() <= 1e15 {
                Ok(x as i64)
            } else {
                Err(PyValueError::new_err(format!(
                    "{who}: {what} must be whole-number codes, got {x} at index {k}"
                )))
            }
        })
        .collect()
}

/// Registers a batched Python controller: `maker(layout, params)` returns the function that
/// each tick takes the group's readings `[N, L]` (and, if `pass_context`, a `Batch`).
#[pyfunction]
pub fn register_batch(
    name: String,
    maker: Py<PyAny>,
    needs: Vec<String>,
    pass_context: bool,
) -> PyResult<()> {
    let needs = parse_needs(&needs, true)?;
    let who: Arc<str> = Arc::from(format!("batched controller `{name}`"));
    let build = move |params: Option<&toml::Table>,
                      layout: &SensorLayout|
          -> Result<ControllerFactory, String> {
        Python::attach(|py| {
            let (shape, kwargs, py_layout) = factory_args(py, params, layout)?;
            maker
                .bind(py)
                .call1((py_layout.clone_ref(py), kwargs.clone_ref(py)))
                .map_err(|e| describe(py, &e))?;
            let maker = maker.clone_ref(py);
            let who = who.clone();
            Ok(ControllerFactory::batched(needs, move || {
                Python::attach(|py| -> Box<dyn BatchController> {
                    match maker
                        .bind(py)
                        .call1((py_layout.clone_ref(py), kwargs.clone_ref(py)))
                    {
                        Ok(step) => Box::new(BatchAdapter {
                            step: step.unbind(),
                            layout: py_layout.clone_ref(py),
                            shape: shape.clone(),
                            pass_context,
                            who: who.clone(),
                        }),
                        Err(e) => Box::new(Failed(Mutex::new(Some(e)))),
                    }
                })
            }))
        })
    };
    Registry::update_global(|r| r.controller(&name, build).map(|_| ()))
        .map_err(|e| PyValueError::new_err(e.to_string()))?;
    note_python(&name);
    Ok(())
}

/// Every controller name the process-wide registry has, built-ins first.
#[pyfunction]
pub fn controller_names() -> Vec<String> {
    Registry::global()
        .controller_names()
        .into_iter()
        .map(str::to_string)
        .collect()
}

/// Panics inside Rust (for the test that a panic becomes `formica.PanicError`).
#[pyfunction]
pub fn panic_for_test() -> PyResult<()> {
    crate::guard(|| -> PyResult<()> { panic!("panic_for_test was called") })
}

/// The `external` controller: robots that do nothing by themselves and are driven from outside
/// (`World.set_actions`). Its parameters say which sensors to compute: `proximity`, `light`,
/// `beacon` (default true) and `camera` (default false).
struct External;

impl Controller for External {
    fn step(&mut self, _r: &Readings, _rng: &mut RobotRng) -> Actuation {
        Actuation::default()
    }
    fn state(&self) -> &'static str {
        "external"
    }
}

fn external_factory(
    params: Option<&toml::Table>,
    _layout: &SensorLayout,
) -> Result<ControllerFactory, String> {
    let mut needs = SensorNeeds {
        proximity: true,
        light: true,
        beacon: true,
        camera: false,
        scan: false,
    };
    for (k, v) in params.into_iter().flatten() {
        let Some(b) = v.as_bool() else {
            return Err(format!("`{k}` must be true or false, got {v}"));
        };
        match k.as_str() {
            "proximity" => needs.proximity = b,
            "light" => needs.light = b,
            "beacon" => needs.beacon = b,
            "camera" => needs.camera = b,
            "scan" => needs.scan = b,
            other => {
                return Err(format!(
                    "unknown parameter `{other}`, expected proximity, light, beacon, camera or scan"
                ))
            }
        }
    }
    Ok(ControllerFactory::new(needs, || Box::new(External)))
}

/// Adds `external` to the process-wide registry.
pub fn register_external() -> Result<(), formica::RegistryError> {
    Registry::update_global(|r| r.controller("external", external_factory).map(|_| ()))
}
