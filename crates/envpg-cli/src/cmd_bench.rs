//! `envpg bench`: side-by-side timings whose ratios matter.

use std::time::{Duration, Instant};

use anyhow::Result;
use clap::Subcommand;
use envpg_model::{Form, GradientKind, Objective, Snapshot, solve_soft};

use crate::args::{load_instance, network, parse_zeta, positive};

/// Benchmarks.
#[derive(Debug, Subcommand)]
pub enum BenchCmd {
    /// Exact ζ-gradient (visits × local derivative) vs central differences over every
    /// coordinate, at the same ζ and α, on one instance.
    Gradient {
        /// Instance: `uav271` (bundled) or a path.
        #[arg(long, default_value = "uav271")]
        instance: String,
        /// κ values to measure.
        #[arg(long, value_delimiter = ',', default_value = "1.0,0.85")]
        kappas: Vec<f64>,
        /// Temperature α.
        #[arg(long, default_value_t = 0.2)]
        alpha: f64,
        /// Design [default: a fixed spread-out design of the bundled instance].
        #[arg(long)]
        zeta: Option<String>,
        /// Seconds to spend per measurement.
        #[arg(long, default_value_t = 2.0)]
        seconds: f64,
    },
}

/// Runs a benchmark.
pub fn run(cmd: BenchCmd) -> Result<()> {
    match cmd {
        BenchCmd::Gradient { instance, kappas, alpha, zeta, seconds } => {
            let inst = load_instance(&instance)?;
            positive("--alpha", alpha)?;
            positive("--seconds", seconds)?;
            println!(
                "gradient benchmark: {} ({} users, {} UAVs), alpha = {alpha}",
                inst.name,
                inst.n_users(),
                inst.n_uav
            );
            println!(
                "{:>6}  {:>14}  {:>14}  {:>8}  {:>12}",
                "kappa", "exact (µs)", "central (µs)", "ratio", "rel diff"
            );
            for kappa in kappas {
                let net = network(inst.clone(), kappa, 100.0)?;
                let zeta = match &zeta {
                    Some(z) => parse_zeta(z, &net)?,
                    None => default_zeta(&net),
                };
                let warm = solve_soft(&Snapshot::build(&net, &zeta), alpha, None)?.pi;
                let mut exact = Objective::new(&net, alpha, Form::Ssp);
                exact.gradient = GradientKind::Exact;
                let mut fd = Objective::new(&net, alpha, Form::Ssp);
                fd.gradient = GradientKind::Fd;
                let ge = exact.value_grad(&zeta, Some(&warm))?.grad;
                let gf = fd.value_grad(&zeta, Some(&warm))?.grad;
                let norm = |v: &mut dyn Iterator<Item = f64>| v.map(|x| x * x).sum::<f64>().sqrt();
                let diff =
                    norm(&mut ge.iter().zip(&gf).map(|(a, b)| a - b)) / norm(&mut gf.iter().copied()).max(1e-300);
                let budget = Duration::from_secs_f64(seconds / 2.0);
                let te = time_per_call(budget, || exact.value_grad(&zeta, Some(&warm)).map(|_| ()))?;
                let tf = time_per_call(budget, || fd.value_grad(&zeta, Some(&warm)).map(|_| ()))?;
                println!(
                    "{kappa:>6}  {:>14.1}  {:>14.1}  {:>7.1}×  {diff:>12.2e}",
                    te.as_secs_f64() * 1e6,
                    tf.as_secs_f64() * 1e6,
                    tf.as_secs_f64() / te.as_secs_f64()
                );
            }
            Ok(())
        }
    }
}

/// A spread-out design inside the users' bounding box.
fn default_zeta(net: &envpg_core::UavNetwork) -> Vec<f64> {
    let (lo, hi) = net.instance().user_bbox();
    let m = net.n_uav();
    (0..m)
        .flat_map(|j| {
            let t = (j as f64 + 0.5) / m as f64;
            [lo[0] + t * (hi[0] - lo[0]), hi[1] - t * (hi[1] - lo[1])]
        })
        .collect()
}

/// Median wall time of `f` over repeated calls within `budget`.
fn time_per_call<E: Into<anyhow::Error>>(budget: Duration, mut f: impl FnMut() -> Result<(), E>) -> Result<Duration> {
    f().map_err(Into::into)?; // warm-up
    let mut samples = Vec::new();
    let start = Instant::now();
    while start.elapsed() < budget || samples.len() < 5 {
        let t = Instant::now();
        f().map_err(Into::into)?;
        samples.push(t.elapsed());
    }
    samples.sort();
    Ok(samples[samples.len() / 2])
}
