//! `formica._formica`: the compiled half of the Python package `formica`.
//!
//! The Python sources in `formica/` wrap these classes and functions; users import `formica`.
//! What lives here: scenarios ([`scenario`]), worlds as numpy arrays ([`world`]), runs and sweeps
//! ([`runs`]), and controllers written in Python ([`controllers`]).
//!
//! Errors: a scenario error becomes `formica.ScenarioError` (a `ValueError`) with the same
//! `file:line:column: message` text; a Python exception raised by a Python controller inside the
//! simulation comes back out unchanged; any Rust panic becomes `formica.PanicError` (a
//! `RuntimeError`), never a crashed interpreter.

use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use std::any::Any;
use std::panic::AssertUnwindSafe;

mod controllers;
mod runs;
mod scenario;
mod world;

pyo3::create_exception!(
    formica._formica,
    ScenarioError,
    PyValueError,
    "A scenario file (or an override of it) that failed to load or validate. `str(e)` is \
     `file:line:column: message`, as the formica command prints it; the attributes `file`, \
     `line`, `column` (1-based; None when the file could not be read) and `message` hold the \
     parts."
);

pyo3::create_exception!(
    formica._formica,
    PanicError,
    PyRuntimeError,
    "A bug inside the simulator (a Rust panic), turned into an exception."
);

/// A Python exception raised inside the simulation (by a Python controller), carried out of
/// the simulator as a panic payload and raised again at the Python boundary.
pub(crate) struct Raised(pub(crate) PyErr);

/// The Python type name of `v`, for error messages ("" if Python cannot say).
pub(crate) fn type_name(v: &Bound<'_, PyAny>) -> String {
    v.get_type()
        .name()
        .map(|n| n.to_string())
        .unwrap_or_default()
}

/// A number argument that refuses `True` and `False` (Python's bool is an int, so `seed=True`
/// would run seed 1 and `duration=True` one second), and says that a negative one is negative.
pub(crate) struct NotBool<T>(pub(crate) T);

impl<'a, 'py, T: FromPyObject<'a, 'py>> FromPyObject<'a, 'py> for NotBool<T> {
    type Error = PyErr;

    fn extract(obj: pyo3::Borrowed<'a, 'py, PyAny>) -> PyResult<Self> {
        if obj.is_instance_of::<pyo3::types::PyBool>() {
            return Err(pyo3::exceptions::PyTypeError::new_err(
                "expected a number, got a bool",
            ));
        }
        obj.extract::<T>().map(NotBool).map_err(|e| {
            // A negative int for an unsigned one: say so, not "can't convert negative int to
            // unsigned" (an OverflowError).
            let e: PyErr = e.into();
            match obj.extract::<i64>() {
                Ok(v) if v < 0 => pyo3::exceptions::PyValueError::new_err(format!(
                    "expected a whole number, 0 or more, got {v}"
                )),
                _ => e,
            }
        })
    }
}

/// Leaves the simulation with the Python exception `e`; [`guard`] raises it again.
pub(crate) fn raise(e: PyErr) -> ! {
    std::panic::panic_any(Raised(e))
}

/// Runs `f`, turning a panic into a Python exception: a [`Raised`] one into the exception it
/// carries, any other into [`PanicError`].
pub(crate) fn guard<T>(f: impl FnOnce() -> PyResult<T>) -> PyResult<T> {
    match std::panic::catch_unwind(AssertUnwindSafe(f)) {
        Ok(r) => r,
        Err(payload) => Err(from_panic(payload)),
    }
}

fn from_panic(payload: Box<dyn Any + Send>) -> PyErr {
    match payload.downcast::<Raised>() {
        Ok(r) => r.0,
        Err(p) => {
            let text = formica::world::panic_message(p.as_ref())
                .unwrap_or_else(|| "(no message)".to_string());
            PanicError::new_err(format!("the simulator panicked: {text}"))
        }
    }
}

/// `formica.ScenarioError` for a core scenario error, with its parts as attributes.
pub(crate) fn scenario_error(py: Python<'_>, e: &formica::ScenarioError) -> PyErr {
    // From Python, an unknown controller is most often one registered too late.
    let hint = |m: &str| {
        if m.contains("unknown controller `") {
            format!(
                "{m} (a controller written in Python is known once registered, \
                 formica.register_controller, before a scenario naming it is loaded)"
            )
        } else {
            m.to_string()
        }
    };
    let err = ScenarioError::new_err(hint(&e.to_string()));
    let value = err.value(py);
    let parts = match e {
        formica::ScenarioError::Invalid {
            file,
            line,
            column,
            message,
        } => (file.clone(), Some(*line), Some(*column), hint(message)),
        formica::ScenarioError::Io { file, message } => (file.clone(), None, None, hint(message)),
    };
    let set = || -> PyResult<()> {
        value.setattr("file", parts.0)?;
        value.setattr("line", parts.1)?;
        value.setattr("column", parts.2)?;
        value.setattr("message", parts.3)?;
        Ok(())
    };
    match set() {
        Ok(()) => err,
        Err(e) => e,
    }
}

