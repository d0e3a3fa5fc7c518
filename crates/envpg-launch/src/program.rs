//! [`Program`]: how the launcher starts its own learner and worker processes (this executable,
//! or — for the Python package — `python -m envpg._launch`), and [`abort_env`], how an
//! environment that cannot go on ends its process so that the run stops with its message.

use std::ffi::OsString;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

/// Exit code of a learner or worker whose environment failed ([`abort_env`]): the run stops
/// (a replacement would fail the same way) with the message the process left in the run
/// directory.
pub const EXIT_ENV: u8 = 4;

/// The command that runs this launcher program: `program prefix… ARGS` is `envpg-launch ARGS`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Program {
    /// The executable.
    pub program: PathBuf,
    /// Arguments before the launcher's own (`["-m", "envpg._launch"]` for Python).
    pub prefix: Vec<OsString>,
    /// How the command is shown to users (in `--resume` hints).
    pub display: String,
}

impl Program {
    /// This executable, shown by its file name.
    pub fn current_exe() -> std::io::Result<Self> {
        let program = std::env::current_exe()?;
        let display =
            program.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_else(|| "envpg-launch".into());
        Ok(Self { program, prefix: Vec::new(), display })
    }
}

static PROGRAM: OnceLock<Program> = OnceLock::new();

/// Sets the program the launcher starts its roles with (the first call wins).
pub(crate) fn set(p: Program) {
    let _ = PROGRAM.set(p);
}

/// The program the roles are started with (this executable unless [`set`]).
pub(crate) fn get() -> std::io::Result<Program> {
    match PROGRAM.get() {
        Some(p) => Ok(p.clone()),
        None => Program::current_exe(),
    }
}

/// A command running this launcher with `args`.
pub(crate) fn command(args: &[String]) -> std::io::Result<Command> {
    let p = get()?;
    let mut cmd = Command::new(&p.program);
    cmd.args(&p.prefix).args(args);
    Ok(cmd)
}

/// `DIR/env-error.txt`: what a failed environment said.
pub(crate) fn env_error_path(dir: &Path) -> PathBuf {
    dir.join("env-error.txt")
}

static RUN_DIR: OnceLock<PathBuf> = OnceLock::new();

/// Remembers the run directory of this process, where [`abort_env`] leaves its message.
pub(crate) fn set_run_dir(dir: &Path) {
    let _ = RUN_DIR.set(dir.to_owned());
}

/// Ends this learner or worker process because its environment cannot go on (an exception in a
/// Python environment's `step`, a NaN cost, a state out of range): the message goes to stderr
/// and to the run directory, and the process exits with [`EXIT_ENV`], on which the supervisor
/// stops the run with that message (exit code 1) instead of restarting the process.
///
/// For environments whose sampler cannot return an error; only for the processes of a run
/// started by this launcher (a thread of `--in-process` would end the whole program).
pub fn abort_env(message: &str) -> ! {
    eprintln!("error: the environment failed: {message}");
    crate::log::to_file(&format!("error: the environment failed: {message}"));
    if let Some(dir) = RUN_DIR.get() {
        // First failure wins: several workers may fail alike at once.
        let path = env_error_path(dir);
        if !path.exists() {
            let _ = envpg_core::io::write_atomic(&path, message.as_bytes());
        }
    }
    std::process::exit(i32::from(EXIT_ENV))
}

/// The run failed because its environment did ([`abort_env`]).
#[derive(Debug)]
pub struct EnvFailed(pub String);

impl std::fmt::Display for EnvFailed {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "the environment failed: {}", self.0)
    }
}

impl std::error::Error for EnvFailed {}

/// The failure a process of the run in `dir` that exited with [`EXIT_ENV`] left (`who` names it).
pub(crate) fn env_failure(dir: &Path, who: &str) -> anyhow::Error {
    let message = std::fs::read_to_string(env_error_path(dir))
        .unwrap_or_else(|_| format!("{who} exited with code {EXIT_ENV} without saying why"));
    EnvFailed(message).into()
}
