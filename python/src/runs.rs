//! Whole runs: `formica.run` (seeds of one scenario, as `formica run --json`) and the
//! `formica` command itself (`formica.sweep` runs its `sweep` subcommand).

use crate::world::{uses_python, Build};
use crate::{guard, input_error, result_to_py, scenario_error, NotBool};
use formica::experiment::Run;
use formica::{Registry, RunResult};
use formica_cli::provenance::Provenance;
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use rayon::prelude::*;

/// Runs one seed on this thread, attached to the interpreter (Python controllers step here),
/// checking for Ctrl-C every few hundred ticks.
fn run_attached(
    py: Python<'_>,
    sc: &formica::Scenario,
    b: &Build,
    seed: u64,
) -> PyResult<RunResult> {
    let mut run = Run::new(sc, &b.options(Some(seed))).map_err(|e| scenario_error(py, &e))?;
    let mut k = 0u32;
    while run.step().is_none() {
        k += 1;
        if k % 256 == 0 {
            py.check_signals()?;
        }
    }
    Ok(run.result())
}

/// Runs `scenario` once per seed and returns the results as dicts, in seed order: the JSON
/// lines of `formica run --json`. `threads`: worker threads (default: every core, or 1 when
/// Python controllers run, which then step on the calling thread).
#[pyfunction]
#[pyo3(signature = (scenario, seeds, threads = None, duration = None, controller = None))]
pub fn run_seeds(
    py: Python<'_>,
    scenario: &Bound<'_, PyAny>,
    seeds: Vec<NotBool<u64>>,
    threads: Option<NotBool<usize>>,
    duration: Option<NotBool<f32>>,
    controller: Option<String>,
) -> PyResult<Vec<Py<PyAny>>> {
    let seeds: Vec<u64> = seeds.into_iter().map(|s| s.0).collect();
    let (threads, duration) = (threads.map(|t| t.0), duration.map(|d| d.0));
    guard(|| {
        let sc = crate::scenario::scenario_of(py, scenario)?;
        let b = Build {
            duration,
            controller,
            record: false,
        };
        b.check(&sc)?;
        let most = formica_cli::MAX_THREADS;
        if let Some(t) = threads.filter(|t| !(1..=most).contains(t)) {
            return Err(PyValueError::new_err(format!(
                "threads: expected 1 to {most}, got {t} (leave it out to use every core)"
            )));
        }
        let max = formica::limits::MAX_RUN_SEEDS;
        if seeds.len() as u64 > max {
            return Err(PyValueError::new_err(format!(
                "seeds: at most {max} seeds a call, got {} (as `formica run --seeds`; \
                 formica.sweep stores each trial as it ends and takes more)",
                seeds.len()
            )));
        }
        let Some(&first) = seeds.first() else {
            return Ok(Vec::new());
        };
        // Check the scenario builds before fanning out, so errors are reported once.
        Run::new(&sc, &b.options(Some(first))).map_err(|e| scenario_error(py, &e))?;
        let python = uses_python(&sc, &b);
        let results: Vec<RunResult> = if python && threads.unwrap_or(1) == 1 {
            seeds
                .iter()
                .map(|&s| run_attached(py, &sc, &b, s))
                .collect::<PyResult<_>>()?
        } else {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads.unwrap_or(0))
                .build()
                .map_err(|e| PyRuntimeError::new_err(format!("starting worker threads: {e}")))?;
            // Seeds in chunks, the GIL released for each, so that Ctrl-C stops the call
            // between chunks.
            let chunk = 2 * pool.current_num_threads();
            let mut out: Vec<Result<RunResult, formica::ScenarioError>> =
                Vec::with_capacity(seeds.len());
            for part in seeds.chunks(chunk) {
                out.extend(py.detach(|| {
                    pool.install(|| {
                        part.par_iter()
                            .map(|&s| formica::run(&sc, &b.options(Some(s))).map(|(r, _)| r))
                            .collect::<Vec<_>>()
                    })
                }));
                py.check_signals()?;
            }
            out.into_iter()
                .collect::<Result<_, _>>()
                .map_err(|e| scenario_error(py, &e))?
        };
        let provenance = Provenance::of(&sc, &b.options(None).overrides);
        results
            .iter()
            .map(|r| result_to_py(py, r, &provenance))
            .collect()
    })
}

/// Runs a `formica` subcommand (`args` as on the command line, without the program name)
/// with the process-wide registry, Python controllers included. Bad input (exit code 2)
/// raises `ScenarioError`, other failures `RuntimeError`.
#[pyfunction]
pub fn command(py: Python<'_>, args: Vec<String>) -> PyResult<()> {
    guard(|| {
        let argv: Vec<String> = std::iter::once("formica".to_string()).chain(args).collect();
        // The command runs on its own thread while this one looks for Ctrl-C (a notebook's
        // interrupt) every 50 ms: a sweep then starts no new trial, stores those running and
        // returns; the interrupt is raised here once it has.
        let mut interrupt: Option<PyErr> = None;
        let joined = py.detach(|| {
            std::thread::scope(|s| {
                let worker = s.spawn(|| formica_cli::try_main_from(Registry::global(), argv));
                while !worker.is_finished() {
                    std::thread::sleep(std::time::Duration::from_millis(50));
                    if interrupt.is_none() {
                        if let Err(e) = Python::attach(|py| py.check_signals()) {
                            formica_cli::request_stop();
                            interrupt = Some(e);
                        }
                    }
                }
                worker.join()
            })
        });
        let r = joined.unwrap_or_else(|payload| std::panic::resume_unwind(payload));
        if let Some(e) = interrupt {
            if let Err(c) = &r {
                eprintln!("{}", c.message);
            }
            return Err(e);
        }
        match r {
            Ok(()) => Ok(()),
            Err(e) if e.code == 0 => Ok(()),
            Err(e) if e.code == 2 => Err(input_error(py, &e.message)),
            Err(e) => Err(PyRuntimeError::new_err(e.message)),
        }
    })
}