/// `ScenarioError` for a message that names `file:line:column` at its start (as the command's
/// input errors do), with the parts parsed back out where they are there.
pub(crate) fn input_error(py: Python<'_>, text: &str) -> PyErr {
    let mut it = text.splitn(4, ':');
    let parsed = match (it.next(), it.next(), it.next(), it.next()) {
        (Some(file), Some(line), Some(col), Some(rest)) => {
            match (line.parse::<usize>(), col.parse::<usize>()) {
                (Ok(line), Ok(column)) => Some(formica::ScenarioError::Invalid {
                    file: file.to_string(),
                    line,
                    column,
                    message: rest.trim_start().to_string(),
                }),
                _ => None,
            }
        }
        _ => None,
    };
    match parsed {
        Some(e) => scenario_error(py, &e),
        None => {
            let err = ScenarioError::new_err(text.to_string());
            let value = err.value(py);
            let _ = value.setattr("file", py.None());
            let _ = value.setattr("line", py.None());
            let _ = value.setattr("column", py.None());
            let _ = value.setattr("message", text);
            err
        }
    }
}

/// A run's result with its provenance, as the dict `json.loads` makes of the JSON line
/// `formica run --json` prints (keys in the line's order).
pub(crate) fn result_to_py(
    py: Python<'_>,
    r: &formica::RunResult,
    provenance: &formica_cli::provenance::Provenance,
) -> PyResult<Py<PyAny>> {
    let stamped = formica_cli::provenance::Stamped {
        result: r,
        provenance,
    };
    let line =
        serde_json::to_string(&stamped).map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
    Ok(py
        .import(pyo3::intern!(py, "json"))?
        .call_method1(pyo3::intern!(py, "loads"), (line,))?
        .unbind())
}

/// Installs a panic hook that stays quiet for [`Raised`] payloads (a Python exception on its
/// way out, which Python reports itself) and otherwise defers to the previous hook.
fn quiet_raised_panics() {
    let previous = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        if !info.payload().is::<Raised>() {
            previous(info);
        }
    }));
}

/// The compiled module.
#[pymodule]
fn _formica(m: &Bound<'_, PyModule>) -> PyResult<()> {
    quiet_raised_panics();
    let py = m.py();
    m.add("ScenarioError", py.get_type::<ScenarioError>())?;
    m.add("PanicError", py.get_type::<PanicError>())?;
    m.add("COLORS", world::color_names())?;
    m.add("_MAX_RUN_SEEDS", formica::limits::MAX_RUN_SEEDS)?;
    m.add_class::<scenario::PyScenario>()?;
    m.add_class::<world::PyWorld>()?;
    m.add_class::<world::PyWorlds>()?;
    m.add_class::<controllers::PyRng>()?;
    m.add_class::<controllers::PyRngs>()?;
    m.add_class::<controllers::PyLayout>()?;
    m.add_class::<controllers::PyReadings>()?;
    m.add_class::<controllers::PyBatch>()?;
    m.add_function(wrap_pyfunction!(scenario::load, m)?)?;
    m.add_function(wrap_pyfunction!(scenario::parse, m)?)?;
    m.add_function(wrap_pyfunction!(scenario::_scenario_from_parts, m)?)?;
    m.add_function(wrap_pyfunction!(scenario::bench_scenario, m)?)?;
    m.add_function(wrap_pyfunction!(scenario::shipped_scenario, m)?)?;
    m.add_function(wrap_pyfunction!(runs::run_seeds, m)?)?;
    m.add_function(wrap_pyfunction!(runs::command, m)?)?;
    m.add_function(wrap_pyfunction!(controllers::register_robot, m)?)?;
    m.add_function(wrap_pyfunction!(controllers::register_batch, m)?)?;
    m.add_function(wrap_pyfunction!(controllers::controller_names, m)?)?;
    m.add_function(wrap_pyfunction!(controllers::panic_for_test, m)?)?;
    controllers::register_external().map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
    Ok(())
}
