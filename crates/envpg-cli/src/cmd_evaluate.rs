//! `envpg evaluate`.

use anyhow::{Context, Result, bail};
use clap::Args;
use envpg_core::ResultFile;
use envpg_model::{optimal_greedy, rescore};

use crate::args::{InputError, InstanceArgs, Tools, input_err, parse_zeta};

/// Options of `envpg evaluate`: either result files, or a design on an instance.
#[derive(Debug, Args)]
pub struct EvaluateArgs {
    /// Result files (envpg.result.v2, or v1) to re-score from their own contents (environment,
    /// instance with its parameters, ζ, policy).
    results: Vec<std::path::PathBuf>,
    /// The instance for `--zeta`.
    #[command(flatten)]
    instance: InstanceArgs,
    /// Design to score with its optimal (greedy) policy: d comma-separated numbers.
    #[arg(long)]
    zeta: Option<String>,
    /// Relative tolerance when comparing with the J stored in a result file.
    #[arg(long, default_value_t = 1e-9)]
    tol: f64,
}

/// Re-scores result files (exit 1 if a stored J disagrees) or scores a design.
pub fn run(a: EvaluateArgs, tools: &Tools) -> Result<()> {
    if a.results.is_empty() && a.zeta.is_none() {
        return input_err("give result files to re-score, or --zeta to score a design");
    }
    let i = &a.instance;
    if a.zeta.is_none() && (i.instance != "uav271" || !i.env_params.is_empty() || i.kappa.is_some() || i.eta.is_some())
    {
        return input_err(
            "--instance, --env-param, --kappa and --eta choose the problem for --zeta; a result file is \
             scored on the instance it carries",
        );
    }
    if let Some(z) = &a.zeta {
        let env = a.instance.load(&tools.registry)?;
        let model = env.model()?;
        let zeta = parse_zeta(z, &env)?;
        let (_, _, j) = optimal_greedy(model, &zeta).context("solving the design")?;
        println!("J = {j:.9}  (optimal policy at the given zeta; {} {}, {})", env.name, env.title, env.params_text());
    }
    let mut mismatches = 0;
    for path in &a.results {
        let r = ResultFile::load(path)?;
        let env = r.load_env(&tools.registry, path)?;
        let model = env.model().map_err(|e| InputError(format!("{}: {e}", path.display())))?;
        let rescored = rescore(model, &r).map_err(|e| InputError(format!("{}: {e}", path.display())))?;
        let mut line = format!("{}: method={} env={} {} ", path.display(), r.method, r.env, env.params_text());
        match (&rescored.j, r.j) {
            (Ok(j), Some(stored)) => {
                let ok = (j - stored).abs() <= a.tol * stored.abs().max(1.0);
                line += &format!("J = {:.9} (stored {:.9}) {}", j, stored, if ok { "ok" } else { "MISMATCH" });
                mismatches += usize::from(!ok);
            }
            (Ok(j), None) => {
                line += &format!("J = {:.9} (stored null) MISMATCH", j);
                mismatches += 1;
            }
            (Err(e), None) => line += &format!("J = inf ({e}) (stored null) ok"),
            (Err(e), Some(stored)) => {
                line += &format!("J = inf ({e}) (stored {stored}) MISMATCH");
                mismatches += 1;
            }
        }
        if let (Some(j_h), Some(alpha)) = (rescored.j_h, r.alpha_final) {
            line += &format!("  J_H(soft policy, alpha={alpha:.3e}) = {j_h:.9}");
        }
        println!("{line}");
    }
    if mismatches > 0 {
        bail!("{mismatches} result file(s) disagree with their stored J");
    }
    Ok(())
}
