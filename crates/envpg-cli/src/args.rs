//! Shared argument parsing, the registry the tools run with, and error → exit-code mapping.

use anyhow::{Result, bail};
use clap::Args;
use envpg_core::exit::{self, Failure};
use envpg_core::{LoadedEnv, Registry, ResultFile};

/// What every command runs with: the registered environments, and the launcher binary that
/// `--workers` runs.
#[derive(Debug, Clone)]
pub struct Tools {
    /// The environments.
    pub registry: Registry,
    /// The launcher binary's name (beside this executable).
    pub launcher: String,
}

/// Marks an error as the user's input being wrong (exit code 2).
#[derive(Debug)]
pub struct InputError(pub String);

impl std::fmt::Display for InputError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}
impl std::error::Error for InputError {}

/// Returns an input error.
pub fn input_err<T>(msg: impl Into<String>) -> Result<T> {
    Err(InputError(msg.into()).into())
}

/// Logs to stderr; `RUST_LOG` overrides the default level (warn).
pub fn init_tracing() {
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("warn"));
    let _ = tracing_subscriber::fmt().with_env_filter(filter).with_writer(std::io::stderr).try_init();
}

/// Maps an error to the program's exit code (2 for bad input, 1 otherwise) and its message.
pub fn failure(e: &anyhow::Error) -> Failure {
    let input = e.chain().any(|c| {
        c.is::<InputError>()
            || c.is::<envpg_core::InstanceError>()
            || c.is::<envpg_core::result::ResultError>()
            || c.is::<envpg_core::ZetaError>()
            || c.is::<envpg_core::NoModel>()
            || c.is::<envpg_ac::config::PresetError>()
            || c.is::<envpg_ac::config::ConfigError>()
            || matches!(c.downcast_ref::<envpg_report::ReportError>(), Some(envpg_report::ReportError::Plan(_)))
            || matches!(c.downcast_ref::<envpg_model::ModelError>(), Some(envpg_model::ModelError::Invalid(_)))
    });
    Failure { code: if input { exit::INPUT } else { exit::FAILED }, message: format!("{e:#}") }
}

/// Which instance, with which parameters.
#[derive(Debug, Clone, Args)]
pub struct InstanceArgs {
    /// Instance: a bundled one (`uav271`, `aac1800`, `flpo-n10m4`; `envpg envs` lists them) or a
    /// path to an instance JSON file, which names its environment (`"env"`; none: `uav`).
    #[arg(long, default_value = "uav271")]
    pub instance: String,
    /// Override a parameter of the instance's environment: `--env-param deviation=0.3`
    /// (repeatable; `envpg envs` lists each environment's parameters).
    #[arg(long = "env-param", value_name = "KEY=VALUE")]
    pub env_params: Vec<String>,
    /// Shorthand for `--env-param kappa=K` (uav, flpo): probability that a hop reaches its
    /// intended target.
    #[arg(long)]
    pub kappa: Option<f64>,
    /// Shorthand for `--env-param eta=E` (uav, flpo): concentration of off-target moves.
    #[arg(long)]
    pub eta: Option<f64>,
}

impl InstanceArgs {
    /// The parameter overrides.
    pub fn overrides(&self) -> Result<Vec<(String, f64)>> {
        envpg_core::instance::param_overrides(&self.env_params, self.kappa, self.eta).map_err(|e| InputError(e).into())
    }

    /// The environment of the instance.
    pub fn load(&self, registry: &Registry) -> Result<LoadedEnv> {
        Ok(registry.load(&self.instance, &self.overrides()?)?)
    }
}

/// Parses a design: comma-separated finite numbers inside the environment's bounds.
pub fn parse_zeta(text: &str, env: &LoadedEnv) -> Result<Vec<f64>> {
    let zeta: Vec<f64> = text
        .split(',')
        .map(|t| t.trim().parse::<f64>().map_err(|e| InputError(format!("zeta entry {t:?}: {e}"))))
        .collect::<Result<_, _>>()?;
    env.sampler().zeta_space().check(&zeta)?;
    Ok(zeta)
}

/// `ZETA` list or `RESULT.json` on the same instance (its ζ₀): the initial design of a run.
pub fn parse_init(text: &str, env: &LoadedEnv) -> Result<Vec<f64>> {
    if std::path::Path::new(text).is_file() {
        let r = ResultFile::load(text)?;
        if r.instance != env.instance {
            bail!(InputError(format!(
                "{text} was computed on instance {:?} ({}), not {:?} ({})",
                r.instance_name(),
                r.env,
                env.title,
                env.name
            )));
        }
        return Ok(r.zeta0);
    }
    parse_zeta(text, env).map_err(|e| {
        InputError(format!(
            "--init {text:?} is neither a result file nor {} numbers inside the bounds: {e:#}",
            env.sampler().zeta_dim()
        ))
        .into()
    })
}

/// A positive finite number.
pub fn positive(name: &str, x: f64) -> Result<f64> {
    if x.is_finite() && x > 0.0 { Ok(x) } else { input_err(format!("{name} must be finite and > 0, got {x}")) }
}

/// Checks, before any work, that a file can be written at `path` (an input error if not).
pub fn check_writable(path: &std::path::Path) -> Result<()> {
    envpg_core::io::check_writable(path).map_err(|e| InputError(e.to_string()).into())
}

/// Checks, before any work, that files can be written into `dir` (an input error if not).
pub fn check_dir_writable(dir: &std::path::Path) -> Result<()> {
    envpg_core::io::check_dir_writable(dir).map_err(|e| InputError(e.to_string()).into())
}
