//! The `formica` command as a library: every subcommand (run, check, sweep, report, serve,
//! record, bench, export, merge, slurm) over the controllers, loop functions and robot models of
//! a [`Registry`]. The `formica` binary is
//! `fn main() -> ExitCode { formica_cli::main_with(Registry::builtin()) }`; a program that adds
//! its own controller to the registry first gets the same command with that controller in it:
//!
//! ```no_run
//! use formica::Registry;
//! use std::process::ExitCode;
//!
//! fn main() -> Result<ExitCode, formica::RegistryError> {
//!     let mut registry = Registry::builtin();
//!     // A copy of `constant` under another name; a real program registers its own builder.
//!     registry.controller("my-constant", formica::controllers::constant::factory)?;
//!     Ok(formica_cli::main_with(registry))
//! }
//! ```

use clap::{Parser, Subcommand};
use formica::Registry;
use std::ffi::OsString;
use std::path::Path;
use std::process::ExitCode;
use std::sync::Mutex;

#[macro_use]
mod console;

mod cmd_bench;
mod cmd_check;
mod cmd_export;
mod cmd_merge;
mod cmd_record;
mod cmd_report;
mod cmd_run;
mod cmd_serve;
mod cmd_slurm;
mod cmd_sweep;
mod gallery;
mod output;
mod plots;
pub mod provenance;
mod replay;
pub mod schema;
mod stats;
mod store;
mod sweep;

/// Formica: a simulator and behaviour suite for cooperative transport by robot swarms.
#[derive(Parser)]
#[command(name = "formica", version = provenance::LONG_VERSION, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Run a scenario headless (one seed, or a range of seeds in parallel).
    #[command(override_usage = "formica run [OPTIONS] <SCENARIO>\n       \
                                formica run --db <STUDY.db> --trial <N|A..B|all>")]
    Run(cmd_run::Args),
    /// Validate a scenario file and describe what it sets up.
    Check(cmd_check::Args),
    /// Measure robot-ticks per second on the standard scaled transport world.
    Bench(cmd_bench::Args),
    /// Run a parameter sweep into a SQLite result store (resumable).
    Sweep(cmd_sweep::Args),
    /// Export a result store to CSV.
    Export(cmd_export::Args),
    /// Plots and a Markdown summary from a result store.
    Report(cmd_report::Args),
    /// Merge shard result stores into one.
    Merge(cmd_merge::Args),
    /// Write (and optionally submit) a Slurm job-array script for a sweep.
    Slurm(cmd_slurm::Args),
    /// Serve a live viewer of a scenario on 127.0.0.1.
    #[command(override_usage = "formica serve [OPTIONS] <SCENARIO>\n       \
                                formica serve --db <STUDY.db> --trial <N> [OPTIONS]")]
    Serve(cmd_serve::Args),
    /// Render a run to an animated GIF or an MP4 video.
    #[command(
        override_usage = "formica record [OPTIONS] --out <OUT> <SCENARIO>\n       \
                                formica record --db <STUDY.db> --trial <N> --out <OUT> [OPTIONS]"
    )]
    Record(cmd_record::Args),
    /// Print the JSON Schema of scenario or sweep files (for editors), or the scenario reference.
    Schema(schema::Args),
}

/// Parses the command line, as `Cli::try_parse_from` does, with every subcommand taking
/// negative numbers as values: `--duration -1` gets the option's own message, not clap's
/// "unexpected argument '-1'" (whatever subcommands there are, added later ones too).
fn parse<I, T>(args: I) -> Result<Cli, clap::Error>
where
    I: IntoIterator<Item = T>,
    T: Into<OsString> + Clone,
{
    use clap::{CommandFactory, FromArgMatches};
    let mut cmd = Cli::command().mut_subcommands(|c| c.allow_negative_numbers(true));
    let mut matches = cmd.try_get_matches_from_mut(args)?;
    Cli::from_arg_matches_mut(&mut matches).map_err(|e| e.format(&mut cmd))
}

/// An error with the exit code it deserves: 2 for bad input, 1 otherwise.
#[derive(Debug)]
pub(crate) enum CliError {
    /// The user's input (scenario file, arguments) is wrong.
    Input(String),
    /// Something else failed (I/O, ...).
    Other(anyhow::Error),
    /// Stopped by [`request_stop`] (exit code 130, as a shell gives for Ctrl-C).
    Interrupted(String),
}

