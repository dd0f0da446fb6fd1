//! Worlds from Python: [`PyWorld`] (`formica.World`, one world) and [`PyWorlds`]
//! (`formica.Worlds`, many worlds of one scenario stepped in one call).
//!
//! Every array is one fresh numpy array per call, filled straight from the simulation (no
//! Python object per robot). Units: metres, radians (counter-clockwise, world frame), seconds.

use crate::controllers::{
    attach_of_code, check_wheels, codes_of, numbers, slots_dict, PyLayout, Shape,
};
use crate::{guard, result_to_py, scenario_error, NotBool};
use formica::controller::Actuation;
use formica::experiment::{Run, RunOptions};
use formica::scenario::Color;
use formica::{Outcome, Overrides, Scenario};
use formica_cli::provenance::Provenance;
use numpy::{AllowTypeChange, PyArray1, PyArray2, PyArrayLike2, PyArrayLike3, PyArrayMethods};
use pyo3::exceptions::{PyIndexError, PyRuntimeError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use rayon::prelude::*;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex, MutexGuard, PoisonError, TryLockError};

/// Every colour, in code order: the LED codes of `World.leds` index this list.
const COLORS: [Color; 11] = Color::ALL;

/// The colour names, in code order (`formica.COLORS`).
pub(crate) fn color_names() -> Vec<&'static str> {
    COLORS.iter().map(|c| c.name()).collect()
}

/// The colour called `name`.
pub(crate) fn color_of_name(name: &str) -> Option<Color> {
    COLORS.iter().copied().find(|c| c.name() == name)
}

/// The colour with code `code` (its index in `formica.COLORS`).
pub(crate) fn color_of_code(code: i64) -> PyResult<Color> {
    usize::try_from(code)
        .ok()
        .and_then(|i| COLORS.get(i).copied())
        .ok_or_else(|| {
            PyValueError::new_err(format!(
                "LED code {code} is not a colour: expected 0 to {} (formica.COLORS)",
                COLORS.len() - 1
            ))
        })
}

fn color_code(c: Color) -> u8 {
    COLORS
        .iter()
        .position(|&k| k == c)
        .map_or(u8::MAX, |i| i as u8)
}

/// `out` as a writable float32 array of `D`'s dimensions, or an error that says what it must be.
fn out_buffer<'py, D: numpy::ndarray::Dimension>(
    out: &Bound<'py, PyAny>,
) -> PyResult<numpy::PyReadwriteArray<'py, f32, D>> {
    out.extract().map_err(|_| {
        let what = match (out.getattr("dtype"), out.getattr("ndim")) {
            (Ok(dtype), Ok(ndim)) => format!("a {ndim}-dimensional array of dtype {dtype}"),
            _ => format!("a {}", crate::type_name(out)),
        };
        PyTypeError::new_err(format!(
            "out: expected a writable {}-dimensional float32 numpy array, got {what}",
            D::NDIM.unwrap_or(0)
        ))
    })
}

/// The memory of an `out` buffer, if it is laid out row-major (C order), the index order the
/// readings are written in. (numpy's `as_slice_mut` takes any contiguous array, Fortran order
/// too.)
fn row_major<'a, 'py, D: numpy::ndarray::Dimension>(
    arr: &'a mut numpy::PyReadwriteArray<'py, f32, D>,
) -> PyResult<&'a mut [f32]> {
    let wrong = || {
        PyValueError::new_err(
            "out: expected a C-contiguous float32 array (row-major, as np.zeros makes it), got \
             another layout",
        )
    };
    if !arr.as_array().is_standard_layout() {
        return Err(wrong());
    }
    arr.as_slice_mut().map_err(|_| wrong())
}

/// Most worlds of one `Worlds`.
const MAX_WORLDS: usize = 10_000;
/// Most robots in all the worlds of one `Worlds` together (a robot holds 6 to 16 KiB as it
/// runs, so this is up to about 16 GB): past it, a request fails here with a message, where
/// running out of memory would abort the interpreter.
const MAX_WORLDS_ROBOTS: usize = 1_000_000;

/// Outcome codes of `Worlds.step`: 0 still running, 1 success, 2 wall, 3 timeout.
fn outcome_code(o: Option<Outcome>) -> i8 {
    match o {
        None => 0,
        Some(Outcome::Success) => 1,
        Some(Outcome::Wall) => 2,
        Some(Outcome::Timeout) => 3,
    }
}

/// How a world is built: the overrides of `World(...)` / `Worlds(...)`.
#[derive(Clone, Default)]
pub(crate) struct Build {
    pub(crate) duration: Option<f32>,
    pub(crate) controller: Option<String>,
    pub(crate) record: bool,
}

impl Build {
    pub(crate) fn check(&self, sc: &Scenario) -> PyResult<()> {
        if let Some(d) = self.duration {
            let max = formica::limits::MAX_DURATION_S;
            if !(d > 0.0 && d <= max) {
                return Err(PyValueError::new_err(format!(
                    "duration: expected more than 0 and at most {} seconds, got {d}",
                    formica::limits::show(max)
                )));
            }
        }
        if let Some(c) = &self.controller {
            if !sc.registry().has_controller(c) {
                return Err(PyValueError::new_err(format!(
                    "controller: {}",
                    sc.registry().unknown_controller(c)
                )));
            }
        }
        Ok(())
    }

    pub(crate) fn options(&self, seed: Option<u64>) -> RunOptions {
        RunOptions {
            overrides: Overrides {
                seed,
                duration_s: self.duration,
                controller: self.controller.clone(),
            },
            record: self.record,
            robot_every: 1,
            // Python controllers run on the caller's thread (the GIL).
            threads: 0,
        }
    }
}

