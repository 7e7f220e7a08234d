//! Errors, exit codes and number formatting shared by the commands.

use std::fmt;
use std::io;
use std::process::ExitCode;

/// Exit code for bad input (a malformed material spec, an unknown name): the same code clap
/// uses for usage errors.
pub const EXIT_USAGE: u8 = 2;

/// Exit code of `specula brdf check` when a check fails (distinct from usage errors).
pub const EXIT_CHECKS_FAILED: u8 = 1;

/// A command failure, printed as a single `error: …` line.
#[derive(Debug)]
pub enum CliError {
    /// The user's input was rejected.
    Usage(String),
    /// Writing the output failed.
    Io(io::Error),
    /// A check reported a failure; its report (already printed) says which, so nothing more
    /// is printed.
    ChecksFailed,
}

impl CliError {
    pub fn usage(msg: impl fmt::Display) -> Self {
        // keep the report on one line whatever the message contains
        let msg = msg.to_string().replace(['\n', '\r'], " ");
        CliError::Usage(msg)
    }

    /// Print the error (if any is worth printing) and pick the exit code.
    pub fn report(self) -> ExitCode {
        match self {
            CliError::Usage(msg) => {
                eprintln!("error: {msg}");
                ExitCode::from(EXIT_USAGE)
            }
            // `specula fresnel | head`: the reader went away, which is not an error
            CliError::Io(e) if e.kind() == io::ErrorKind::BrokenPipe => ExitCode::SUCCESS,
            CliError::Io(e) => {
                eprintln!("error: cannot write output: {e}");
                ExitCode::FAILURE
            }
            CliError::ChecksFailed => ExitCode::from(EXIT_CHECKS_FAILED),
        }
    }
}

impl From<io::Error> for CliError {
    fn from(e: io::Error) -> Self {
        CliError::Io(e)
    }
}

/// A value in a fixed-width column: fixed-point in the usual range, scientific otherwise.
pub fn num(v: f32) -> String {
    let a = v.abs();
    if v == 0.0 || (1e-4..1e6).contains(&a) || !v.is_finite() {
        format!("{v:.6}")
    } else {
        format!("{v:.6e}")
    }
}

/// Three channels, space separated.
pub fn rgb(c: [f32; 3]) -> String {
    format!("{} {} {}", num(c[0]), num(c[1]), num(c[2]))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers() {
        assert_eq!(num(0.0), "0.000000");
        assert_eq!(num(0.5 / std::f32::consts::PI), "0.159155");
        assert_eq!(num(1234.5), "1234.500000");
        assert_eq!(num(1e-7), "1.000000e-7");
        assert_eq!(num(f32::INFINITY), "inf");
    }

    #[test]
    fn usage_errors_are_one_line() {
        match CliError::usage("a\nb") {
            CliError::Usage(m) => assert_eq!(m, "a b"),
            other => panic!("{other:?}"),
        }
    }
}