static STOP: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Asks a running [`try_main_from`] to stop early: a sweep starts no new trial, lets those
/// running finish and be stored, and returns an error of code 130 (resume it by running it
/// again). For embedders that handle Ctrl-C themselves (the Python package: a notebook's
/// interrupt); the command line is simply killed by Ctrl-C, which keeps every stored trial too.
pub fn request_stop() {
    STOP.store(true, std::sync::atomic::Ordering::Relaxed);
}

/// Whether [`request_stop`] was called since the command began.
pub(crate) fn stop_requested() -> bool {
    STOP.load(std::sync::atomic::Ordering::Relaxed)
}

/// `--duration`: more than 0 and at most [`formica::limits::MAX_DURATION_S`].
pub(crate) fn check_duration(d: Option<f32>) -> Result<(), CliError> {
    let max = formica::limits::MAX_DURATION_S;
    match d {
        Some(d) if !(d > 0.0 && d <= max) => Err(CliError::Input(format!(
            "--duration: expected more than 0 and at most {} seconds, got {d}",
            formica::limits::show(max)
        ))),
        _ => Ok(()),
    }
}

/// An error if writing `out` would overwrite `input` (the same file, through any path or
/// link, or its SQLite companions `-wal`, `-shm`, `-journal`), which the command reads as
/// `what`.
pub(crate) fn refuse_overwriting(
    out: &std::path::Path,
    input: &std::path::Path,
    what: &str,
) -> Result<(), CliError> {
    let (Some(out_c), Ok(in_c)) = (resolve_path(out), input.canonicalize()) else {
        return Ok(());
    };
    let same = out_c == in_c
        || same_inode(out, input)
        || ["-wal", "-shm", "-journal"].iter().any(|suffix| {
            let mut companion = in_c.clone().into_os_string();
            companion.push(suffix);
            out_c == std::path::Path::new(&companion)
        });
    if same {
        return Err(CliError::Input(format!(
            "{}: this is the {what} the command reads ({}); writing it would destroy it, so \
             give another output file",
            out.display(),
            input.display()
        )));
    }
    Ok(())
}

/// `p` made absolute with links resolved; a file that does not exist yet (an output, an SQLite
/// companion that comes and goes) by its folder's resolved path.
pub(crate) fn resolve_path(p: &std::path::Path) -> Option<std::path::PathBuf> {
    p.canonicalize().ok().or_else(|| {
        let dir = match p.parent() {
            Some(d) if !d.as_os_str().is_empty() => d,
            _ => std::path::Path::new("."),
        };
        Some(dir.canonicalize().ok()?.join(p.file_name()?))
    })
}

/// Whether two existing paths are one file through a hard link (Unix; elsewhere false).
fn same_inode(a: &std::path::Path, b: &std::path::Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        if let (Ok(x), Ok(y)) = (std::fs::metadata(a), std::fs::metadata(b)) {
            return x.dev() == y.dev() && x.ino() == y.ino();
        }
    }
    let _ = (a, b);
    false
}

/// What a file given to a command looks like, for an error that says what was given and
/// which command takes it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum FileKind {
    /// A TOML file with an `arena` table and no `scenario` key.
    Scenario,
    /// A TOML file with `scenario`, `seeds`, `vary` or `cases` and no `arena`.
    Sweep,
    /// An SQLite file (a result store, or another program's).
    Sqlite,
}

/// The kind of file at `path`, if it is one of [`FileKind`]'s (read only up to the size a
/// scenario file may have, [`formica::limits::MAX_FILE_BYTES`]).
pub(crate) fn file_kind(path: &std::path::Path) -> Option<FileKind> {
    use std::io::Read;
    let mut head = [0u8; 16];
    let mut f = std::fs::File::open(path).ok()?;
    if f.read_exact(&mut head).is_ok() && &head == b"SQLite format 3\0" {
        return Some(FileKind::Sqlite);
    }
    let text = formica::limits::read_text(path).ok()?;
    // Too large to parse safely: the caller's own parse reports it, with its line.
    if formica::limits::too_large(&text).is_some() {
        return None;
    }
    let table: toml::Table = toml::from_str(&text).ok()?;
    let arena = table.contains_key("arena");
    let sweep = ["scenario", "seeds", "vary", "cases"]
        .iter()
        .any(|k| table.contains_key(*k));
    match (arena, sweep) {
        (true, false) => Some(FileKind::Scenario),
        (false, true) => Some(FileKind::Sweep),
        _ => None,
    }
}

