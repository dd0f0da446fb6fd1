//! `formica-phototaxis`: the whole `formica` command (run, check, sweep, report, serve, ...) with
//! the `phototaxis` controller, the `gathering` loop functions and the `demo-bot` model in it.

use std::process::ExitCode;

fn main() -> Result<ExitCode, formica::RegistryError> {
    Ok(formica_cli::main_with(custom_controller::registry()?))
}
