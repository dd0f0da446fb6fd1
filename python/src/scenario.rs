//! Scenarios from Python: `formica.load(path)`, `formica.parse(text)`, and
//! `Scenario.set(key, value)` with the keys of `--set` and sweep files.

use crate::{guard, scenario_error};
use formica::{Scenario, ScenarioError};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};
use std::path::PathBuf;
use std::sync::{Mutex, PoisonError};

/// The file's text with the overrides applied, checked against the process-wide registry.
fn parse_all(
    file: &str,
    text: &str,
    overrides: &[(String, toml::Value)],
) -> Result<Scenario, ScenarioError> {
    if overrides.is_empty() {
        return Scenario::parse(text, file);
    }
    let origin: Vec<String> = overrides
        .iter()
        .map(|(k, v)| format!("{k} = {v}"))
        .collect();
    Scenario::parse_with_overrides(text, file, overrides, ("Scenario.set", &origin.join("\n")))
}

/// A Python value as a TOML value: bool, int, float, str, lists / tuples and dicts of them
/// (numpy scalars and arrays too).
/// `v` as a scenario value: nested at most [`formica::limits::MAX_NESTING`] deep (a list that
/// holds itself is refused, not followed until the stack runs out).
fn py_to_toml(v: &Bound<'_, PyAny>) -> PyResult<toml::Value> {
    to_toml(v, 0)
}

fn to_toml(v: &Bound<'_, PyAny>, depth: usize) -> PyResult<toml::Value> {
    if depth > formica::limits::MAX_NESTING {
        return Err(PyValueError::new_err(format!(
            "a scenario value nests lists and dicts at most {} deep (does a list hold itself?)",
            formica::limits::MAX_NESTING
        )));
    }
    if let Ok(b) = v.cast::<PyBool>() {
        return Ok(toml::Value::Boolean(b.is_true()));
    }
    if v.is_instance_of::<PyInt>() {
        return v
            .extract()
            .map(toml::Value::Integer)
            .map_err(|_| PyValueError::new_err(format!("{v} does not fit in a 64-bit integer")));
    }
    if v.is_instance_of::<PyFloat>() {
        return Ok(toml::Value::Float(v.extract()?));
    }
    if let Ok(s) = v.cast::<PyString>() {
        return Ok(toml::Value::String(s.to_str()?.to_string()));
    }
    if let Ok(d) = v.cast::<PyDict>() {
        let mut t = toml::Table::new();
        for (k, item) in d.iter() {
            let key: String = k
                .extract()
                .map_err(|_| PyTypeError::new_err("scenario tables need string keys"))?;
            t.insert(key, to_toml(&item, depth + 1)?);
        }
        return Ok(toml::Value::Table(t));
    }
    if v.is_instance_of::<PyList>() || v.is_instance_of::<PyTuple>() {
        let items: PyResult<Vec<toml::Value>> = v
            .try_iter()?
            .map(|item| to_toml(&item?, depth + 1))
            .collect();
        return Ok(toml::Value::Array(items?));
    }
    if v.hasattr("dtype")? && v.hasattr("tolist")? {
        return to_toml(&v.call_method0("tolist")?, depth);
    }
    Err(PyTypeError::new_err(format!(
        "cannot put a {} in a scenario: expected bool, int, float, str, list or dict",
        v.get_type().name()?
    )))
}

/// A scenario: a file's text, the overrides set on it, and the checked result.
///
/// `formica.load(path)` or `formica.parse(text, file)` make one; `set(key, value)` overrides a
/// key as `formica run --set` and sweep files do (`"robots.0.count"`, `"run.duration_s"`,
/// `"robots.0.params.perception"`) and checks the result at once. Controller names resolve in
/// the process-wide registry, so register Python controllers before loading scenarios that
/// name them (a scenario checked earlier is checked again once more are registered).
#[pyclass(module = "formica", name = "Scenario")]
pub struct PyScenario {
    file: String,
    text: String,
    overrides: Vec<(String, toml::Value)>,
    parsed: Mutex<(Scenario, u64)>,
}

impl PyScenario {
    fn make(
        file: String,
        text: String,
        overrides: Vec<(String, toml::Value)>,
    ) -> Result<Self, ScenarioError> {
        let generation = crate::controllers::generation();
        let sc = parse_all(&file, &text, &overrides)?;
        Ok(PyScenario {
            file,
            text,
            overrides,
            parsed: Mutex::new((sc, generation)),
        })
    }

