//! `envpg evaluate`.

use anyhow::{Context, Result, bail};
use clap::Args;
use envpg_core::ResultFile;
use envpg_model::uav::{optimal_greedy, pairs_from_rows};
use envpg_model::{Snapshot, evaluate};

use crate::args::{input_err, load_instance, network, parse_zeta};

/// Options of `envpg evaluate`: either result files, or a design on an instance.
#[derive(Debug, Args)]
pub struct EvaluateArgs {
    /// Result files to re-score from their own contents (instance, κ, η, ζ, policy).
    results: Vec<std::path::PathBuf>,
    /// Instance for `--zeta`: `uav271` (bundled) or a path.
    #[arg(long, default_value = "uav271")]
    instance: String,
    /// Design to score with its optimal (greedy) policy: 2M comma-separated numbers.
    #[arg(long)]
    zeta: Option<String>,
    /// κ for `--zeta`.
    #[arg(long, default_value_t = 1.0)]
    kappa: f64,
    /// η for `--zeta`.
    #[arg(long, default_value_t = 100.0)]
    eta: f64,
    /// Relative tolerance when comparing with the J stored in a result file.
    #[arg(long, default_value_t = 1e-9)]
    tol: f64,
}

/// Re-scores result files (exit 1 if a stored J disagrees) or scores a design.
pub fn run(a: EvaluateArgs) -> Result<()> {
    if a.results.is_empty() && a.zeta.is_none() {
        return input_err("give result files to re-score, or --zeta to score a design");
    }
    if let Some(z) = &a.zeta {
        let net = network(load_instance(&a.instance)?, a.kappa, a.eta)?;
        let zeta = parse_zeta(z, &net)?;
        let (_, _, j) = optimal_greedy(&net, &zeta).context("solving the design")?;
        println!("J = {j:.9}  (optimal policy at the given zeta, kappa={}, eta={})", a.kappa, a.eta);
    }
    let mut mismatches = 0;
    for path in &a.results {
        let r = ResultFile::load(path)?;
        let net = network(r.instance.clone(), r.kappa, r.eta).with_context(|| format!("{}", path.display()))?;
        let snap = Snapshot::build(&net, &r.zeta);
        let pi = pairs_from_rows(&net, &snap, &r.policy)
            .map_err(|e| crate::args::InputError(format!("{}: {e}", path.display())))?;
        let recomputed = evaluate(&snap, &pi, 0.0);
        let mut line = format!("{}: method={} kappa={} ", path.display(), r.method, r.kappa);
        match (&recomputed, r.j) {
            (Ok(v), Some(stored)) => {
                let ok = (v.j - stored).abs() <= a.tol * stored.abs().max(1.0);
                line += &format!("J = {:.9} (stored {:.9}) {}", v.j, stored, if ok { "ok" } else { "MISMATCH" });
                mismatches += usize::from(!ok);
            }
            (Ok(v), None) => {
                line += &format!("J = {:.9} (stored null) MISMATCH", v.j);
                mismatches += 1;
            }
            (Err(e), None) => line += &format!("J = inf ({e}) (stored null) ok"),
            (Err(e), Some(stored)) => {
                line += &format!("J = inf ({e}) (stored {stored}) MISMATCH");
                mismatches += 1;
            }
        }
        if let (Some(soft), Some(alpha)) = (&r.policy_soft, r.alpha_final) {
            let pis = pairs_from_rows(&net, &snap, soft)
                .map_err(|e| crate::args::InputError(format!("{}: {e}", path.display())))?;
            if let Ok(v) = evaluate(&snap, &pis, alpha) {
                line += &format!("  J_H(soft policy, alpha={alpha:.3e}) = {:.9}", v.j);
            }
        }
        println!("{line}");
    }
    if mismatches > 0 {
        bail!("{mismatches} result file(s) disagree with their stored J");
    }
    Ok(())
}
