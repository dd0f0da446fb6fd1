//! `formica serve SCENARIO`: a live web viewer of one run on 127.0.0.1.

use crate::CliError;
use formica::Scenario;
use formica_serve::{ServeError, ServeOptions, Server};
use std::net::IpAddr;
use std::path::PathBuf;

/// Arguments of `formica serve`.
#[derive(clap::Args)]
pub struct Args {
    /// Scenario file (TOML).
    pub scenario: PathBuf,
    /// Port to listen on (0: any free port).
    #[arg(long, default_value_t = formica_serve::DEFAULT_PORT)]
    pub port: u16,
    /// Seed of the first run (default: the file's `run.seed`); the page can restart with others.
    #[arg(long)]
    pub seed: Option<u64>,
    /// Simulated time limit in seconds (default: the file's `run.duration_s`).
    #[arg(long)]
    pub duration: Option<f32>,
    /// Address to listen on. The default, 127.0.0.1, keeps the viewer on this machine; any
    /// other address (e.g. 0.0.0.0) exposes it to the network, unauthenticated.
    #[arg(long, default_value = "127.0.0.1")]
    pub host: IpAddr,
    /// Start playing at once instead of paused.
    #[arg(long)]
    pub play: bool,
}

/// Runs the command.
pub fn main(a: Args) -> Result<(), CliError> {
    let sc = Scenario::load(&a.scenario)?;
    if let Some(d) = a.duration {
        if !(d > 0.0 && d.is_finite()) {
            return Err(CliError::Input(format!(
                "--duration: expected a positive number of seconds, got {d}"
            )));
        }
    }
    let opts = ServeOptions {
        host: a.host,
        port: a.port,
        seed: a.seed,
        duration_s: a.duration,
        play: a.play,
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
        eprintln!(
            "warning: listening on {addr}, reachable from other machines; the viewer has no authentication"
        );
    }
    let shown = if addr.ip().is_unspecified() {
        format!("127.0.0.1:{}", addr.port())
    } else {
        addr.to_string()
    };
    outln!(
        "serving {} on http://{shown}/ (Ctrl-C to stop)",
        a.scenario.display()
    );
    server
        .run()
        .map_err(|e| CliError::Other(anyhow::Error::new(e).context("serving")))
}
