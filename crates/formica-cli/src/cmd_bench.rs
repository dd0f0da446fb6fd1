//! `formica bench`: robot-ticks per second on the benchmark workloads
//! ([`formica::bench::Workload`]), with the time in physics, sensing and control and the memory
//! per robot.
//!
//! Each size runs in a child process of its own (the same program, `bench --child`), so that
//! its peak memory is its own. A size runs trials of `--ticks` ticks from the start (robots
//! reach and push the objects) on fresh worlds (seeds 1, 2, ...) until the timed ticks add up
//! to `--min-time` seconds of wall time; world building is not timed.

use crate::CliError;
use anyhow::Context;
use formica::bench::Workload;
use formica::world::{Overrides, World};
use serde::{Deserialize, Serialize};

/// Arguments of `formica bench`.
#[derive(clap::Args)]
pub struct Args {
    /// Workload: `transport` (the seed's transport at its density), `fill-transport` (the
    /// concave objects of `scenarios/fill-transport-*.toml`) or `random-walk` (the older world).
    #[arg(long, default_value = "transport")]
    pub workload: String,
    /// Swarm sizes to measure, comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "20,100,1000,5000,10000")]
    pub robots: Vec<usize>,
    /// Ticks per trial (each trial starts a fresh world).
    #[arg(long, default_value_t = 2000)]
    pub ticks: u64,
    /// Keep running trials until this much wall time is timed (s); 0: one trial.
    #[arg(long, default_value_t = 5.0)]
    pub min_time: f64,
    /// Threads for sensing and control within the world (results do not depend on it).
    #[arg(long, default_value_t = 1)]
    pub threads: usize,
    /// Controller every robot runs instead of the workload's.
    #[arg(long)]
    pub controller: Option<String>,
    /// Print one JSON line per size.
    #[arg(long)]
    pub json: bool,
    /// Measure in this process (memory figures then include earlier sizes).
    #[arg(long)]
    pub in_process: bool,
    /// Internal: one size, as a child process, printing its JSON line.
    #[arg(long, hide = true)]
    pub child: bool,
}

/// One size's figures (the JSON line).
#[derive(Serialize, Deserialize)]
struct Line {
    workload: String,
    robots: usize,
    threads: usize,
    /// Timed ticks, all trials.
    ticks: u64,
    trials: u64,
    robot_ticks_per_s: f64,
    us_per_robot_tick: f64,
    /// Timed wall time (s), and its split.
    wall_s: f64,
    physics_s: f64,
    sense_s: f64,
    control_s: f64,
    /// Mean physics steps per tick.
    substeps_per_tick: f64,
    /// Fraction of objects moved more than 0.1 m by the end of the first trial.
    objects_moved: f64,
    peak_memory_mib: Option<f64>,
    /// Peak memory of the same world without robots while it runs (MiB).
    empty_memory_mib: Option<f64>,
    /// (peak - empty) / robots (KiB).
    memory_per_robot_kib: Option<f64>,
    setup_s: f64,
    /// Digest of every body's pose at the end of the first trial (the same for any thread
    /// count).
    digest: String,
}

/// Peak resident memory of this process (MiB), from /proc (Linux only).
fn peak_memory_mib() -> Option<f64> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = s.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kib: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib / 1024.0)
}

/// Resets the peak to the current resident memory (Linux >= 4.0; ignored elsewhere).
fn reset_peak_memory() {
    let _ = std::fs::write("/proc/self/clear_refs", "5");
}

/// FNV-1a over the bits of every robot's and object's pose.
fn digest(w: &World) -> String {
    let mut h = 0xcbf2_9ce4_8422_2325u64;
    let mut eat = |x: f32| {
        for b in x.to_bits().to_le_bytes() {
            h ^= u64::from(b);
            h = h.wrapping_mul(0x0100_0000_01b3);
        }
    };
    for i in 0..w.robots.len() {
        let p = w.robot_pose(i);
        [p.x, p.y, p.theta].into_iter().for_each(&mut eat);
    }
    for i in 0..w.objects.len() {
        let p = w.object_pose(i);
        [p.x, p.y, p.theta].into_iter().for_each(&mut eat);
    }
    format!("{h:016x}")
}

fn build(workload: Workload, n: usize, seed: u64, a: &Args) -> Result<World, CliError> {
    let sc = workload.scenario(n)?;
    let ov = Overrides {
        seed: Some(seed),
        controller: a.controller.clone(),
        ..Overrides::default()
    };
    let mut w = World::new(&sc, &ov)?;
    w.set_threads(a.threads)
        .map_err(|e| CliError::Other(anyhow::anyhow!(e)))?;
    Ok(w)
}