/// For an error loading `path` as a scenario: what the file is instead, and the command that
/// takes it (`None` if it is not a sweep file or a store). Public for the Python package's
/// `formica.load`.
pub fn not_a_scenario_hint(path: &std::path::Path) -> Option<String> {
    let file = path.display();
    match file_kind(path)? {
        FileKind::Sweep => Some(format!(
            "{file}: a sweep file (it sets seeds, vary or cases), not a scenario; run it with \
             `formica sweep {file}` (check it with `--dry-run`)"
        )),
        FileKind::Sqlite => Some(format!(
            "{file}: an SQLite file (a result store?), not a scenario; replay a trial of a store \
             with `formica run --db {file} --trial N`"
        )),
        FileKind::Scenario => None,
    }
}

/// `--trial N` of `serve` and `record`: one trial; a range or `all` is pointed to `run`.
pub(crate) fn one_trial(s: &str) -> Result<usize, String> {
    if s.contains("..") || s.eq_ignore_ascii_case("all") {
        return Err(format!(
            "this command shows one trial (`formica run --db STUDY.db --trial {s}` checks many)"
        ));
    }
    s.parse()
        .map_err(|_| format!("expected a trial number (0, 1, ...), got `{s}`"))
}

/// Most worker threads `run` and `sweep` start (and the Python package's `run`).
pub const MAX_THREADS: usize = 1024;

/// `--threads`: 1 to [`MAX_THREADS`].
pub(crate) fn check_threads(t: Option<usize>) -> Result<(), CliError> {
    match t {
        Some(t) if !(1..=MAX_THREADS).contains(&t) => Err(CliError::Input(format!(
            "--threads: expected 1 to {MAX_THREADS}, got {t} (leave it out to use every core)"
        ))),
        _ => Ok(()),
    }
}

/// `--seed`: at most [`formica::limits::MAX_SEED`] (seeds are stored as 64-bit signed
/// integers, as TOML writes them).
pub(crate) fn check_seed(s: Option<u64>) -> Result<(), CliError> {
    let max = formica::limits::MAX_SEED;
    match s {
        Some(s) if s > max => Err(CliError::Input(format!(
            "--seed: expected 0 to {max}, got {s}"
        ))),
        _ => Ok(()),
    }
}

impl std::fmt::Display for CliError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            CliError::Input(m) | CliError::Interrupted(m) => f.write_str(m),
            CliError::Other(e) => write!(f, "{e:#}"),
        }
    }
}

impl From<formica::ScenarioError> for CliError {
    fn from(e: formica::ScenarioError) -> Self {
        CliError::Input(e.to_string())
    }
}

impl From<anyhow::Error> for CliError {
    fn from(e: anyhow::Error) -> Self {
        CliError::Other(e)
    }
}

/// Checks a `--controller` option against the process-wide registry.
pub(crate) fn check_controller(name: Option<&str>) -> Result<(), CliError> {
    match name {
        Some(c) => {
            let registry = Registry::global();
            if registry.has_controller(c) {
                Ok(())
            } else {
                Err(CliError::Input(format!(
                    "--controller: {}",
                    registry.unknown_controller(c)
                )))
            }
        }
        None => Ok(()),
    }
}

/// The name of the program running (`formica`, or that of a program built on [`main_with`]).
static PROGRAM: Mutex<String> = Mutex::new(String::new());

/// Records the program's name from `args[0]`: its file name without the extension.
fn set_program(arg0: Option<&OsString>) {
    let name = arg0
        .and_then(|a| Path::new(a).file_stem())
        .map(|s| s.to_string_lossy().into_owned())
        .filter(|s| !s.is_empty())
        .unwrap_or_default();
    if let Ok(mut p) = PROGRAM.lock() {
        *p = name;
    }
}

