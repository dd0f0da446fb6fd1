//! `formica slurm SWEEP.toml --array N`: write (and optionally submit) a Slurm job-array script
//! whose tasks run the shards of a sweep, one result store each.

use crate::sweep::Sweep;
use crate::CliError;
use anyhow::Context;
use std::path::{Path, PathBuf};

/// Arguments of `formica slurm`.
#[derive(clap::Args)]
pub struct Args {
    /// Sweep file (TOML).
    pub sweep: PathBuf,
    /// Number of array tasks (shards).
    #[arg(long)]
    pub array: usize,
    /// Folder of the shard stores `shard-K.db` (default: `<sweep stem>-shards` next to the
    /// sweep file).
    #[arg(long)]
    pub db_dir: Option<PathBuf>,
    /// Script to write (default: `<sweep stem>.slurm` next to the sweep file).
    #[arg(long)]
    pub script: Option<PathBuf>,
    /// CPUs per task (`#SBATCH --cpus-per-task`; the sweep uses them all).
    #[arg(long, default_value_t = 1)]
    pub cpus: usize,
    /// Time limit per task (`#SBATCH --time`).
    #[arg(long, default_value = "04:00:00")]
    pub time: String,
    /// Extra `#SBATCH` lines, e.g. `--sbatch "--partition=short"` (repeatable).
    #[arg(long, allow_hyphen_values = true)]
    pub sbatch: Vec<String>,
    /// Also submit the script with `sbatch` (prints the job id).
    #[arg(long)]
    pub submit: bool,
}

/// Single-quotes a string for a POSIX shell.
fn sh(s: &str) -> String {
    format!("'{}'", s.replace('\'', "'\\''"))
}

fn absolute(p: &Path) -> Result<PathBuf, CliError> {
    Ok(if p.is_absolute() {
        p.to_path_buf()
    } else {
        std::env::current_dir()
            .context("reading the current folder")?
            .join(p)
    })
}

/// How every script this command writes begins (the job name follows); a file that does not
/// is not overwritten.
const SCRIPT_HEAD: &str = "#!/bin/bash\n#SBATCH --job-name=formica-";

/// Checks `--time` against Slurm's formats: `M`, `M:S`, `H:M:S`, `D-H`, `D-H:M`, `D-H:M:S`,
/// or `UNLIMITED` / `INFINITE`.
fn check_time(t: &str) -> Result<(), CliError> {
    let digits = |x: &str| !x.is_empty() && x.len() <= 9 && x.bytes().all(|b| b.is_ascii_digit());
    let ok = match t {
        "UNLIMITED" | "INFINITE" | "unlimited" | "infinite" => true,
        _ => match t.split_once('-') {
            Some((days, rest)) => {
                let parts: Vec<&str> = rest.split(':').collect();
                digits(days) && parts.len() <= 3 && parts.iter().all(|p| digits(p))
            }
            None => {
                let parts: Vec<&str> = t.split(':').collect();
                parts.len() <= 3 && parts.iter().all(|p| digits(p))
            }
        },
    };
    if ok {
        Ok(())
    } else {
        Err(CliError::Input(format!(
            "--time `{}`: expected a Slurm time limit such as 04:00:00, 90 (minutes) or \
             1-12:00:00",
            t.escape_debug()
        )))
    }
}

/// The job-array script.
pub fn script(exe: &Path, sweep: &Path, db_dir: &Path, name: &str, a: &Args) -> String {
    let n = a.array;
    let mut s = String::new();
    s += SCRIPT_HEAD;
    s += &format!("{name}\n");
    s += &format!("#SBATCH --array=0-{}\n", n - 1);
    s += "#SBATCH --ntasks=1\n";
    s += &format!("#SBATCH --cpus-per-task={}\n", a.cpus);
    s += &format!("#SBATCH --time={}\n", a.time);
    // sbatch reads `#SBATCH` lines as it reads its command line: a path with spaces is quoted.
    s += &format!(
        "#SBATCH --output=\"{}/slurm-%A_%a.out\"\n",
        db_dir.display()
    );
    for extra in &a.sbatch {
        s += &format!("#SBATCH {extra}\n");
    }
    s += &format!(
        "# Written by `formica slurm`: task K runs shard K/{n} of the sweep into its own store.\n\
         # Merge them afterwards: formica merge ALL.db {}/shard-*.db\n",
        sh(&db_dir.display().to_string())
    );
    s += "set -euo pipefail\n";
    s += &format!("mkdir -p {}\n", sh(&db_dir.display().to_string()));
    s += &format!(
        "exec {} sweep {} --shard \"$SLURM_ARRAY_TASK_ID/{n}\" --threads \"${{SLURM_CPUS_PER_TASK:-1}}\" --quiet --db {}/\"shard-$SLURM_ARRAY_TASK_ID.db\"\n",
        sh(&exe.display().to_string()),
        sh(&sweep.display().to_string()),
        sh(&db_dir.display().to_string()),
    );
    s
}