/// The thread pool that builds and steps `Worlds`, one per process: a child forked from a
/// process that used it (`multiprocessing`'s default on Linux) has none of its threads, and
/// work handed to rayon's global pool there would wait for ever, so the child builds its own.
fn worlds_pool() -> PyResult<Arc<rayon::ThreadPool>> {
    static POOL: Mutex<Option<(u32, Arc<rayon::ThreadPool>)>> = Mutex::new(None);
    let mut pool = POOL.lock().unwrap_or_else(PoisonError::into_inner);
    let pid = std::process::id();
    match &*pool {
        Some((owner, p)) if *owner == pid => Ok(p.clone()),
        _ => {
            let p =
                Arc::new(rayon::ThreadPoolBuilder::new().build().map_err(|e| {
                    PyRuntimeError::new_err(format!("starting worker threads: {e}"))
                })?);
            // The parent's pool is not dropped here: its threads are not in this process.
            std::mem::forget(pool.replace((pid, p.clone())));
            Ok(p)
        }
    }
}

/// Whether a scenario (with the build's controller override) runs Python controllers, which
/// need the interpreter while they step.
pub(crate) fn uses_python(sc: &Scenario, b: &Build) -> bool {
    match &b.controller {
        Some(c) => crate::controllers::is_python(c),
        None => sc
            .spec
            .robots
            .iter()
            .any(|g| crate::controllers::is_python(g.get_ref().controller.get_ref())),
    }
}

/// One world and what Python set on it.
pub(crate) struct Sim {
    run: Run,
    /// Actions set from Python, applied before every tick until changed or cleared.
    held: Option<Vec<Actuation>>,
    /// Set while a tick runs: still set afterwards means the tick died half-way.
    broken: bool,
    python: bool,
    shapes: Vec<Arc<Shape>>,
    /// Which Formica made the result, and from what scenario.
    provenance: Provenance,
}

impl Sim {
    pub(crate) fn new(
        sc: &Scenario,
        b: &Build,
        seed: Option<u64>,
    ) -> Result<Sim, formica::ScenarioError> {
        let run = Run::new(sc, &b.options(seed))?;
        let shapes = run
            .world
            .groups
            .iter()
            .map(|g| Arc::new(Shape::of(&g.layout)))
            .collect();
        Ok(Sim {
            run,
            held: None,
            broken: false,
            python: uses_python(sc, b),
            shapes,
            provenance: Provenance::of(sc, &b.options(seed).overrides),
        })
    }

    /// Puts the actions set from Python in place of what the controllers decided.
    fn apply_held(&mut self) {
        if let Some(held) = &self.held {
            for (r, a) in self.run.world.robots.iter_mut().zip(held) {
                r.action = *a;
            }
        }
    }

    fn tick(&mut self) -> Option<Outcome> {
        if self.run.outcome().is_some() {
            return self.run.outcome();
        }
        self.apply_held();
        let out = self.run.step();
        self.apply_held();
        out
    }

    /// [`Sim::ticks`] in chunks, checking for Ctrl-C between them, the GIL released while a
    /// chunk runs unless Python controllers step (`broken` while a chunk runs, so that a panic
    /// or a Python exception leaves the world marked spent).
    fn ticks_interruptibly(&mut self, py: Python<'_>, n: u64) -> PyResult<Option<Outcome>> {
        let mut left = n;
        let mut out = self.run.outcome();
        while left > 0 && out.is_none() {
            let chunk = left.min(if self.python { 64 } else { 4096 });
            self.broken = true;
            out = if self.python {
                self.ticks(chunk)
            } else {
                py.detach(|| self.ticks(chunk))
            };
            self.broken = false;
            left -= chunk;
            py.check_signals()?;
        }
        Ok(out)
    }

    fn ticks(&mut self, n: u64) -> Option<Outcome> {
        let mut out = self.run.outcome();
        for _ in 0..n {
            out = self.tick();
            if out.is_some() {
                break;
            }
        }
        out
    }

    fn n(&self) -> usize {
        self.run.world.robots.len()
    }

    /// The robots of `group` (all: None), and their common readings shape.
    fn selection(&self, group: Option<usize>) -> PyResult<(Vec<usize>, Arc<Shape>)> {
        let w = &self.run.world;
        match group {
            Some(g) => {
                let shape = self.shapes.get(g).cloned().ok_or_else(|| {
                    PyIndexError::new_err(format!(
                        "group {g}: this world has {} robot group(s)",
                        self.shapes.len()
                    ))
                })?;
                let idx = (0..w.robots.len())
                    .filter(|&i| w.robots[i].group == g)
                    .collect();
                Ok((idx, shape))
            }
            None => {
                let Some(first) = self.shapes.first() else {
                    return Err(PyValueError::new_err("this world has no robots"));
                };
                if self.shapes.iter().any(|s| s.names != first.names) {
                    return Err(PyValueError::new_err(
                        "the robot groups' readings differ in layout: pass group=G",
                    ));
                }
                Ok(((0..w.robots.len()).collect(), first.clone()))
            }
        }
    }

    fn write_readings(&self, idx: &[usize], shape: &Shape, out: &mut [f32]) -> PyResult<()> {
        let l = shape.flat.len();
        for (row, &i) in out.chunks_exact_mut(l).zip(idx) {
            shape
                .flat
                .write(&self.run.world.robots[i].readings, row)
                .map_err(PyRuntimeError::new_err)?;
        }
        Ok(())
    }

    fn goal_distance(&self) -> f64 {
        let w = &self.run.world;
        match (w.target, w.goal()) {
            (Some(t), Some(g)) => f64::from((w.object_center(t) - g).length()),
            _ => f64::NAN,
        }
    }

    fn poses(&self) -> Vec<f32> {
        let w = &self.run.world;
        (0..w.robots.len())
            .flat_map(|i| {
                let p = w.robot_pose(i);
                [p.x, p.y, p.theta]
            })
            .collect()
    }

