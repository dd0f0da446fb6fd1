//! `formica record SCENARIO --out run.gif|run.mp4`: render a run headless to an animated GIF or
//! an H.264 MP4 video; with `--db STUDY.db --trial N`, a stored trial, checked against the store.

use crate::replay::Replayer;
use crate::CliError;
use anyhow::Context;
use formica::experiment::{Run, RunOptions};
use formica::Overrides;
use formica_render::{record_gif, record_mp4, RecordOptions};
use std::path::PathBuf;

/// Arguments of `formica record`.
#[derive(clap::Args)]
pub struct Args {
    /// Scenario file (TOML).
    #[arg(required_unless_present = "db")]
    pub scenario: Option<PathBuf>,
    /// Output file: `.gif` (animated GIF) or `.mp4` (H.264 video).
    #[arg(long)]
    pub out: PathBuf,
    /// Record a trial of this result store (with `--trial`) instead of a scenario file.
    #[arg(long, value_name = "STUDY.db", requires = "trial",
          conflicts_with_all = ["scenario", "seed", "duration", "controller", "set"])]
    pub db: Option<PathBuf>,
    /// With `--db`: the trial to record (its number, as `formica report` lists it).
    #[arg(long, requires = "db", value_parser = crate::one_trial)]
    pub trial: Option<usize>,
    /// Seed (default: the file's `run.seed`).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Simulated time limit in seconds (default: the file's `run.duration_s`).
    #[arg(long)]
    pub duration: Option<f32>,
    /// Use this controller for every robot group.
    #[arg(long)]
    pub controller: Option<String>,
    /// Override any scenario key, as `formica run --set` does (repeatable).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    /// Frames per second of the animation.
    #[arg(long, default_value_t = 10)]
    pub fps: u32,
    /// Simulated seconds per second of animation.
    #[arg(long, default_value_t = 10.0)]
    pub speed: f32,
    /// Image width in pixels (the height follows the arena).
    #[arg(long, default_value_t = 640)]
    pub width: u32,
    /// Shade the zone where the object hides the goal light.
    #[arg(long)]
    pub occlusion: bool,
    /// Stop after this many frames even if the run goes on.
    #[arg(long, default_value_t = 3000)]
    pub max_frames: usize,
}

/// Runs the command.
pub fn main(a: Args) -> Result<(), CliError> {
    let ext = a
        .out
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let video = match ext.as_deref() {
        Some("gif") => false,
        Some("mp4") => true,
        _ => {
            return Err(CliError::Input(format!(
                "--out: expected a file name ending in .gif or .mp4, got `{}`",
                a.out.display()
            )))
        }
    };
    if !(1..=50).contains(&a.fps) {
        return Err(CliError::Input(format!(
            "--fps: expected 1 to 50, got {}",
            a.fps
        )));
    }
    if !(a.speed > 0.0 && a.speed.is_finite()) {
        return Err(CliError::Input(format!(
            "--speed: expected a positive number, got {}",
            a.speed
        )));
    }
    if !(64..=4096).contains(&a.width) {
        return Err(CliError::Input(format!(
            "--width: expected 64 to 4096 pixels, got {}",
            a.width
        )));
    }
    if a.max_frames == 0 {
        return Err(CliError::Input("--max-frames: expected at least 1".into()));
    }
    crate::check_duration(a.duration)?;
    crate::check_seed(a.seed)?;
    crate::check_controller(a.controller.as_deref())?;
    let replay = match (&a.db, a.trial) {
        (Some(db), Some(n)) => Some(Replayer::open(db)?.trial(n)?),
        _ => None,
    };
    let (sc, overrides) = match (&replay, &a.scenario) {
        (Some(r), _) => (r.scenario.clone(), r.overrides()),
        (None, Some(path)) => (
            crate::cmd_run::load(path, &a.set)?,
            Overrides {
                seed: a.seed,
                duration_s: a.duration,
                controller: a.controller.clone(),
            },
        ),
        (None, None) => {
            return Err(CliError::Input(
                "expected a scenario file, or --db STUDY.db --trial N".into(),
            ))
        }
    };
    let opts = RunOptions {
        overrides,
        record: false,
        robot_every: 1,
        // One world: large swarms sense and control on every core (same results).
        threads: formica::world::threads_for(sc.robot_count(), crate::available_threads()),
    };
    let mut run = Run::new(&sc, &opts)?;
    let ticks_per_frame = (run.world.tick_hz * f64::from(a.speed) / f64::from(a.fps)).round();
    let rec = RecordOptions {
        width_px: a.width,
        every_ticks: (ticks_per_frame as u64).max(1),
        delay_cs: (100 / a.fps).max(2) as u16,
        hold_cs: 200,
        occlusion: a.occlusion,
        max_frames: a.max_frames,
    };
    if let Some(db) = &a.db {
        crate::refuse_overwriting(&a.out, db, "result store")?;
    }
    if let Some(dir) = a.out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    let file =
        std::fs::File::create(&a.out).with_context(|| format!("creating {}", a.out.display()))?;
    let out = std::io::BufWriter::new(file);
    let (summary, w) = if video {
        record_mp4(&mut run, &rec, a.fps, out)
    } else {
        record_gif(&mut run, &rec, out)
    }
    .map_err(anyhow::Error::msg)
    .with_context(|| format!("writing {}", a.out.display()))?;
    w.into_inner()
        .map_err(|e| anyhow::Error::new(e.into_error()))
        .with_context(|| format!("writing {}", a.out.display()))?;
    let how = summary
        .outcome
        .map_or("cut short by --max-frames".to_string(), |o| {
            o.name().to_string()
        });
    outln!(
        "wrote {}: {} frames, {} after {:.1} s ({} ticks)",
        a.out.display(),
        summary.frames,
        how,
        summary.sim_time_s,
        summary.ticks
    );
    if let Some(r) = &replay {
        if summary.outcome.is_none() {
            outln!(
                "trial {} not checked against the store: --max-frames cut the run short",
                r.trial
            );
            return Ok(());
        }
        let diffs = r.differences(&run.result());
        if !diffs.is_empty() {
            return Err(CliError::Other(anyhow::anyhow!(
                "the replay of trial {} does not end as stored ({}): {}",
                r.trial,
                r.stored_outcome(),
                diffs.join("; ")
            )));
        }
        outln!(
            "trial {} (seed {}) ends as stored: {}{}",
            r.trial,
            r.seed,
            r.stored_outcome(),
            r.not_compared(&run.result())
        );
    }
    Ok(())
}