/// Runs the command.
pub fn main(a: Args) -> Result<(), CliError> {
    if a.array == 0 {
        return Err(CliError::Input("--array: expected at least 1 task".into()));
    }
    if a.cpus == 0 {
        return Err(CliError::Input("--cpus: expected at least 1".into()));
    }
    check_time(&a.time)?;

    if let Some(bad) = a.sbatch.iter().find(|x| x.contains(['\n', '\r'])) {
        return Err(CliError::Input(format!(
            "--sbatch `{}`: one option per --sbatch, without line breaks",
            bad.escape_debug()
        )));
    }
    // Validate the sweep now rather than in every task.
    let sweep = Sweep::load(&a.sweep)?;
    let n_trials = sweep.sets.len() * sweep.seeds.len();
    if a.array > n_trials {
        return Err(CliError::Input(format!(
            "--array {}: more tasks than the sweep has trials ({n_trials}); tasks beyond that \
             would run nothing (use at most {n_trials})",
            a.array
        )));
    }
    let sweep_abs = absolute(&a.sweep)?;
    let stem = a
        .sweep
        .file_stem()
        .map_or_else(|| "sweep".to_string(), |s| s.to_string_lossy().into_owned());
    let dir = sweep_abs.parent().unwrap_or(Path::new("/")).to_path_buf();
    let db_dir = absolute(
        &a.db_dir
            .clone()
            .unwrap_or_else(|| dir.join(format!("{stem}-shards"))),
    )?;
    let shown = db_dir.display().to_string();
    if shown.contains(['"', '\n', '\r']) {
        return Err(CliError::Input(format!(
            "the shards' folder `{}` holds a double quote or a line break, which the script's \
             #SBATCH lines cannot hold: give another with --db-dir",
            shown.escape_debug()
        )));
    }
    let script_path = a
        .script
        .clone()
        .unwrap_or_else(|| dir.join(format!("{stem}.slurm")));
    crate::refuse_overwriting(&script_path, &a.sweep, "sweep file")?;
    let ours = match std::fs::read_to_string(&script_path) {
        Ok(old) => old.starts_with(SCRIPT_HEAD),
        Err(_) => !script_path.exists(),
    };
    if !ours {
        return Err(CliError::Input(format!(
            "{}: exists and is not a script that formica slurm wrote; give another --script \
             or remove it",
            script_path.display()
        )));
    }
    let exe = std::env::current_exe().context("finding the formica executable")?;
    let text = script(&exe, &sweep_abs, &db_dir, &sweep.name, &a);
    std::fs::create_dir_all(&db_dir).with_context(|| format!("creating {}", db_dir.display()))?;
    std::fs::write(&script_path, &text)
        .with_context(|| format!("writing {}", script_path.display()))?;
    outln!(
        "wrote {} ({} tasks over {n_trials} trials, stores in {})",
        script_path.display(),
        a.array,
        db_dir.display()
    );
    if a.submit {
        let out = std::process::Command::new("sbatch")
            .arg("--parsable")
            .arg(&script_path)
            .output()
            .context("running sbatch (is Slurm installed?)")?;
        if !out.status.success() {
            return Err(CliError::Other(anyhow::anyhow!(
                "sbatch failed: {}",
                String::from_utf8_lossy(&out.stderr).trim()
            )));
        }
        let id = String::from_utf8_lossy(&out.stdout).trim().to_string();
        outln!("submitted job {id}");
    }
    Ok(())
}