    fn object_poses(&self) -> Vec<f32> {
        let w = &self.run.world;
        (0..w.objects.len())
            .flat_map(|i| {
                let p = w.object_pose(i);
                [p.x, p.y, p.theta]
            })
            .collect()
    }

    /// Actions from arrays: wheel speeds `[N, 2]`, LED codes `[N]`, attach codes `[N]`.
    fn actions_of(
        &self,
        wheels: &[f32],
        leds: Option<Vec<i64>>,
        attach: Option<Vec<i64>>,
    ) -> PyResult<Vec<Actuation>> {
        let n = self.n();
        let mut out = Vec::with_capacity(n);
        for i in 0..n {
            let (left, right) = (wheels[2 * i], wheels[2 * i + 1]);
            check_wheels(left, right, || format!("set_actions, robot {i}"))?;
            let at_robot = |e| {
                Python::attach(|py| {
                    crate::controllers::prefix(py, e, &format!("set_actions, robot {i}"))
                })
            };
            let led = match &leds {
                Some(c) => color_of_code(c[i]).map_err(at_robot)?,
                None => Color::Off,
            };
            let attach = match &attach {
                Some(c) => attach_of_code(c[i]).map_err(at_robot)?,
                None => formica::controller::AttachCommand::Keep,
            };
            out.push(Actuation {
                left,
                right,
                led,
                attach,
                ..Actuation::default()
            });
        }
        Ok(out)
    }
}

/// A simulation shared with Python threads: one at a time. A thread that finds it in use by
/// another waits (with the GIL released, Ctrl-C still seen); a controller that reaches back
/// into the world stepping it gets an error instead of a deadlock.
pub(crate) struct SimCell {
    sim: Mutex<Sim>,
    /// The [`thread_number`] of the thread holding `sim`, 0 when none does.
    holder: AtomicU64,
}

/// A locked [`SimCell`].
pub(crate) struct Held<'a> {
    guard: MutexGuard<'a, Sim>,
    holder: &'a AtomicU64,
}

impl Drop for Held<'_> {
    fn drop(&mut self) {
        // Before the guard (a field) unlocks: while `sim` is locked, `holder` is 0 or the
        // holder's number, never a former holder's.
        self.holder.store(0, Ordering::SeqCst);
    }
}

impl std::ops::Deref for Held<'_> {
    type Target = Sim;
    fn deref(&self) -> &Sim {
        &self.guard
    }
}

impl std::ops::DerefMut for Held<'_> {
    fn deref_mut(&mut self) -> &mut Sim {
        &mut self.guard
    }
}

/// This thread's number (from 1), to tell the thread holding a [`SimCell`] from the others.
fn thread_number() -> u64 {
    static NEXT: AtomicU64 = AtomicU64::new(1);
    thread_local!(static ME: u64 = NEXT.fetch_add(1, Ordering::Relaxed));
    ME.with(|m| *m)
}

impl SimCell {
    fn new(sim: Sim) -> Self {
        SimCell {
            sim: Mutex::new(sim),
            holder: AtomicU64::new(0),
        }
    }

    /// Locks it, waiting while another thread holds it, even if it `broken`.
    fn lock_any(&self) -> PyResult<Held<'_>> {
        let me = thread_number();
        let guard = loop {
            match self.sim.try_lock() {
                Ok(g) => break g,
                Err(TryLockError::Poisoned(p)) => break p.into_inner(),
                Err(TryLockError::WouldBlock) => {
                    if self.holder.load(Ordering::SeqCst) == me {
                        return Err(PyRuntimeError::new_err(
                            "this World is being stepped by this very thread (a controller \
                             reaching back into the World that runs it); a controller reads \
                             what it needs from its readings",
                        ));
                    }
                    Python::attach(|py| {
                        py.check_signals()?;
                        py.detach(|| std::thread::sleep(std::time::Duration::from_micros(200)));
                        PyResult::Ok(())
                    })?;
                }
            }
        };
        self.holder.store(me, Ordering::SeqCst);
        Ok(Held {
            guard,
            holder: &self.holder,
        })
    }

    /// Locks it (waiting while another thread holds it); a world `broken` by an earlier error
    /// is refused.
    fn lock(&self) -> PyResult<Held<'_>> {
        self.lock_whole("this World", "build a new one")
    }

    /// [`SimCell::lock`], its refusal naming the world (`which`) and how to rebuild it.
    fn lock_whole(&self, which: &str, remedy: &str) -> PyResult<Held<'_>> {
        let g = self.lock_any()?;
        if g.broken {
            return Err(PyRuntimeError::new_err(format!(
                "{which} stopped half-way through a tick at an earlier error; {remedy}"
            )));
        }
        Ok(g)
    }
}

fn wheels_array(wheels: &Bound<'_, PyAny>, n: usize, who: &str) -> PyResult<Vec<f32>> {
    let arr: PyArrayLike2<'_, f32, AllowTypeChange> = numbers(wheels, who, "wheel speeds")?
        .extract()
        .map_err(|_| {
            PyValueError::new_err(format!(
                "{who}: wheel speeds must be a float array of shape ({n}, 2)"
            ))
        })?;
    let a = arr.as_array();
    if a.shape() != [n, 2] {
        return Err(PyValueError::new_err(format!(
            "{who}: wheel speeds must have shape ({n}, 2), got {:?}",
            a.shape()
        )));
    }
    Ok(a.iter().copied().collect())
}

