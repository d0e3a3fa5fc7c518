//! [`Failure`]: how a program of envpg ended when it did not succeed — its exit code and its
//! message — for front ends that run the programs in-process (the Python package) rather than
//! as a process whose exit code a shell reads.

/// Exit code of a failed computation.
pub const FAILED: u8 = 1;
/// Exit code of bad input (arguments, files, settings).
pub const INPUT: u8 = 2;
/// Exit code of a run interrupted by SIGINT/SIGTERM.
pub const INTERRUPTED: u8 = 130;

/// A program's unsuccessful end: the exit code it maps to ([`FAILED`], [`INPUT`],
/// [`INTERRUPTED`]) and the error message it would print.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{message}")]
pub struct Failure {
    /// The exit code.
    pub code: u8,
    /// The error, with its causes.
    pub message: String,
}

impl Failure {
    /// Bad command-line arguments, from the argument parser's rendered error (its leading
    /// `error: ` dropped: callers print their own).
    pub fn usage(rendered: &str) -> Self {
        let text = rendered.trim_end();
        Self { code: INPUT, message: text.strip_prefix("error: ").unwrap_or(text).to_owned() }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_usage_error_is_bad_input_without_the_parsers_prefix() {
        let f = Failure::usage("error: unexpected argument '--x' found\n\nUsage: envpg\n");
        assert_eq!(f.code, INPUT);
        assert_eq!(f.message, "unexpected argument '--x' found\n\nUsage: envpg");
        assert_eq!(Failure::usage("no prefix").message, "no prefix");
    }
}
