//! `formica serve SCENARIO`: a live web viewer of one run on 127.0.0.1; with
//! `--db STUDY.db --trial N`, of a stored trial, checked against the store as it ends.

use crate::replay::{self, Replayer};
use crate::CliError;
use formica_serve::{ReplayInfo, ServeError, ServeOptions, Server};
use std::net::IpAddr;
use std::path::PathBuf;

/// Arguments of `formica serve`.
#[derive(clap::Args)]
pub struct Args {
    /// Scenario file (TOML).
    #[arg(required_unless_present = "db")]
    pub scenario: Option<PathBuf>,
    /// Show a trial of this result store (with `--trial`) instead of a scenario file.
    #[arg(long, value_name = "STUDY.db", requires = "trial",
          conflicts_with_all = ["scenario", "seed", "duration", "set", "controller"])]
    pub db: Option<PathBuf>,
    /// With `--db`: the trial to show (its number, as `formica report` lists it).
    #[arg(long, requires = "db", value_parser = crate::one_trial)]
    pub trial: Option<usize>,
    /// Port to listen on (0: any free port).
    #[arg(long, default_value_t = formica_serve::DEFAULT_PORT)]
    pub port: u16,
    /// Seed of the first run (default: the file's `run.seed`); the page can restart with others.
    #[arg(long)]
    pub seed: Option<u64>,
    /// Simulated time limit in seconds (default: the file's `run.duration_s`).
    #[arg(long)]
    pub duration: Option<f32>,
    /// Use this controller for every robot group, as `formica run --controller` does.
    #[arg(long)]
    pub controller: Option<String>,
    /// Override any scenario key, as `formica run --set` does (repeatable).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    /// Address to listen on. The default, 127.0.0.1, keeps the viewer on this machine; any
    /// other address (e.g. 0.0.0.0) exposes it to the network, unauthenticated.
    #[arg(long, default_value = "127.0.0.1", value_parser = listen_address)]
    pub host: IpAddr,
    /// Start playing at once instead of paused.
    #[arg(long)]
    pub play: bool,
}

/// `--host`: an address a client can connect to (not a multicast or broadcast one), given as
/// numbers.
fn listen_address(s: &str) -> Result<IpAddr, String> {
    if s.eq_ignore_ascii_case("localhost") {
        return Err("give the address as numbers: 127.0.0.1 (or ::1)".into());
    }
    let ip: IpAddr = s
        .parse()
        .map_err(|_| format!("expected an IP address such as 127.0.0.1 or 0.0.0.0, got `{s}`"))?;
    let broadcast = matches!(ip, IpAddr::V4(v4) if v4.is_broadcast());
    if ip.is_multicast() || broadcast {
        return Err(format!(
            "{ip} is a multicast or broadcast address, which no client can connect to"
        ));
    }
    Ok(ip)
}

/// Runs the command.
pub fn main(a: Args) -> Result<(), CliError> {
    let (sc, seed, replay, what) = match (&a.db, a.trial, &a.scenario) {
        (Some(db), Some(n), _) => {
            let r = Replayer::open(db)?.trial(n)?;
            let label = format!("trial {n} of {}", replay::store_name(db));
            let params = r
                .stored
                .params
                .iter()
                .map(|(k, v)| {
                    let v = v.as_str().map_or_else(|| v.to_string(), str::to_string);
                    (k.clone(), v)
                })
                .collect();
            let info = ReplayInfo {
                label: label.clone(),
                seed: r.seed,
                stored: r.stored.result.clone(),
                columns: r.columns.clone(),
                params,
            };
            (r.scenario, Some(r.seed), Some(info), label)
        }
        (_, _, Some(path)) => (
            crate::cmd_run::load_with_controller(path, &a.set, a.controller.as_deref())?,
            a.seed,
            None,
            path.display().to_string(),
        ),
        _ => {
            return Err(CliError::Input(
                "expected a scenario file, or --db STUDY.db --trial N".into(),
            ))
        }
    };
    crate::check_duration(a.duration)?;
    crate::check_seed(a.seed)?;
    let opts = ServeOptions {
        host: a.host,
        port: a.port,
        seed,
        duration_s: a.duration,
        play: a.play,
        replay,
        ..ServeOptions::default()
    };
    let server = Server::bind(sc, opts).map_err(|e| match e {
        ServeError::Scenario(e) => CliError::from(e),
        ServeError::Io(e) => {
            CliError::Input(format!("cannot listen on {}:{}: {e}", a.host, a.port))
        }
    })?;
    let addr = server.local_addr();
    if !addr.ip().is_loopback() {
        errln!(
            "warning: listening on {addr}, reachable from other machines; the viewer has no authentication"
        );
    }
    let shown = if addr.ip().is_unspecified() {
        format!("127.0.0.1:{}", addr.port())
    } else {
        addr.to_string()
    };
    outln!("serving {what} on http://{shown}/ (Ctrl-C to stop)");
    server
        .run()
        .map_err(|e| CliError::Other(anyhow::Error::new(e).context("serving")))
}