/// One world of a scenario, for one seed, with its stop rules and metrics, stepped from Python.
///
/// `World(scenario, seed=None, duration=None, controller=None, record=False)`: `scenario` is a
/// `formica.Scenario` or a path; `seed` defaults to the file's `run.seed`; `controller`
/// replaces every group's controller (e.g. `"external"`, driven by `set_actions`). Any thread
/// may use it: a call waits while another thread steps it.
///
/// Arrays (fresh numpy arrays each call; N robots, M objects, L readings per robot):
/// `robot_poses` `[N, 3]` float32 (x m, y m, theta rad), `leds` `[N]` uint8 (codes into
/// `formica.COLORS`), `states` (list of N str), `released` / `attached` `[N]` bool,
/// `wheel_speeds` `[N, 2]` float32 (m/s, what the robots are told to drive with next; the
/// model caps each wheel at its top speed, and `wheels` errors apply after), `object_poses` `[M, 3]` float32 (x m, y m, theta
/// rad of each object's frame), `object_centers` `[M, 2]` (centre of mass, m), `readings()`
/// `[N, L]` float32 (see `reading_names()`).
#[pyclass(module = "formica", name = "World")]
pub struct PyWorld {
    sim: SimCell,
}

impl PyWorld {
    fn sim(&self) -> PyResult<Held<'_>> {
        self.sim.lock()
    }
}

#[pymethods]
impl PyWorld {
    #[new]
    #[pyo3(signature = (scenario, seed = None, duration = None, controller = None, record = false))]
    fn new(
        py: Python<'_>,
        scenario: &Bound<'_, PyAny>,
        seed: Option<NotBool<u64>>,
        duration: Option<NotBool<f32>>,
        controller: Option<String>,
        record: bool,
    ) -> PyResult<Self> {
        let (seed, duration) = (seed.map(|s| s.0), duration.map(|d| d.0));
        guard(|| {
            let sc = crate::scenario::scenario_of(py, scenario)?;
            let b = Build {
                duration,
                controller,
                record,
            };
            b.check(&sc)?;
            let sim = Sim::new(&sc, &b, seed).map_err(|e| scenario_error(py, &e))?;
            Ok(PyWorld {
                sim: SimCell::new(sim),
            })
        })
    }

    /// Advances `n` ticks, or fewer if the run ends; returns the outcome (`"success"`,
    /// `"wall"`, `"timeout"`) once the run is over, else None. Ctrl-C interrupts it.
    #[pyo3(signature = (n = NotBool(1)))]
    fn step(&self, py: Python<'_>, n: NotBool<u64>) -> PyResult<Option<&'static str>> {
        let n = n.0;
        guard(|| {
            let mut g = self.sim()?;
            Ok(g.ticks_interruptibly(py, n)?.map(Outcome::name))
        })
    }

    /// Steps to the end of the run and returns its result (as `run`).
    fn run<'py>(&self, py: Python<'py>) -> PyResult<Py<PyAny>> {
        self.step(py, NotBool(u64::MAX))?;
        self.result(py)
    }

    /// The result so far: the JSON line `formica run --json` prints, as a dict.
    fn result(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        guard(|| {
            let g = self.sim()?;
            result_to_py(py, &g.run.result(), &g.provenance)
        })
    }

    /// Whether the run is over.
    #[getter]
    fn done(&self) -> PyResult<bool> {
        Ok(self.sim()?.run.outcome().is_some())
    }

