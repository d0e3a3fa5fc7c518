//! One training run from its command line: the run directory, the benchmark or the passes, and
//! each pass's learner and workers with its progress bar, live metrics and resume hint.

use std::path::PathBuf;
use std::time::Duration;

use anyhow::{Context, Result};
use envpg_core::Registry;
use indicatif::{ProgressBar, ProgressStyle};

use crate::run_dir::RunFile;
use crate::{
    InputError, LaunchArgs, args, bench, in_process, is_interrupt, log, metrics, multi_host, passes, program, run_dir,
    supervise,
};

/// An interrupted run says where it stands and how to continue it (on stderr, before the
/// error itself).
fn with_resume_hint(
    e: anyhow::Error,
    run: &RunFile,
    dir: &std::path::Path,
    resume_dir: &std::path::Path,
) -> anyhow::Error {
    if !is_interrupt(&e) {
        return e;
    }
    let exe = program::get().map_or_else(|_| "envpg-launch".into(), |p| p.display);
    match run.load_checkpoint(dir) {
        Ok(c) => eprintln!(
            "kept: checkpoint at iteration {} of {} in {}\ncontinue the run with: {exe} --resume {}",
            c.k,
            run.spec.config.iterations,
            RunFile::checkpoint_path(dir).display(),
            resume_dir.display()
        ),
        Err(c) => eprintln!("no checkpoint could be kept: {c}"),
    }
    e
}