/// How reports and messages name the command in the commands they show (`formica serve --db
/// ...`): the program's own name, so that a program built on [`main_with`] shows commands that
/// know its controllers; `formica` if unknown.
pub(crate) fn program() -> String {
    PROGRAM
        .lock()
        .ok()
        .map(|p| p.clone())
        .filter(|p| !p.is_empty())
        .unwrap_or_else(|| "formica".into())
}

/// Runs the `formica` command line of this process (`std::env::args`) with `registry` as the
/// process-wide registry ([`Registry::install`]): scenario files, sweeps, `--controller` and
/// `--set` resolve controller and model names in it, and every run gets its loop functions.
/// Returns the exit code: 0 on success, 2 for bad input (a scenario error names
/// `file:line:column`) or bad arguments, 1 for other failures.
pub fn main_with(registry: Registry) -> ExitCode {
    main_from(registry, std::env::args_os())
}

/// [`main_with`] for the given command line (`args[0]` is the program name).
///
/// ```
/// use formica::Registry;
/// use std::process::ExitCode;
///
/// let scenario = concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenarios/seed-transport.toml");
/// let code = formica_cli::main_from(Registry::builtin(), ["formica", "check", scenario]);
/// assert_eq!(code, ExitCode::SUCCESS);
/// let code = formica_cli::main_from(Registry::builtin(), ["formica", "check", "missing.toml"]);
/// assert_eq!(code, ExitCode::from(2));
/// ```
pub fn main_from<I, T>(registry: Registry, args: I) -> ExitCode
where
    I: IntoIterator<Item = T>,
    T: Into<OsString> + Clone,
{
    registry.install();
    let args: Vec<OsString> = args.into_iter().map(Into::into).collect();
    set_program(args.first());
    let cli = match parse(args) {
        Ok(cli) => cli,
        Err(e) => {
            // Help and version go to stdout with code 0, usage errors to stderr with code 2.
            let _ = e.print();
            return ExitCode::from(u8::try_from(e.exit_code()).unwrap_or(2));
        }
    };
    match dispatch(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            errln!("error: {e}");
            ExitCode::from(e.code)
        }
    }
}

/// A subcommand that failed: what [`main_from`] would print after `error: `, and its exit code.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CommandError {
    /// 2 for bad input (a scenario error names `file:line:column`) or bad arguments (also: 0
    /// for `--help` and `--version`, whose text is the message), 1 for other failures.
    pub code: u8,
    /// What went wrong.
    pub message: String,
}

impl std::fmt::Display for CommandError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::error::Error for CommandError {}

/// [`main_from`] for programs that report failures themselves (the Python package's
/// `formica.sweep`): the same subcommands, with the error returned instead of printed.
///
/// ```
/// use formica::Registry;
///
/// let err = formica_cli::try_main_from(Registry::builtin(), ["formica", "check", "missing.toml"])
///     .unwrap_err();
/// assert_eq!(err.code, 2);
/// assert!(err.message.starts_with("missing.toml: cannot read"), "{err}");
/// ```
pub fn try_main_from<I, T>(registry: Registry, args: I) -> Result<(), CommandError>
where
    I: IntoIterator<Item = T>,
    T: Into<OsString> + Clone,
{
    registry.install();
    STOP.store(false, std::sync::atomic::Ordering::Relaxed);
    let cli = parse(args).map_err(|e| CommandError {
        code: u8::try_from(e.exit_code()).unwrap_or(2),
        message: e.render().to_string(),
    })?;
    dispatch(cli)
}

fn dispatch(cli: Cli) -> Result<(), CommandError> {
    console::reset();
    let r = match cli.command {
        Command::Run(a) => cmd_run::main(a),
        Command::Check(a) => cmd_check::main(a),
        Command::Bench(a) => cmd_bench::main(a),
        Command::Sweep(a) => cmd_sweep::main(a),
        Command::Export(a) => cmd_export::main(a),
        Command::Report(a) => cmd_report::main(a),
        Command::Merge(a) => cmd_merge::main(a),
        Command::Slurm(a) => cmd_slurm::main(a),
        Command::Serve(a) => cmd_serve::main(a),
        Command::Record(a) => cmd_record::main(a),
        Command::Schema(a) => schema::main(a),
    };
    r.map_err(|e| match e {
        CliError::Input(message) => CommandError { code: 2, message },
        CliError::Other(e) => CommandError {
            code: 1,
            message: format!("{e:#}"),
        },
        CliError::Interrupted(message) => CommandError { code: 130, message },
    })?;
    // Output lost to a failed stdout (not a reader that went away) is a failure, even when the
    // command's own work succeeded.
    match console::failure() {
        Some(e) => Err(CommandError {
            code: 1,
            message: format!("writing to stdout: {e}; the output is incomplete"),
        }),
        None => Ok(()),
    }
}