    /// `"success"`, `"wall"` or `"timeout"` once the run is over, else None.
    #[getter]
    fn outcome(&self) -> PyResult<Option<&'static str>> {
        Ok(self.sim()?.run.outcome().map(Outcome::name))
    }

    /// Ticks done.
    #[getter]
    fn tick(&self) -> PyResult<u64> {
        Ok(self.sim()?.run.world.tick)
    }

    /// Simulated time (s).
    #[getter]
    fn time_s(&self) -> PyResult<f64> {
        Ok(self.sim()?.run.world.time_s)
    }

    /// Seconds per tick.
    #[getter]
    fn tick_s(&self) -> PyResult<f32> {
        Ok(self.sim()?.run.world.tick_s)
    }

    /// The seed in use.
    #[getter]
    fn seed(&self) -> PyResult<u64> {
        Ok(self.sim()?.run.world.seed)
    }

    /// Number of robots, N.
    fn __len__(&self) -> PyResult<usize> {
        Ok(self.sim()?.n())
    }

    /// The robot groups: `[{"controller", "model", "count", "batched"}, ...]`.
    #[getter]
    fn groups<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        let g = self.sim()?;
        let w = &g.run.world;
        let list = PyList::empty(py);
        for (k, grp) in w.groups.iter().enumerate() {
            let d = PyDict::new(py);
            d.set_item("controller", &grp.controller)?;
            d.set_item("model", &grp.model_name)?;
            d.set_item("count", w.robots.iter().filter(|r| r.group == k).count())?;
            d.set_item("batched", grp.is_batched())?;
            list.append(d)?;
        }
        Ok(list)
    }

    /// Group index of each robot, `[N]` int64.
    #[getter]
    fn robot_groups<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<i64>>> {
        let g = self.sim()?;
        let v = g.run.world.robots.iter().map(|r| r.group as i64).collect();
        Ok(PyArray1::from_vec(py, v))
    }

    /// Robot poses `[N, 3]` float32: x (m), y (m), heading theta (rad); unreleased robots at
    /// their start pose.
    #[getter]
    fn robot_poses<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f32>>> {
        let g = self.sim()?;
        let n = g.n();
        PyArray1::from_vec(py, g.poses()).reshape([n, 3])
    }

    /// LED colours `[N]` uint8, codes into `formica.COLORS` (0: off).
    #[getter]
    fn leds<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<u8>>> {
        let g = self.sim()?;
        let v = g
            .run
            .world
            .robots
            .iter()
            .map(|r| color_code(r.led))
            .collect();
        Ok(PyArray1::from_vec(py, v))
    }

    /// Controller state names, one per robot (`waiting` before release).
    #[getter]
    fn states(&self) -> PyResult<Vec<&'static str>> {
        Ok(self
            .sim()?
            .run
            .world
            .robots
            .iter()
            .map(|r| r.state)
            .collect())
    }

    /// Whether each robot is in the arena yet, `[N]` bool.
    #[getter]
    fn released<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<bool>>> {
        let g = self.sim()?;
        let v = g
            .run
            .world
            .robots
            .iter()
            .map(|r| r.body.is_some())
            .collect();
        Ok(PyArray1::from_vec(py, v))
    }

    /// Whether each robot is attached to a body, `[N]` bool.
    #[getter]
    fn attached<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<bool>>> {
        let g = self.sim()?;
        let v = g
            .run
            .world
            .robots
            .iter()
            .map(|r| r.attached.is_some())
            .collect();
        Ok(PyArray1::from_vec(py, v))
    }

    /// Wheel speeds each robot drives with in the next tick, `[N, 2]` float32 (m/s, left and
    /// right): what its controller decided, or what `set_actions` holds.
    #[getter]
    fn wheel_speeds<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f32>>> {
        let g = self.sim()?;
        let n = g.n();
        let v = g
            .run
            .world
            .robots
            .iter()
            .flat_map(|r| [r.action.left, r.action.right])
            .collect();
        PyArray1::from_vec(py, v).reshape([n, 2])
    }

    /// Object poses `[M, 3]` float32: x (m), y (m), theta (rad) of each object's frame.
    #[getter]
    fn object_poses<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f32>>> {
        let g = self.sim()?;
        let m = g.run.world.objects.len();
        PyArray1::from_vec(py, g.object_poses()).reshape([m, 3])
    }

    /// Objects' centres of mass `[M, 2]` float32 (m).
    #[getter]
    fn object_centers<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f32>>> {
        let g = self.sim()?;
        let w = &g.run.world;
        let v = (0..w.objects.len())
            .flat_map(|i| {
                let c = w.object_center(i);
                [c.x, c.y]
            })
            .collect();
        PyArray1::from_vec(py, v).reshape([w.objects.len(), 2])
    }

    /// Index of the object whose transport is measured (the first movable one; object 0 if
    /// none moves), or None without objects.
    #[getter]
    fn target(&self) -> PyResult<Option<usize>> {
        Ok(self.sim()?.run.world.target)
    }

    /// Floor point of the goal light `(x, y)` (m), or None.
    #[getter]
    fn goal(&self) -> PyResult<Option<(f32, f32)>> {
        Ok(self.sim()?.run.world.goal().map(|g| (g.x, g.y)))
    }

    /// Distance from the target object's centre to the goal (m); NaN without either.
    #[getter]
    fn goal_distance(&self) -> PyResult<f64> {
        Ok(self.sim()?.goal_distance())
    }

    /// Radius of the success rule around the goal (m), or None.
    #[getter]
    fn goal_radius(&self) -> PyResult<Option<f32>> {
        Ok(self.sim()?.run.goal_radius())
    }

    /// Every robot's readings from the end of the last tick, `[N, L]` float32 (or only group
    /// `group`'s robots); columns named by `reading_names()`. Unreleased robots read zeros.
    /// `out`: a C-contiguous float32 array of that shape to fill instead of a new one.
    #[pyo3(signature = (group = None, out = None))]
    fn readings<'py>(
        &self,
        py: Python<'py>,
        group: Option<usize>,
        out: Option<Bound<'py, PyAny>>,
    ) -> PyResult<Py<PyAny>> {
        let out = out.map(|o| out_buffer::<numpy::Ix2>(&o)).transpose()?;
        let g = self.sim()?;
        let (idx, shape) = g.selection(group)?;
        let l = shape.flat.len();
        match out {
            Some(mut arr) => {
                if arr.as_array().shape() != [idx.len(), l] {
                    return Err(PyValueError::new_err(format!(
                        "out: expected shape ({}, {l}), got {:?}",
                        idx.len(),
                        arr.as_array().shape()
                    )));
                }
                let slice = row_major(&mut arr)?;
                g.write_readings(&idx, &shape, slice)?;
                drop(arr);
                Ok(py.None())
            }
            None => {
                let mut buf = vec![0.0f32; idx.len() * l];
                g.write_readings(&idx, &shape, &mut buf)?;
                Ok(PyArray1::from_vec(py, buf)
                    .reshape([idx.len(), l])?
                    .into_any()
                    .unbind())
            }
        }
    }

    /// Names of the readings' columns (all groups alike, or group `group`'s).
    #[pyo3(signature = (group = None))]
    fn reading_names(&self, group: Option<usize>) -> PyResult<Vec<String>> {
        let g = self.sim()?;
        Ok(g.selection(group)?.1.names.clone())
    }

    /// `{slot: (offset, length)}` of the readings' columns.
    #[pyo3(signature = (group = None))]
    fn reading_slots<'py>(
        &self,
        py: Python<'py>,
        group: Option<usize>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let g = self.sim()?;
        slots_dict(py, &g.selection(group)?.1)
    }

    /// `(low, high)`, float32 `[L]` each: bounds that every value of the readings' columns
    /// (all groups alike, or group `group`'s) keeps over this run, from the arena, the sensor
    /// noise (its largest draw) and the run's duration: proximity, light and the flags in
    /// [0, 1], `theta` in [-pi, pi], positions in the arena (and 0, what a robot not yet
    /// released reads), `time_s` in [0, duration].
    #[pyo3(signature = (group = None))]
    #[allow(clippy::type_complexity)]
    fn reading_bounds<'py>(
        &self,
        py: Python<'py>,
        group: Option<usize>,
    ) -> PyResult<(Bound<'py, PyArray1<f32>>, Bound<'py, PyArray1<f32>>)> {
        let g = self.sim()?;
        g.selection(group)?;
        let groups = match group {
            Some(k) => k..k + 1,
            None => 0..g.shapes.len(),
        };
        let mut bounds: Option<(Vec<f32>, Vec<f32>)> = None;
        for k in groups {
            let (lo, hi) = g
                .run
                .reading_bounds(k)
                .ok_or_else(|| PyIndexError::new_err(format!("group {k}: no such group")))?;
            bounds = Some(match bounds {
                None => (lo, hi),
                Some((l, h)) => (
                    l.iter().zip(&lo).map(|(a, b)| a.min(*b)).collect(),
                    h.iter().zip(&hi).map(|(a, b)| a.max(*b)).collect(),
                ),
            });
        }
        let (lo, hi) = bounds.ok_or_else(|| PyValueError::new_err("this world has no robots"))?;
        Ok((PyArray1::from_vec(py, lo), PyArray1::from_vec(py, hi)))
    }

    /// The sensor layout of group `group`'s robots.
    #[pyo3(signature = (group = 0))]
    fn layout(&self, group: usize) -> PyResult<PyLayout> {
        let g = self.sim()?;
        let grp = g.run.world.groups.get(group).ok_or_else(|| {
            PyIndexError::new_err(format!(
                "group {group}: this world has {} group(s)",
                g.shapes.len()
            ))
        })?;
        Ok(PyLayout::new(&grp.layout, g.shapes[group].clone()))
    }

    /// Drives the robots from outside: wheel speeds `[N, 2]` (m/s, left and right; clamped to
    /// the model's maximum), optional LED codes `[N]` and attach codes `[N]` (-1 detach, 0 keep,
    /// 1 attach). They replace what the robots' controllers decide, on every following tick,
    /// until set again or `clear_actions()`. Non-finite speeds or wrong shapes: ValueError.
    #[pyo3(signature = (wheels, leds = None, attach = None))]
    fn set_actions(
        &self,
        wheels: &Bound<'_, PyAny>,
        leds: Option<&Bound<'_, PyAny>>,
        attach: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<()> {
        let mut g = self.sim()?;
        let n = g.n();
        let w = wheels_array(wheels, n, "set_actions")?;
        let leds = leds
            .filter(|v| !v.is_none())
            .map(|v| codes_of(v, n, "set_actions", "leds"))
            .transpose()?;
        let attach = attach
            .filter(|v| !v.is_none())
            .map(|v| codes_of(v, n, "set_actions", "attach"))
            .transpose()?;
        let actions = g.actions_of(&w, leds, attach)?;
        g.held = Some(actions);
        g.apply_held();
        Ok(())
    }

    /// Hands the robots back to their own controllers.
    fn clear_actions(&self) -> PyResult<()> {
        self.sim()?.held = None;
        Ok(())
    }

    /// Recorded trajectories (with `record=True`): `{"object": [T, 4] (t s, x m, y m,
    /// theta rad) every tick, "robots": [K, 5] (t, robot, x, y, theta)}` as float64 arrays.
    fn trajectories<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        let g = self.sim()?;
        let Some(tr) = g.run.trajectories() else {
            return Ok(None);
        };
        let d = PyDict::new(py);
        let obj: Vec<f64> = tr
            .object
            .iter()
            .flat_map(|s| [s.t, f64::from(s.x), f64::from(s.y), f64::from(s.theta)])
            .collect();
        d.set_item(
            "object",
            PyArray1::from_vec(py, obj).reshape([tr.object.len(), 4])?,
        )?;
        let rob: Vec<f64> = tr
            .robots
            .iter()
            .flat_map(|s| {
                [
                    s.t,
                    f64::from(s.id.unwrap_or(0)),
                    f64::from(s.x),
                    f64::from(s.y),
                    f64::from(s.theta),
                ]
            })
            .collect();
        d.set_item(
            "robots",
            PyArray1::from_vec(py, rob).reshape([tr.robots.len(), 5])?,
        )?;
        Ok(Some(d))
    }

    fn __repr__(&self) -> String {
        match self.sim() {
            Ok(g) => format!(
                "World({} robots, seed {}, tick {}, {})",
                g.n(),
                g.run.world.seed,
                g.run.world.tick,
                g.run.outcome().map_or("running", Outcome::name)
            ),
            Err(_) => "World(unavailable)".into(),
        }
    }
}