    /// The checked scenario, checked again if controllers were registered since.
    pub(crate) fn resolve(&self, py: Python<'_>) -> PyResult<Scenario> {
        let mut g = self.parsed.lock().unwrap_or_else(PoisonError::into_inner);
        let now = crate::controllers::generation();
        if g.1 != now {
            let sc = parse_all(&self.file, &self.text, &self.overrides)
                .map_err(|e| scenario_error(py, &e))?;
            *g = (sc, now);
        }
        Ok(g.0.clone())
    }

    fn current(&self) -> Scenario {
        self.parsed
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .0
            .clone()
    }
}

/// The scenario `obj` stands for: a `Scenario`, or a path to load.
pub(crate) fn scenario_of(py: Python<'_>, obj: &Bound<'_, PyAny>) -> PyResult<Scenario> {
    if let Ok(s) = obj.cast::<PyScenario>() {
        return s.borrow().resolve(py);
    }
    let path: PathBuf = obj.extract().map_err(|_| {
        PyTypeError::new_err(format!(
            "expected a formica.Scenario or a path, got {}",
            crate::type_name(obj)
        ))
    })?;
    let s = load_file(&path).map_err(|e| scenario_error(py, &e))?;
    s.resolve(py)
}

fn load_file(path: &std::path::Path) -> Result<PyScenario, ScenarioError> {
    let file = path.display().to_string();
    let text =
        formica::limits::read_text(path).map_err(|e| formica::limits::read_error(&file, &e))?;
    PyScenario::make(file, text, Vec::new())
}

#[pymethods]
impl PyScenario {
    /// Overrides `key` (a dotted path into the file, array elements by index) with `value`
    /// and checks the scenario; raises `ScenarioError` (naming the key) and leaves the scenario
    /// as it was if the result is invalid. Returns the scenario, so calls chain.
    fn set<'py>(
        slf: Bound<'py, Self>,
        key: String,
        value: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, Self>> {
        let py = slf.py();
        let v = py_to_toml(value).map_err(|e| {
            // The same error, naming the key.
            let text = format!("{key}: {}", e.value(py));
            if e.is_instance_of::<PyTypeError>(py) {
                PyTypeError::new_err(text)
            } else {
                PyValueError::new_err(text)
            }
        })?;
        guard(|| {
            let mut me = slf.borrow_mut();
            let mut overrides = me.overrides.clone();
            overrides.push((key.clone(), v));
            let sc =
                parse_all(&me.file, &me.text, &overrides).map_err(|e| scenario_error(py, &e))?;
            me.overrides = overrides;
            *me.parsed.lock().unwrap_or_else(PoisonError::into_inner) =
                (sc, crate::controllers::generation());
            Ok(())
        })?;
        Ok(slf)
    }

    /// Pickles as its file name, text and overrides (so that a scenario reaches a `spawn`
    /// process pool, and `copy.copy` and `copy.deepcopy` work); it is checked again where it is
    /// unpickled, with the controllers registered there.
    #[allow(clippy::type_complexity)]
    fn __reduce__<'py>(
        &self,
        py: Python<'py>,
    ) -> PyResult<(Bound<'py, PyAny>, (String, String, Vec<(String, String)>))> {
        let rebuild = py
            .import("formica._formica")?
            .getattr("_scenario_from_parts")?;
        let overrides = self
            .overrides
            .iter()
            .map(|(k, v)| (k.clone(), v.to_string()))
            .collect();
        Ok((rebuild, (self.file.clone(), self.text.clone(), overrides)))
    }

    /// An independent copy (later `set` calls on either do not affect the other).
    fn copy(&self) -> Self {
        PyScenario {
            file: self.file.clone(),
            text: self.text.clone(),
            overrides: self.overrides.clone(),
            parsed: Mutex::new(
                self.parsed
                    .lock()
                    .unwrap_or_else(PoisonError::into_inner)
                    .clone(),
            ),
        }
    }

    /// Name for results (the file's `name`, else its stem).
    #[getter]
    fn name(&self) -> String {
        self.current().name
    }

    /// File name, as given.
    #[getter]
    fn file(&self) -> String {
        self.file.clone()
    }

    /// The file's text as loaded.
    #[getter]
    fn text(&self) -> String {
        self.text.clone()
    }

    /// The scenario's TOML with the overrides applied.
    #[getter]
    fn effective_text(&self) -> String {
        self.current().text().to_string()
    }

    /// The overrides set so far, as `(key, value)` pairs.
    #[getter]
    fn overrides(&self, py: Python<'_>) -> PyResult<Vec<(String, Py<PyAny>)>> {
        self.overrides
            .iter()
            .map(|(k, v)| Ok((k.clone(), crate::controllers::toml_to_py(py, v)?)))
            .collect()
    }

    /// Total number of robots.
    #[getter]
    fn robots(&self) -> usize {
        self.current().robot_count()
    }

    /// Each robot group's controller name.
    #[getter]
    fn controllers(&self) -> Vec<String> {
        self.current()
            .spec
            .robots
            .iter()
            .map(|g| g.get_ref().controller.get_ref().clone())
            .collect()
    }

    /// Simulated time limit (s).
    #[getter]
    fn duration_s(&self) -> f32 {
        self.current().spec.run.duration_s
    }

    /// Control ticks per second.
    #[getter]
    fn tick_hz(&self) -> f32 {
        self.current().spec.run.tick_hz
    }

    /// The file's default seed.
    #[getter]
    fn seed(&self) -> u64 {
        self.current().spec.run.seed
    }

    fn __repr__(&self) -> String {
        let sc = self.current();
        let set = if self.overrides.is_empty() {
            String::new()
        } else {
            format!(", {} override(s)", self.overrides.len())
        };
        format!(
            "Scenario({:?} from {}, {} robots{set})",
            sc.name,
            self.file,
            sc.robot_count()
        )
    }
}

