//! `formica`: run, check and benchmark swarm cooperative-transport scenarios, with the built-in
//! controllers, loop functions and robot models (see the `formica_cli` library to add your own).

use std::process::ExitCode;

fn main() -> ExitCode {
    formica_cli::main_with(formica::Registry::builtin())
}