/// Many worlds of one scenario (one per seed), stepped together in one call, in parallel on
/// every core when no Python controller runs in them: the engine of `formica.env`'s vectorised
/// environment.
///
/// `Worlds(scenario, seeds, duration=None, controller=None)`. Arrays have a leading world axis
/// E: `readings()` `[E, N, L]`, `robot_poses` `[E, N, 3]`, `object_poses` `[E, M, 3]`,
/// `goal_distances` `[E]`; `step()` returns outcome codes `[E]` int8 (0 running, 1 success,
/// 2 wall, 3 timeout).
#[pyclass(module = "formica", name = "Worlds")]
pub struct PyWorlds {
    sims: Vec<SimCell>,
    scenario: Scenario,
    build: Build,
    python: bool,
    n: usize,
}

impl PyWorlds {
    fn locks(&self) -> PyResult<Vec<Held<'_>>> {
        self.sims
            .iter()
            .enumerate()
            .map(|(i, m)| {
                m.lock_whole(
                    &format!("world {i}"),
                    &format!("reset({i}, seed) rebuilds it"),
                )
            })
            .collect()
    }
}

#[pymethods]
impl PyWorlds {
    #[new]
    #[pyo3(signature = (scenario, seeds, duration = None, controller = None))]
    fn new(
        py: Python<'_>,
        scenario: &Bound<'_, PyAny>,
        seeds: Vec<NotBool<u64>>,
        duration: Option<NotBool<f32>>,
        controller: Option<String>,
    ) -> PyResult<Self> {
        let seeds: Vec<u64> = seeds.into_iter().map(|s| s.0).collect();
        let duration = duration.map(|d| d.0);
        guard(|| {
            let sc = crate::scenario::scenario_of(py, scenario)?;
            let build = Build {
                duration,
                controller,
                record: false,
            };
            build.check(&sc)?;
            if seeds.is_empty() {
                return Err(PyValueError::new_err("seeds: expected at least one seed"));
            }
            if seeds.len() > MAX_WORLDS {
                return Err(PyValueError::new_err(format!(
                    "seeds: at most {MAX_WORLDS} worlds in one Worlds, got {} (each is a whole \
                     simulation held in memory)",
                    seeds.len()
                )));
            }
            let robots = seeds.len().saturating_mul(sc.robot_count());
            if robots > MAX_WORLDS_ROBOTS {
                return Err(PyValueError::new_err(format!(
                    "seeds: {} worlds of {} robots are {robots} robots, and one Worlds holds at \
                     most {MAX_WORLDS_ROBOTS} (6 to 16 KiB each in memory): use fewer worlds \
                     or smaller swarms",
                    seeds.len(),
                    sc.robot_count()
                )));
            }
            let python = uses_python(&sc, &build);
            let built: Vec<Result<Sim, formica::ScenarioError>> = if python {
                seeds
                    .iter()
                    .map(|&s| Sim::new(&sc, &build, Some(s)))
                    .collect()
            } else {
                let pool = worlds_pool()?;
                py.detach(|| {
                    pool.install(|| {
                        seeds
                            .par_iter()
                            .map(|&s| Sim::new(&sc, &build, Some(s)))
                            .collect()
                    })
                })
            };
            let sims: Vec<Sim> = built
                .into_iter()
                .collect::<Result<_, _>>()
                .map_err(|e| scenario_error(py, &e))?;
            let n = sims[0].n();
            Ok(PyWorlds {
                sims: sims.into_iter().map(SimCell::new).collect(),
                scenario: sc,
                build,
                python,
                n,
            })
        })
    }

