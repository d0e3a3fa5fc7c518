//! Shared argument parsing and error → exit-code mapping.

use std::process::ExitCode;

use anyhow::{Context, Result, bail};
use envpg_core::{Instance, ParamMdp, ResultFile, UavNetwork};

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

/// Prints the error chain and maps it to an exit code.
pub fn exit_code(result: Result<()>) -> ExitCode {
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            let input = e.chain().any(|c| {
                c.is::<InputError>()
                    || c.is::<envpg_core::InstanceError>()
                    || c.is::<envpg_core::result::ResultError>()
                    || c.is::<envpg_core::UavParamError>()
                    || c.is::<envpg_ac::config::PresetError>()
                    || matches!(c.downcast_ref::<envpg_report::ReportError>(), Some(envpg_report::ReportError::Plan(_)))
            });
            if input { ExitCode::from(2) } else { ExitCode::from(1) }
        }
    }
}

/// Loads an instance: `uav271` (bundled) or a path.
pub fn load_instance(spec: &str) -> Result<Instance> {
    Ok(Instance::resolve(spec)?)
}

/// Builds the network, with κ and η validated.
pub fn network(instance: Instance, kappa: f64, eta: f64) -> Result<UavNetwork> {
    Ok(UavNetwork::new(instance, kappa, eta)?)
}

/// Parses a design: a comma-separated list of 2M finite numbers.
pub fn parse_zeta(text: &str, net: &UavNetwork) -> Result<Vec<f64>> {
    let zeta: Vec<f64> = text
        .split(',')
        .map(|t| t.trim().parse::<f64>().map_err(|e| InputError(format!("zeta entry {t:?}: {e}"))))
        .collect::<Result<_, _>>()?;
    if let Err(e) = net.check_zeta(&zeta) {
        return input_err(e);
    }
    Ok(zeta)
}

/// `ZETA` list or `RESULT.json` (its ζ₀): the initial design of a run.
pub fn parse_init(text: &str, net: &UavNetwork) -> Result<Vec<f64>> {
    if std::path::Path::new(text).is_file() {
        let r = ResultFile::load(text)?;
        if r.instance != *net.instance() {
            bail!(InputError(format!(
                "{text} was computed on instance {:?}, not {:?}",
                r.instance.name,
                net.instance().name
            )));
        }
        return Ok(r.zeta0);
    }
    parse_zeta(text, net)
        .with_context(|| format!("--init {text:?} is neither a result file nor a list of {} numbers", net.zeta_dim()))
}

/// A positive finite number.
pub fn positive(name: &str, x: f64) -> Result<f64> {
    if x.is_finite() && x > 0.0 { Ok(x) } else { input_err(format!("{name} must be finite and > 0, got {x}")) }
}
