//! `formica export` (being written; owned by its issue).

use crate::CliError;

/// Arguments of `formica export`.
#[derive(clap::Args)]
pub struct Args {}

/// Runs the command.
pub fn main(_a: Args) -> Result<(), CliError> {
    Err(CliError::Input("`formica export` is not available in this build yet".into()))
}