fn progress_bar(total: u64, quiet: bool) -> ProgressBar {
    if quiet {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::new(total);
    bar.set_style(
        ProgressStyle::with_template("{elapsed_precise} [{bar:30}] {pos}/{len} {msg}")
            .expect("valid template")
            .progress_chars("=> "),
    );
    bar.enable_steady_tick(Duration::from_millis(200));
    bar
}

fn message(alpha: f64, j_h: f64, j: Option<f64>, tps: f64) -> String {
    format!("α={alpha:.3e} J_H≈{j_h:.3} J={} {tps:.0} tr/s", j.map_or("-".into(), |j| format!("{j:.4}")))
}

/// Where run directories go by default: `$ENVPG_RUNS_DIR`, or `runs/` in the current
/// directory (created; one place a user can find and clean).
fn default_runs_dir() -> Result<PathBuf> {
    let dir = match std::env::var_os("ENVPG_RUNS_DIR") {
        Some(d) if !d.is_empty() => PathBuf::from(d),
        _ => std::env::current_dir()?.join("runs"),
    };
    std::fs::create_dir_all(&dir).map_err(|e| {
        InputError(format!(
            "cannot create {} for the run directory: {e} (choose one with --run-dir DIR)",
            dir.display()
        ))
    })?;
    Ok(dir)
}

pub(crate) fn run(train: args::TrainArgs, launch: LaunchArgs, registry: &Registry) -> Result<()> {
    if launch.bench {
        if launch.passes != 1 {
            return Err(
                InputError("--passes does not apply to --bench (it measures throughput, not designs)".into()).into()
            );
        }
        if let Some(p) = &launch.bench_out {
            envpg_core::io::check_writable(p).map_err(|e| InputError(format!("--bench-out: {e}")))?;
        }
        let (env, spec) = train.spec(registry).map_err(|e| InputError(format!("{e:#}")))?;
        let dir = std::env::temp_dir().join(format!("envpg-bench-{}", run_dir::new_run_id()));
        std::fs::create_dir_all(&dir)?;
        let report =
            bench::run(&env, &spec, launch.emulator_cost_us, &launch.bench_workers, launch.bench_repeats, &dir);
        let _ = std::fs::remove_dir_all(&dir);
        let report = report?;
        bench::print(&report);
        if let Some(p) = &launch.bench_out {
            envpg_core::io::write_atomic(p, serde_json::to_string_pretty(&report)?.as_bytes())?;
        }
        return Ok(());
    }
    let (dir, run, resume) = match &launch.resume {
        Some(dir) => {
            let run = RunFile::load(dir).map_err(|e| InputError(format!("--resume {}: {e:#}", dir.display())))?;
            envpg_core::io::check_writable(&run.out)
                .map_err(|e| InputError(format!("--resume {}: the run's result file: {e}", dir.display())))?;
            if run.passes > 1 {
                // Each pass has a directory of its own; passes::run finds where to continue.
                passes::check_resumable(&run, dir)?;
                (dir.clone(), run, None)
            } else {
                // A missing, corrupt or foreign checkpoint is found here, before any process starts.
                let checkpoint =
                    run.load_checkpoint(dir).map_err(|e| InputError(format!("--resume {}: {e}", dir.display())))?;
                (dir.clone(), run, Some(checkpoint))
            }
        }
        None => {
            // Everything that goes wrong while turning arguments into a run is the user's input.
            let (_, spec) = train.spec(registry).map_err(|e| InputError(format!("{e:#}")))?;
            // Outputs next, before any work: a run that cannot keep its result must not start.
            envpg_core::io::check_writable(&launch.out).map_err(|e| InputError(format!("--out: {e}")))?;
            if let Some(d) = &launch.run_dir {
                envpg_core::io::create_private_dir(d)
                    .and_then(|()| envpg_core::io::check_dir_writable(d))
                    .map_err(|e| InputError(format!("--run-dir {}: {e}", d.display())))?;
            }
            if let Some(d) = &launch.tensorboard {
                std::fs::create_dir_all(d)
                    .map_err(|e| e.to_string())
                    .and_then(|()| envpg_core::io::check_dir_writable(d).map_err(|e| e.to_string()))
                    .map_err(|e| InputError(format!("--tensorboard {}: {e}", d.display())))?;
            }
            if launch.workers == 0 && (launch.in_process || launch.listen.is_none()) {
                return Err(InputError("--workers must be at least 1 (0 only with --listen)".into()).into());
            }
            if let Some(endpoint) = &launch.listen {
                if launch.in_process {
                    return Err(InputError("--listen needs the distributed mode, not --in-process".into()).into());
                }
                multi_host::check_listen(endpoint)?;
            }
            if launch.passes == 0 {
                return Err(InputError("--passes must be at least 1".into()).into());
            }
            if launch.passes == 1 && launch.pass_start.is_some() {
                return Err(InputError(
                    "--pass-start applies to the passes after the first: give --passes 2 or more".into(),
                )
                .into());
            }
            if launch.stall_timeout_s == 0 {
                return Err(InputError("--stall-timeout-s must be at least 1".into()).into());
            }
            let run_id = run_dir::new_run_id();
            let dir = match &launch.run_dir {
                Some(d) => d.clone(),
                None => default_runs_dir()?.join(&run_id),
            };
            // Owner only: the run directory holds the run's description and checkpoints.
            envpg_core::io::create_private_dir(&dir).map_err(|e| {
                InputError(format!(
                    "cannot create the run directory {}: {e} (choose one with --run-dir DIR)",
                    dir.display()
                ))
            })?;
            let absolute = |p: &PathBuf| -> Result<PathBuf> {
                Ok(if p.is_absolute() { p.clone() } else { std::env::current_dir()?.join(p) })
            };
            let out = absolute(&launch.out)?;
            let tensorboard = launch.tensorboard.as_ref().map(absolute).transpose()?;
            let run = RunFile {
                run_id,
                spec,
                out,
                workers: launch.workers,
                checkpoint_every: launch.checkpoint_every,
                emulator_cost_us: launch.emulator_cost_us,
                worker_timeout_ms: launch.worker_timeout_ms,
                stall_timeout_s: launch.stall_timeout_s,
                listen: launch.listen.clone(),
                tensorboard,
                passes: launch.passes,
                pass_start: launch.pass_start.unwrap_or_default(),
            };
            run.save(&dir)?;
            (dir, run, None)
        }
    };
    log::keep_in(&dir);
    if !launch.quiet {
        eprintln!("run directory: {}", dir.display());
    }
    if run.passes > 1 {
        return passes::run(&run, &dir, launch.resume.is_some(), &launch, registry);
    }
    let j = train_pass(&run, &dir, resume, &launch, registry, &Pass::only(&dir))?;
    if !launch.quiet {
        println!(
            "J = {}  → {}  (run directory {})",
            j.map_or("inf".into(), |j| format!("{j:.6}")),
            run.out.display(),
            dir.display()
        );
    }
    Ok(())
}

/// Which pass of a run [`train_pass`] trains, for its progress bar and its resume hint.
pub(crate) struct Pass<'a> {
    /// "pass 2/3 " (empty for a one-pass run).
    pub(crate) label: String,
    /// The directory `--resume` takes to continue the run.
    pub(crate) resume_dir: &'a std::path::Path,
}