/// Reads and checks a scenario file; raises `ScenarioError` with `file:line:column`.
#[pyfunction]
pub fn load(py: Python<'_>, path: PathBuf) -> PyResult<PyScenario> {
    guard(|| {
        load_file(&path).map_err(|e| match formica_cli::not_a_scenario_hint(&path) {
            // A sweep file or a store handed to `load`: say what it is, as the command does.
            Some(hint) => crate::input_error(
                py,
                &format!(
                    "{hint} (from Python: formica.sweep(path) for a sweep file, \
                     formica.read_store(path) for a store)"
                ),
            ),
            None => scenario_error(py, &e),
        })
    })
}

/// Checks scenario text (`file` names it in errors).
#[pyfunction]
#[pyo3(signature = (text, file = "<string>".to_string()))]
pub fn parse(py: Python<'_>, text: String, file: String) -> PyResult<PyScenario> {
    guard(|| PyScenario::make(file, text, Vec::new()).map_err(|e| scenario_error(py, &e)))
}

/// A pickled [`PyScenario`] again: its file name, text and overrides (each value as TOML).
#[pyfunction]
pub fn _scenario_from_parts(
    py: Python<'_>,
    file: String,
    text: String,
    overrides: Vec<(String, String)>,
) -> PyResult<PyScenario> {
    let overrides = overrides
        .into_iter()
        .map(|(k, v)| {
            let mut t: toml::Table = toml::from_str(&format!("v = {v}"))
                .map_err(|e| PyValueError::new_err(format!("{k}: not a TOML value: {e}")))?;
            let v = t
                .remove("v")
                .ok_or_else(|| PyValueError::new_err(format!("{k}: not a TOML value")))?;
            Ok((k, v))
        })
        .collect::<PyResult<Vec<_>>>()?;
    guard(|| PyScenario::make(file, text, overrides).map_err(|e| scenario_error(py, &e)))
}

/// The random-walk benchmark world of `formica bench`'s earlier figures (before its
/// `transport` workload): `robots` Khepera IVs running `controller` in an arena scaled to
/// about 0.8 m^2 per robot.
#[pyfunction]
#[pyo3(signature = (robots, controller = "random-walk".to_string()))]
pub fn bench_scenario(py: Python<'_>, robots: usize, controller: String) -> PyResult<PyScenario> {
    if robots == 0 {
        return Err(PyValueError::new_err("robots: expected a positive number"));
    }
    guard(|| {
        let sc =
            formica::bench::scenario(robots, &controller).map_err(|e| scenario_error(py, &e))?;
        PyScenario::make(sc.file.clone(), sc.text().to_string(), Vec::new())
            .map_err(|e| scenario_error(py, &e))
    })
}

/// Scenario files compiled into the package, so that the environments' default scenario
/// works outside a clone of the repository.
const SHIPPED: &[(&str, &str)] = &[(
    "scenarios/seed-transport.toml",
    include_str!("../../scenarios/seed-transport.toml"),
)];

/// The shipped copy of the scenario file `path` (one of the repository's, as named from its
/// root), or None.
#[pyfunction]
pub fn shipped_scenario(py: Python<'_>, path: &str) -> PyResult<Option<PyScenario>> {
    guard(|| {
        SHIPPED
            .iter()
            .find(|(name, _)| *name == path)
            .map(|(name, text)| {
                PyScenario::make(name.to_string(), text.to_string(), Vec::new())
                    .map_err(|e| scenario_error(py, &e))
            })
            .transpose()
    })
}