    /// Number of worlds, E.
    fn __len__(&self) -> usize {
        self.sims.len()
    }

    /// Robots per world, N.
    #[getter]
    fn robots(&self) -> usize {
        self.n
    }

    /// Each world's seed.
    #[getter]
    fn seeds(&self) -> PyResult<Vec<u64>> {
        Ok(self.locks()?.iter().map(|g| g.run.world.seed).collect())
    }

    /// Rebuilds world `index` from the scenario with `seed`, and runs its first `ticks`
    /// ticks with the robots' own controllers (`external`: standing still).
    #[pyo3(signature = (index, seed, ticks = NotBool(0)))]
    fn reset(
        &self,
        py: Python<'_>,
        index: NotBool<usize>,
        seed: NotBool<u64>,
        ticks: NotBool<u64>,
    ) -> PyResult<()> {
        let (index, seed, ticks) = (index.0, seed.0, ticks.0);
        guard(|| {
            let m = self.sims.get(index).ok_or_else(|| {
                PyIndexError::new_err(format!("world {index}: there are {}", self.sims.len()))
            })?;
            let mut sim = Sim::new(&self.scenario, &self.build, Some(seed))
                .map_err(|e| scenario_error(py, &e))?;
            sim.ticks_interruptibly(py, ticks)?;
            // A broken world is what a reset replaces.
            let mut g = m.lock_any()?;
            *g = sim;
            Ok(())
        })
    }