impl<'a> Pass<'a> {
    fn only(dir: &'a std::path::Path) -> Self {
        Self { label: String::new(), resume_dir: dir }
    }
}

/// Trains the run described by `run` in `dir` (from `resume`'s checkpoint, if given) with
/// learner and workers as processes or threads, streaming its progress to the bar and the live
/// metrics; the result is written to `run.out` and `dir`. Returns the exact J, when the
/// environment has a model.
pub(crate) fn train_pass(
    run: &RunFile,
    dir: &std::path::Path,
    resume: Option<envpg_protocol::Checkpoint>,
    launch: &LaunchArgs,
    registry: &Registry,
    pass: &Pass<'_>,
) -> Result<Option<f64>> {
    let mut live = metrics::Metrics::open(dir, run.tensorboard.as_deref(), resume.as_ref().map(|c| c.k))
        .map_err(|e| InputError(format!("live metrics: {e:#}")))?;
    let bar = progress_bar(run.spec.config.iterations as u64, launch.quiet);
    let label = &pass.label;
    let mut train = || -> Result<Option<f64>> {
        Ok(if launch.in_process {
            let checkpoint = Some(run.checkpoint_policy(dir));
            let env = run.spec.load(registry).map_err(|e| InputError(format!("{e:#}")))?;
            let (result, _) = in_process::run(run, &env, checkpoint, resume.clone(), |p| {
                bar.set_position(p.k + 1);
                bar.set_message(format!("{label}{}", message(p.alpha, p.j_h_estimate, p.j_exact, p.transitions_per_s)));
                live.record(&metrics::ProgressLine::from(p));
                true
            })?;
            run_dir::save_result(&result, &run.out, dir)?;
            result.j
        } else {
            let l = supervise::Launch {
                dir: dir.to_path_buf(),
                // The learner process reads (and checks) the checkpoint again itself.
                resume: resume.is_some(),
                worker_protocol: launch.worker_protocol_version,
                max_restarts: 20,
            };
            let outcome = supervise::supervise(&l, |v| {
                if let Ok(p) = serde_json::from_value::<metrics::ProgressLine>(v.clone()) {
                    bar.set_position(p.k + 1);
                    bar.set_message(format!("{label}{}", message(p.alpha, p.j_h, p.j, p.tps)));
                    live.record(&p);
                }
            })?;
            if let Some(bridge) = outcome.bridge {
                // The learner wrote the result; add what crossed hosts, for the record.
                let mut result = envpg_core::ResultFile::load(&run.out)
                    .with_context(|| format!("reading {} to add the bridge's traffic", run.out.display()))?;
                let details = result.details.get_or_insert_with(|| serde_json::json!({}));
                if let Some(d) = details.as_object_mut() {
                    d.insert("bridge".into(), bridge);
                }
                run_dir::save_result(&result, &run.out, dir)?;
            }
            outcome.done.as_ref().and_then(|d| d.get("J")).and_then(|j| j.as_f64())
        })
    };
    let j = train().map_err(|e| {
        bar.abandon();
        with_resume_hint(e, run, dir, pass.resume_dir)
    })?;
    bar.finish_and_clear();
    Ok(j)
}
