//! `formica serve` (being written; owned by its issue).

use crate::CliError;

/// Arguments of `formica serve`.
#[derive(clap::Args)]
pub struct Args {}

/// Runs the command.
pub fn main(_a: Args) -> Result<(), CliError> {
    Err(CliError::Input("`formica serve` is not available in this build yet".into()))
}