/// Measures one size in this process.
fn measure(workload: Workload, n: usize, a: &Args) -> Result<Line, CliError> {
    // The same world without robots, for the memory per robot. Peaks are taken from when the
    // world is built (the scenario text and its parse are dropped by then) to the end of its
    // run: what the world holds and allocates while it runs.
    let empty_memory_mib = {
        let mut w = World::new(&workload.empty_scenario(n)?, &Overrides::default())?;
        reset_peak_memory();
        for _ in 0..5 {
            w.step();
        }
        peak_memory_mib()
    };
    let mut peak = None;
    let (mut ticks, mut trials, mut setup_s) = (0u64, 0u64, 0.0);
    let mut timing = formica::world::StepTiming::default();
    let (mut steps, mut moved, mut first_digest) = (0u64, 0.0, String::new());
    loop {
        let t0 = std::time::Instant::now();
        let mut w = build(workload, n, trials + 1, a)?;
        setup_s += t0.elapsed().as_secs_f64();
        if trials == 0 {
            reset_peak_memory();
        }
        let start: Vec<_> = (0..w.objects.len()).map(|i| w.object_center(i)).collect();
        w.measure_time();
        for _ in 0..a.ticks {
            w.step();
            steps += u64::from(w.substeps);
        }
        let t = w.timing.unwrap_or_default();
        timing.physics_s += t.physics_s;
        timing.sense_s += t.sense_s;
        timing.control_s += t.control_s;
        ticks += a.ticks;
        if trials == 0 {
            peak = peak_memory_mib();
            first_digest = digest(&w);
            let far = start
                .iter()
                .enumerate()
                .filter(|&(i, s)| (w.object_center(i) - *s).length() > 0.1)
                .count();
            moved = far as f64 / start.len().max(1) as f64;
        }
        trials += 1;
        let wall = timing.physics_s + timing.sense_s + timing.control_s;
        if wall >= a.min_time {
            break;
        }
    }
    let wall_s = timing.physics_s + timing.sense_s + timing.control_s;
    let rts = (n as f64 * ticks as f64) / wall_s.max(1e-12);
    Ok(Line {
        workload: workload.name().into(),
        robots: n,
        threads: a.threads.max(1),
        ticks,
        trials,
        robot_ticks_per_s: rts,
        us_per_robot_tick: 1e6 / rts,
        wall_s,
        physics_s: timing.physics_s,
        sense_s: timing.sense_s,
        control_s: timing.control_s,
        substeps_per_tick: steps as f64 / ticks.max(1) as f64,
        objects_moved: moved,
        peak_memory_mib: peak,
        empty_memory_mib,
        memory_per_robot_kib: peak
            .zip(empty_memory_mib)
            .map(|(p, e)| (p - e).max(0.0) * 1024.0 / n as f64),
        setup_s,
        digest: first_digest,
    })
}

/// Measures one size in a child process (a fresh heap, so its own peak memory).
fn measure_child(workload: Workload, n: usize, a: &Args) -> Result<Line, CliError> {
    let exe = std::env::current_exe().context("finding this program")?;
    let mut cmd = std::process::Command::new(exe);
    cmd.args(["bench", "--child", "--workload", workload.name()])
        .args(["--robots", &n.to_string(), "--ticks", &a.ticks.to_string()])
        .args(["--min-time", &a.min_time.to_string()])
        .args(["--threads", &a.threads.to_string()]);
    if let Some(c) = &a.controller {
        cmd.args(["--controller", c]);
    }
    let out = cmd
        .stderr(std::process::Stdio::inherit())
        .output()
        .context("running the benchmark's child process")?;
    if !out.status.success() {
        return Err(CliError::Other(anyhow::anyhow!(
            "the benchmark of {n} robots failed ({})",
            out.status
        )));
    }
    let text = String::from_utf8_lossy(&out.stdout);
    let line = text.lines().last().unwrap_or_default();
    serde_json::from_str(line)
        .with_context(|| format!("reading the child's line `{line}`"))
        .map_err(CliError::from)
}

/// Most threads of one benchmark world.
const MAX_THREADS: usize = 256;

/// Runs the command.
pub fn main(a: Args) -> Result<(), CliError> {
    let workload = Workload::from_name(&a.workload).ok_or_else(|| {
        let names: Vec<&str> = Workload::ALL.iter().map(|w| w.name()).collect();
        CliError::Input(format!(
            "--workload: expected one of {}, got `{}`",
            names.join(", "),
            a.workload
        ))
    })?;
    if a.robots.is_empty() || a.robots.contains(&0) {
        return Err(CliError::Input(
            "--robots: expected positive counts, e.g. 20,100,1000".into(),
        ));
    }
    let max = workload.max_robots();
    if let Some(n) = a.robots.iter().find(|&&n| n > max) {
        return Err(CliError::Input(format!(
            "--robots: the {} workload holds at most {max} robots (a scenario's limits: {} \
             robots, {} objects), got {n}",
            workload.name(),
            formica::limits::MAX_ROBOTS,
            formica::limits::MAX_ITEMS
        )));
    }
    if !(1..=MAX_THREADS).contains(&a.threads) {
        return Err(CliError::Input(format!(
            "--threads: expected 1 to {MAX_THREADS}, got {}",
            a.threads
        )));
    }
    if a.ticks == 0 {
        return Err(CliError::Input(
            "--ticks: expected a positive number of ticks".into(),
        ));
    }
    if !(a.min_time >= 0.0 && a.min_time.is_finite()) {
        return Err(CliError::Input(
            "--min-time: expected a number of seconds, 0 or more".into(),
        ));
    }
    crate::check_controller(a.controller.as_deref())?;
    for &n in &a.robots {
        let line = if a.child || a.in_process {
            measure(workload, n, &a)?
        } else {
            measure_child(workload, n, &a)?
        };
        if a.json || a.child {
            outln!("{}", serde_json::to_string(&line).context("encoding JSON")?);
        } else {
            let pct = |x: f64| 100.0 * x / line.wall_s.max(1e-12);
            outln!(
                "{} N = {:>6}, {} thread{}: {:>10.0} robot-ticks/s ({:.3} us per robot-tick; physics {:.0} %, sensing {:.0} %, control {:.0} %; {} ticks in {} trials, {:.2} physics steps per tick, {:.0} % of objects moved), {} KiB per robot, digest {}",
                line.workload,
                n,
                line.threads,
                if line.threads == 1 { "" } else { "s" },
                line.robot_ticks_per_s,
                line.us_per_robot_tick,
                pct(line.physics_s),
                pct(line.sense_s),
                pct(line.control_s),
                line.ticks,
                line.trials,
                line.substeps_per_tick,
                100.0 * line.objects_moved,
                line.memory_per_robot_kib
                    .map_or("?".into(), |m| format!("{m:.2}")),
                line.digest
            );
        }
    }
    Ok(())
}
