//! `envpg bench`: side-by-side timings whose ratios matter.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use anyhow::Result;
use clap::Subcommand;
use envpg_core::{Purpose, Streams};
use envpg_model::{Form, GradientKind, Objective, Snapshot, solve_soft};

use crate::args::{InputError, InstanceArgs, Tools, check_dir_writable, parse_zeta, positive};

/// Benchmarks.
#[derive(Debug, Subcommand)]
pub enum BenchCmd {
    /// Exact ζ-gradient (visits × local derivative) vs central differences over every
    /// coordinate, at the same ζ and α, on one instance.
    Gradient {
        #[command(flatten)]
        instance: InstanceArgs,
        /// κ values to measure (uav, flpo; each overrides the instance's).
        #[arg(long, value_delimiter = ',')]
        kappas: Option<Vec<f64>>,
        /// Temperature α.
        #[arg(long, default_value_t = 0.2)]
        alpha: f64,
        /// Design [default: the environment's own starting design, or its random design of seed 1].
        #[arg(long)]
        zeta: Option<String>,
        /// Seconds to spend per measurement.
        #[arg(long, default_value_t = 2.0)]
        seconds: f64,
    },
    /// Training throughput against the number of workers: the throughput model of one or more
    /// `envpg-launch --bench --bench-out FILE` reports (lines: a core per process; crosses: the
    /// measuring machine's cores) and what each measured (points), for lag 0 and 1. Writes
    /// DIR/throughput-model.svg and .png.
    Plot {
        /// `--bench-out` reports of `envpg-launch --bench`.
        #[arg(required = true)]
        reports: Vec<PathBuf>,
        /// Output directory.
        #[arg(long)]
        out: PathBuf,
    },
}

/// Runs a benchmark.
pub fn run(cmd: BenchCmd, tools: &Tools) -> Result<()> {
    match cmd {
        BenchCmd::Plot { reports, out } => plot(&reports, &out),
        BenchCmd::Gradient { instance, kappas, alpha, zeta, seconds } => {
            positive("--alpha", alpha)?;
            positive("--seconds", seconds)?;
            let base = instance.load(&tools.registry)?;
            println!(
                "gradient benchmark: {} ({}, {} states, ζ ∈ ℝ^{}), alpha = {alpha}",
                base.title,
                base.name,
                base.sampler().n_states(),
                base.sampler().zeta_dim()
            );
            println!(
                "{:>24}  {:>14}  {:>14}  {:>8}  {:>12}",
                "parameters", "exact (µs)", "central (µs)", "ratio", "rel diff"
            );
            let settings: Vec<Option<f64>> = match kappas {
                Some(k) => k.into_iter().map(Some).collect(),
                None => vec![None],
            };
            for kappa in settings {
                let mut over = instance.overrides()?;
                over.extend(kappa.map(|k| ("kappa".to_owned(), k)));
                let env = tools.registry.load(&instance.instance, &over)?;
                let net = env.model()?;
                let zeta = match &zeta {
                    Some(z) => parse_zeta(z, &env)?,
                    None => net
                        .heuristic_design()
                        .unwrap_or_else(|| net.random_design(&mut Streams::new(1).stream(Purpose::Zeta0, 0, 0))),
                };
                let warm = solve_soft(&Snapshot::build(net, &zeta), alpha, None)?.pi;
                let mut exact = Objective::new(net, alpha, Form::Ssp);
                exact.gradient = GradientKind::Exact;
                let mut fd = Objective::new(net, alpha, Form::Ssp);
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
                    "{:>24}  {:>14.1}  {:>14.1}  {:>7.1}×  {diff:>12.2e}",
                    env.params_text(),
                    te.as_secs_f64() * 1e6,
                    tf.as_secs_f64() * 1e6,
                    tf.as_secs_f64() / te.as_secs_f64()
                );
            }
            Ok(())
        }
    }
}

/// `envpg bench plot`: the curves of every report, checked before anything is drawn.
fn plot(reports: &[PathBuf], out: &Path) -> Result<()> {
    check_dir_writable(out)?;
    let mut curves = Vec::new();
    for path in reports {
        let bad = |why: &str| {
            InputError(format!("{}: {why} (expected an `envpg-launch --bench --bench-out` report)", path.display()))
        };
        let text = std::fs::read_to_string(path).map_err(|e| InputError(format!("{}: {e}", path.display())))?;
        let report: serde_json::Value = serde_json::from_str(&text).map_err(|e| bad(&e.to_string()))?;
        let cost = report["emulator_cost_us"].as_u64().ok_or_else(|| bad("no emulator_cost_us"))?;
        let predictions =
            report["predictions"].as_array().filter(|p| !p.is_empty()).ok_or_else(|| bad("no model predictions"))?;
        let field =
            |p: &serde_json::Value, k: &str| p[k].as_f64().ok_or_else(|| bad(&format!("a prediction without {k}")));
        for lag in [0.0, 1.0] {
            let (mut predicted, mut measured, mut predicted_there) = (Vec::new(), Vec::new(), Vec::new());
            for p in predictions {
                if field(p, "lag")? != lag {
                    continue;
                }
                let (w, cores) = (field(p, "workers")?, field(p, "cores")?);
                if cores == w + 1.0 {
                    predicted.push((w as usize, field(p, "per_second")?));
                }
                if let Some(m) = p["measured"].as_f64() {
                    measured.push((w as usize, m));
                    predicted_there.push((w as usize, field(p, "per_second")?));
                }
            }
            let step = if cost == 0 { "the UAV emulator".to_string() } else { format!("+{cost} µs a step") };
            let label = format!("{step}, lag {lag}");
            curves.push(envpg_report::figures::ThroughputCurve { label, predicted, measured, predicted_there });
        }
    }
    let title =
        "Training throughput: model (lines: a core per process; ×: the measuring machine's cores), measured (●)";
    for p in envpg_report::figures::throughput(title, &curves, out, "throughput-model")? {
        println!("wrote {}", p.display());
    }
    Ok(())
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