/// How many trials run inside [`caught`] now, on any thread: while one does, a panic with a
/// message is reported by it, not printed by the hook (a trial's world may step on threads of
/// its own pool, whose panic comes back to the trial's thread).
static IN_TRIALS: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);

/// Where the last panic reported by [`caught`] happened, and its message, on any thread.
static LAST_PANIC: Mutex<Option<String>> = Mutex::new(None);

/// Runs one trial's work, turning a panic in it (a bug in a controller, such as a NaN wheel
/// speed, or in Formica) into an error that says where and why: a run of many seeds, or a
/// sweep, reports it once, as an error line with the trial, instead of a panic message from
/// every worker thread, and a sweep keeps running its other trials. A panic that carries
/// something else than a message (an embedder's, such as the Python package's controller
/// exceptions) is printed and unwinds on as before.
pub(crate) fn caught<T, E: Into<CliError>>(
    f: impl FnOnce() -> Result<T, E>,
) -> Result<T, CliError> {
    use std::sync::atomic::Ordering;
    static HOOK: std::sync::Once = std::sync::Once::new();
    HOOK.call_once(|| {
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            let message = info.payload().is::<String>() || info.payload().is::<&str>();
            if message && IN_TRIALS.load(Ordering::SeqCst) > 0 {
                let at = info
                    .location()
                    .map(|l| format!(" at {}:{}", l.file(), l.line()))
                    .unwrap_or_default();
                if let Ok(mut last) = LAST_PANIC.lock() {
                    *last = Some(at);
                }
            } else {
                previous(info);
            }
        }));
    });
    IN_TRIALS.fetch_add(1, Ordering::SeqCst);
    let out = std::panic::catch_unwind(std::panic::AssertUnwindSafe(f));
    IN_TRIALS.fetch_sub(1, Ordering::SeqCst);
    out.map(|r| r.map_err(Into::into))
        .unwrap_or_else(|payload| {
            let Some(message) = formica::world::panic_message(payload.as_ref()) else {
                std::panic::resume_unwind(payload)
            };
            // The place of this panic, or of one beside it on another trial's thread (two trials
            // that panic at once may swap places; the messages are their own).
            let at = LAST_PANIC
                .lock()
                .ok()
                .and_then(|mut last| last.take())
                .unwrap_or_default();
            Err(CliError::Other(anyhow::anyhow!(
                "stopped by a panic{at}: {message} (a bug in a controller, or in Formica: please \
             report it with the scenario and seed)"
            )))
        })
}

/// Cores this process may use (1 when unknown).
pub(crate) fn available_threads() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_panic_in_a_trial_becomes_an_error_that_says_where_and_why() {
        let err = caught(|| -> Result<(), CliError> {
            panic!("controller `x` gave robot 0 the wheel speeds (NaN, 0.1)")
        })
        .expect_err("the panic was not caught");
        let text = err.to_string();
        assert!(
            text.starts_with("stopped by a panic at crates/formica-cli/src/lib.rs:")
                && text.contains("controller `x` gave robot 0 the wheel speeds (NaN, 0.1)")
                && text.contains("a bug in a controller, or in Formica"),
            "{text}"
        );
        assert!(matches!(err, CliError::Other(_)));
        // Values pass through.
        assert_eq!(caught(|| Ok::<_, CliError>(7)).ok(), Some(7));
        // Another payload (an embedder's) unwinds on, untouched.
        struct Carried(u8);
        let payload = std::panic::catch_unwind(|| {
            caught(|| -> Result<(), CliError> { std::panic::panic_any(Carried(3)) })
        })
        .expect_err("an embedder's panic was swallowed");
        assert_eq!(payload.downcast_ref::<Carried>().map(|c| c.0), Some(3));
    }
}