    /// Sets every world's robots' wheel speeds (`[E, N, 2]`, m/s; None keeps what was set)
    /// and steps every world that is still running `ticks` ticks. Returns outcome codes `[E]`
    /// int8: 0 running, 1 success, 2 wall, 3 timeout.
    #[pyo3(signature = (wheels = None, ticks = NotBool(1)))]
    fn step<'py>(
        &self,
        py: Python<'py>,
        wheels: Option<&Bound<'py, PyAny>>,
        ticks: NotBool<u64>,
    ) -> PyResult<Bound<'py, PyArray1<i8>>> {
        let ticks = ticks.0;
        guard(|| {
            let mut locks = self.locks()?;
            let (e, n) = (locks.len(), self.n);
            if let Some(w) = wheels.filter(|v| !v.is_none()) {
                let arr: PyArrayLike3<'_, f32, AllowTypeChange> =
                    numbers(w, "step", "wheel speeds")?.extract().map_err(|_| {
                        PyValueError::new_err(format!(
                            "step: wheel speeds must be a float array of shape ({e}, {n}, 2)"
                        ))
                    })?;
                let a = arr.as_array();
                if a.shape() != [e, n, 2] {
                    return Err(PyValueError::new_err(format!(
                        "step: wheel speeds must have shape ({e}, {n}, 2), got {:?}",
                        a.shape()
                    )));
                }
                let flat: Vec<f32> = a.iter().copied().collect();
                // Every world's actions are checked before any is set: a rejected call
                // changes nothing.
                let mut all = Vec::with_capacity(e);
                for (k, g) in locks.iter().enumerate() {
                    let actions = g
                        .actions_of(&flat[k * n * 2..(k + 1) * n * 2], None, None)
                        .map_err(|err| {
                            PyValueError::new_err(format!(
                                "step, world {k}: {}",
                                err.value(py)
                                    .str()
                                    .map_or_else(|_| "bad wheel speeds".into(), |s| s.to_string())
                            ))
                        })?;
                    all.push(actions);
                }
                for (g, actions) in locks.iter_mut().zip(all) {
                    g.held = Some(actions);
                    g.apply_held();
                }
            }
            let run = |g: &mut Sim, chunk: u64| {
                g.broken = true;
                let o = g.ticks(chunk);
                g.broken = false;
                o
            };
            let mut sims: Vec<&mut Sim> = locks.iter_mut().map(|g| &mut **g).collect();
            let outcomes: Vec<Option<Outcome>> = if self.python {
                // World after world, on this thread.
                sims.iter_mut()
                    .enumerate()
                    .map(|(i, g)| {
                        g.ticks_interruptibly(py, ticks).inspect_err(|e| {
                            // The exception as raised, with a note of where (Python 3.11+).
                            let note = format!(
                                "in world {i} of this Worlds, stepped one after another: the \
                                 worlds before it took their ticks, those after it none; \
                                 reset({i}, seed) rebuilds it"
                            );
                            let _ = e.value(py).call_method1("add_note", (note,));
                        })
                    })
                    .collect::<PyResult<_>>()?
            } else {
                // In chunks, the GIL released for each, so that Ctrl-C interrupts a long call
                // (as `World.step`); a world that has ended ticks no more.
                let mut left = ticks;
                let mut outcomes: Vec<Option<Outcome>> =
                    sims.iter().map(|g| g.run.outcome()).collect();
                let pool = worlds_pool()?;
                while left > 0 && outcomes.iter().any(Option::is_none) {
                    let chunk = left.min(4096);
                    outcomes = py.detach(|| {
                        pool.install(|| sims.par_iter_mut().map(|g| run(g, chunk)).collect())
                    });
                    left -= chunk;
                    py.check_signals()?;
                }
                outcomes
            };
            let codes: Vec<i8> = outcomes.into_iter().map(outcome_code).collect();
            Ok(PyArray1::from_vec(py, codes))
        })
    }

    /// Every world's robots' readings, `[E, N, L]` float32 (`out`: an array of that shape to
    /// fill instead).
    #[pyo3(signature = (out = None))]
    fn readings<'py>(
        &self,
        py: Python<'py>,
        out: Option<Bound<'py, PyAny>>,
    ) -> PyResult<Py<PyAny>> {
        let out = out.map(|o| out_buffer::<numpy::Ix3>(&o)).transpose()?;
        let locks = self.locks()?;
        let (idx, shape) = locks[0].selection(None)?;
        let (e, n, l) = (locks.len(), idx.len(), shape.flat.len());
        let fill = |buf: &mut [f32]| -> PyResult<()> {
            for (chunk, g) in buf.chunks_exact_mut(n * l).zip(&locks) {
                g.write_readings(&idx, &shape, chunk)?;
            }
            Ok(())
        };
        match out {
            Some(mut arr) => {
                if arr.as_array().shape() != [e, n, l] {
                    return Err(PyValueError::new_err(format!(
                        "out: expected shape ({e}, {n}, {l}), got {:?}",
                        arr.as_array().shape()
                    )));
                }
                let slice = row_major(&mut arr)?;
                fill(slice)?;
                Ok(py.None())
            }
            None => {
                let mut buf = vec![0.0f32; e * n * l];
                fill(&mut buf)?;
                Ok(PyArray1::from_vec(py, buf)
                    .reshape([e, n, l])?
                    .into_any()
                    .unbind())
            }
        }
    }

    /// Names of the readings' columns.
    fn reading_names(&self) -> PyResult<Vec<String>> {
        let locks = self.locks()?;
        Ok(locks[0].selection(None)?.1.names.clone())
    }

    /// The sensor layout of the first group's robots.
    fn layout(&self) -> PyResult<PyLayout> {
        let locks = self.locks()?;
        let g = &locks[0];
        let grp = g
            .run
            .world
            .groups
            .first()
            .ok_or_else(|| PyValueError::new_err("these worlds have no robots"))?;
        Ok(PyLayout::new(&grp.layout, g.shapes[0].clone()))
    }

    /// Distance from each world's target object to its goal, `[E]` float64 (m).
    #[getter]
    fn goal_distances<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let v = self.locks()?.iter().map(|g| g.goal_distance()).collect();
        Ok(PyArray1::from_vec(py, v))
    }

    /// Outcome codes `[E]` int8 (0 running, 1 success, 2 wall, 3 timeout).
    #[getter]
    fn outcomes<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<i8>>> {
        let v = self
            .locks()?
            .iter()
            .map(|g| outcome_code(g.run.outcome()))
            .collect();
        Ok(PyArray1::from_vec(py, v))
    }

    /// Ticks done in each world, `[E]` int64.
    #[getter]
    fn ticks<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<i64>>> {
        let v = self
            .locks()?
            .iter()
            .map(|g| g.run.world.tick as i64)
            .collect();
        Ok(PyArray1::from_vec(py, v))
    }

    /// Robot poses `[E, N, 3]` float32 (x m, y m, theta rad).
    #[getter]
    fn robot_poses<'py>(&self, py: Python<'py>) -> PyResult<Py<PyAny>> {
        let locks = self.locks()?;
        let v: Vec<f32> = locks.iter().flat_map(|g| g.poses()).collect();
        Ok(PyArray1::from_vec(py, v)
            .reshape([locks.len(), self.n, 3])?
            .into_any()
            .unbind())
    }

    /// Object poses `[E, M, 3]` float32 (x m, y m, theta rad).
    #[getter]
    fn object_poses<'py>(&self, py: Python<'py>) -> PyResult<Py<PyAny>> {
        let locks = self.locks()?;
        let m = locks[0].run.world.objects.len();
        let v: Vec<f32> = locks.iter().flat_map(|g| g.object_poses()).collect();
        Ok(PyArray1::from_vec(py, v)
            .reshape([locks.len(), m, 3])?
            .into_any()
            .unbind())
    }

    /// The result so far of world `index`, as a dict.
    fn result(&self, py: Python<'_>, index: usize) -> PyResult<Py<PyAny>> {
        let m = self.sims.get(index).ok_or_else(|| {
            PyIndexError::new_err(format!("world {index}: there are {}", self.sims.len()))
        })?;
        let g = m.lock()?;
        result_to_py(py, &g.run.result(), &g.provenance)
    }
}
