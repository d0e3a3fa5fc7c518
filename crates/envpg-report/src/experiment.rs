//! Table I as a set of independent jobs: Algorithm 1 and the same-start oracle for every
//! (κ, seed), and the best-of-restarts oracle for every κ.
//!
//! Jobs run in parallel up to [`TablePlan::jobs`]; each writes its result file atomically, and
//! a job whose file is already there (and matches the plan) is not run again, so an
//! interrupted table resumes where it stopped. `plan.json` records the settings; a directory
//! holding a table made with other settings is refused rather than mixed.

use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

use envpg_ac::AcConfig;
use envpg_ac::trainer::RunSpec;
use envpg_ac::zeta0::initial_design;
use envpg_core::{Instance, ResultFile, UavNetwork};
use envpg_model::oracle::{OracleConfig, Strategy, run_oracle};
use serde::{Deserialize, Serialize};

use crate::summary::{Method, Row, Summary};
use crate::{ReportError, figures, stats};

/// Runs Algorithm 1 for one spec and writes its result file to `out` (atomically).
pub trait Alg1Runner: Sync {
    /// Trains `spec`; the result file is at `out` when this returns `Ok`.
    fn run(&self, spec: &RunSpec, out: &Path) -> Result<ResultFile, String>;
    /// How runs are executed, for the table's preamble.
    fn describe(&self) -> String;
}

/// Algorithm 1 in this process (the serial trainer of `envpg-ac`).
#[derive(Debug, Clone, Copy, Default)]
pub struct InProcess;

impl Alg1Runner for InProcess {
    fn run(&self, spec: &RunSpec, out: &Path) -> Result<ResultFile, String> {
        let r = envpg_ac::trainer::train(spec, |_| true).map_err(|e| e.to_string())?;
        r.save(out).map_err(|e| format!("{}: {e}", out.display()))?;
        Ok(r)
    }

    fn describe(&self) -> String {
        "Algorithm 1 in process (serial trainer)".into()
    }
}

/// Everything that defines a table.
#[derive(Debug, Clone)]
pub struct TablePlan {
    /// The instance.
    pub instance: Instance,
    /// η.
    pub eta: f64,
    /// κ columns.
    pub kappas: Vec<f64>,
    /// Seeds of Algorithm 1 (and of the same-start oracle).
    pub seeds: Vec<u64>,
    /// Algorithm 1 settings.
    pub config: AcConfig,
    /// Restarts of the best-of-restarts oracle.
    pub restarts: usize,
    /// Seed of the best-of-restarts oracle.
    pub oracle_seed: u64,
    /// Relative J tolerance for "reached the best basin".
    pub basin_tol: f64,
    /// Runs at once.
    pub jobs: usize,
    /// Moving-average window of the figures.
    pub window: usize,
    /// Extra lines for the table's preamble (command, machine).
    pub preamble: Vec<String>,
}

/// The part of a plan its results depend on (`plan.json`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
struct Recorded {
    instance: Instance,
    eta: f64,
    config: AcConfig,
    restarts: usize,
    oracle_seed: u64,
}

/// One run of the table.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Job {
    /// Algorithm 1 at (κ, seed).
    Alg1 {
        /// κ.
        kappa: f64,
        /// Seed.
        seed: u64,
    },
    /// The oracle warm-started from Algorithm 1's ζ₀ of `seed`, over the same α range.
    SameStart {
        /// κ.
        kappa: f64,
        /// Seed.
        seed: u64,
    },
    /// The oracle's best of its restarts at κ.
    Best {
        /// κ.
        kappa: f64,
    },
}

impl Job {
    /// The table column the job fills.
    pub fn method(&self) -> Method {
        match self {
            Job::Alg1 { .. } => Method::Algorithm1,
            Job::SameStart { .. } => Method::OracleSameStart,
            Job::Best { .. } => Method::OracleBest,
        }
    }

    /// κ of the job.
    pub fn kappa(&self) -> f64 {
        match *self {
            Job::Alg1 { kappa, .. } | Job::SameStart { kappa, .. } | Job::Best { kappa } => kappa,
        }
    }

    /// The result file's name in the table directory.
    pub fn file(&self) -> String {
        match self {
            Job::Alg1 { kappa, seed } => format!("runs/algorithm1_k{kappa}_s{seed}.json"),
            Job::SameStart { kappa, seed } => format!("runs/oracle-same-start_k{kappa}_s{seed}.json"),
            Job::Best { kappa } => format!("runs/oracle-best_k{kappa}.json"),
        }
    }
}

impl std::fmt::Display for Job {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Job::Alg1 { kappa, seed } => write!(f, "Algorithm 1, κ = {kappa}, seed {seed}"),
            Job::SameStart { kappa, seed } => write!(f, "oracle from seed {seed}'s ζ₀, κ = {kappa}"),
            Job::Best { kappa } => write!(f, "oracle best of restarts, κ = {kappa}"),
        }
    }
}

/// What happened to one job, for progress reporting.
#[derive(Debug, Clone)]
pub struct JobReport {
    /// The job.
    pub job: Job,
    /// Jobs finished so far (this one included).
    pub done: usize,
    /// All jobs.
    pub total: usize,
    /// J of the run, or why it failed.
    pub outcome: Result<Option<f64>, String>,
    /// The result file was already there.
    pub skipped: bool,
    /// Seconds the job took (0 when skipped).
    pub seconds: f64,
}

impl TablePlan {
    /// Checks the plan.
    pub fn validate(&self) -> Result<(), ReportError> {
        let bad = |m: String| Err(ReportError::Plan(m));
        if self.kappas.is_empty() || self.seeds.is_empty() {
            return bad("the table needs at least one κ and one seed".into());
        }
        for &k in &self.kappas {
            if !(k.is_finite() && k > 0.0 && k <= 1.0) {
                return bad(format!("κ must be in (0, 1], got {k}"));
            }
        }
        if has_duplicates(&self.kappas) || has_duplicates(&self.seeds) {
            return bad("κ values and seeds must be distinct".into());
        }
        if !(self.eta.is_finite() && self.eta >= 0.0) {
            return bad(format!("η must be finite and >= 0, got {}", self.eta));
        }
        if self.restarts == 0 || self.jobs == 0 || self.window == 0 {
            return bad("restarts, jobs and the window must be at least 1".into());
        }
        if !(self.basin_tol.is_finite() && self.basin_tol >= 0.0) {
            return bad(format!("the basin tolerance must be finite and >= 0, got {}", self.basin_tol));
        }
        self.config.validate().map_err(|e| ReportError::Plan(e.to_string()))
    }

    /// Every job, longest first (small κ trains longest), so parallel runs finish together.
    pub fn jobs(&self) -> Vec<Job> {
        let mut kappas = self.kappas.clone();
        kappas.sort_by(f64::total_cmp);
        let mut jobs = Vec::new();
        for &kappa in &kappas {
            jobs.extend(self.seeds.iter().map(|&seed| Job::Alg1 { kappa, seed }));
        }
        jobs.extend(kappas.iter().map(|&kappa| Job::Best { kappa }));
        for &kappa in &kappas {
            jobs.extend(self.seeds.iter().map(|&seed| Job::SameStart { kappa, seed }));
        }
        jobs
    }

    fn recorded(&self) -> Recorded {
        Recorded {
            instance: self.instance.clone(),
            eta: self.eta,
            config: self.config.clone(),
            restarts: self.restarts,
            oracle_seed: self.oracle_seed,
        }
    }

    /// The Algorithm 1 run spec of (κ, seed).
    pub fn spec(&self, kappa: f64, seed: u64) -> RunSpec {
        RunSpec { instance: self.instance.clone(), kappa, eta: self.eta, seed, config: self.config.clone() }
    }

    /// Oracle settings of a job: same start = one warm restart from the seed's ζ₀ over
    /// Algorithm 1's α range; best = the default restarts.
    fn oracle_config(&self, net: &UavNetwork, job: Job) -> Result<OracleConfig, String> {
        let mut cfg = OracleConfig::for_network(net);
        if self.jobs > 1 {
            cfg.threads = 1;
        }
        match job {
            Job::SameStart { seed, .. } => {
                cfg.restarts = 1;
                cfg.seed = seed;
                cfg.strategy = Strategy::Warm;
                cfg.init = Some(initial_design(&self.instance, &self.config.zeta0, seed)?);
                cfg.warm_alpha0 = self.config.alpha0;
                cfg.alpha_min = self.config.alpha_final;
            }
            Job::Best { .. } => {
                cfg.restarts = self.restarts;
                cfg.seed = self.oracle_seed;
            }
            Job::Alg1 { .. } => unreachable!("not an oracle job"),
        }
        cfg.validate(net).map_err(|e| e.to_string())?;
        Ok(cfg)
    }

    /// Whether an existing result file is this job's.
    fn matches(&self, job: Job, r: &ResultFile) -> bool {
        let common = r.instance == self.instance && r.kappa == job.kappa() && r.eta == self.eta;
        match job {
            Job::Alg1 { seed, .. } => {
                common
                    && r.method == "envpg-ac"
                    && r.seed == seed
                    && r.config.as_ref().and_then(|c| serde_json::from_value::<AcConfig>(c.clone()).ok()).as_ref()
                        == Some(&self.config)
            }
            Job::SameStart { seed, .. } => {
                common
                    && r.method == "oracle"
                    && r.seed == seed
                    && initial_design(&self.instance, &self.config.zeta0, seed).is_ok_and(|z| z == r.zeta0)
            }
            Job::Best { .. } => common && r.method == "oracle" && r.seed == self.oracle_seed,
        }
    }
}

fn has_duplicates<T: PartialEq>(xs: &[T]) -> bool {
    xs.iter().enumerate().any(|(i, x)| xs[..i].contains(x))
}

fn run_job(plan: &TablePlan, job: Job, runner: &dyn Alg1Runner, path: &Path) -> Result<ResultFile, String> {
    match job {
        Job::Alg1 { kappa, seed } => runner.run(&plan.spec(kappa, seed), path),
        Job::SameStart { kappa, .. } | Job::Best { kappa } => {
            let net = UavNetwork::new(plan.instance.clone(), kappa, plan.eta).map_err(|e| e.to_string())?;
            let cfg = plan.oracle_config(&net, job)?;
            let out = run_oracle(&net, &cfg).map_err(|e| e.to_string())?;
            let mut r = out.to_result(&net, &cfg).map_err(|e| e.to_string())?;
            if let Some(d) = r.details.as_mut().and_then(|d| d.as_object_mut()) {
                d.insert("table_role".into(), job.method().key().into());
            }
            r.save(path).map_err(|e| format!("{}: {e}", path.display()))?;
            Ok(r)
        }
    }
}

/// Runs (or resumes) the table in `dir`: every job, then `table.md`, `table.csv` and the
/// figures. `on_job` sees every job as it finishes (from worker threads). Runs that fail are
/// reported and left out; the error names them after everything else is written.
pub fn run_table(
    plan: &TablePlan,
    dir: &Path,
    runner: &dyn Alg1Runner,
    on_job: &(dyn Fn(&JobReport) + Sync),
) -> Result<Summary, ReportError> {
    plan.validate()?;
    let started = Instant::now();
    std::fs::create_dir_all(dir.join("runs")).map_err(|e| ReportError::io(dir, e))?;
    check_plan_file(plan, dir)?;
    let jobs = plan.jobs();
    let total = jobs.len();
    let results: Mutex<Vec<Option<Result<ResultFile, String>>>> = Mutex::new(vec![None; total]);
    let done = AtomicUsize::new(0);
    let mut pending = Vec::new();
    for (i, &job) in jobs.iter().enumerate() {
        let path = dir.join(job.file());
        let existing = path.is_file().then(|| ResultFile::load(&path)).transpose()?;
        match existing {
            Some(r) if plan.matches(job, &r) => {
                let n = done.fetch_add(1, Ordering::SeqCst) + 1;
                on_job(&JobReport { job, done: n, total, outcome: Ok(r.j), skipped: true, seconds: 0.0 });
                results.lock().unwrap()[i] = Some(Ok(r));
            }
            Some(_) => {
                return Err(ReportError::Plan(format!(
                    "{} is not the run this table needs ({job}); remove it or use another output directory",
                    path.display()
                )));
            }
            None => pending.push(i),
        }
    }
    let next = AtomicUsize::new(0);
    std::thread::scope(|scope| {
        for _ in 0..plan.jobs.min(pending.len()) {
            scope.spawn(|| {
                while let Some(&i) = pending.get(next.fetch_add(1, Ordering::SeqCst)) {
                    let job = jobs[i];
                    let t = Instant::now();
                    let r = run_job(plan, job, runner, &dir.join(job.file()));
                    let n = done.fetch_add(1, Ordering::SeqCst) + 1;
                    let outcome = r.as_ref().map(|r| r.j).map_err(Clone::clone);
                    let seconds = t.elapsed().as_secs_f64();
                    on_job(&JobReport { job, done: n, total, outcome, skipped: false, seconds });
                    results.lock().unwrap()[i] = Some(r);
                }
            });
        }
    });
    let results = results.into_inner().unwrap();
    let mut rows = Vec::new();
    let mut files: Vec<(Job, ResultFile)> = Vec::new();
    let mut failures = Vec::new();
    for (job, r) in jobs.iter().zip(results) {
        match r.expect("every job ran") {
            Ok(r) => {
                rows.push(Row::from_result(job.method(), &r, &job.file()));
                files.push((*job, r));
            }
            Err(e) => failures.push(format!("{job}: {e}")),
        }
    }
    let summary = Summary {
        rows,
        kappas: plan.kappas.clone(),
        seeds: plan.seeds.clone(),
        restarts: plan.restarts,
        basin_tol: plan.basin_tol,
        preamble: preamble(plan, runner, &files, started.elapsed().as_secs_f64()),
    };
    write(dir.join("table.md"), summary.markdown())?;
    write(dir.join("table.csv"), summary.csv())?;
    table_figures(plan, &files, dir)?;
    if let Some(first) = failures.first() {
        return Err(ReportError::Runs { failed: failures.len(), total, first: first.clone() });
    }
    Ok(summary)
}

fn write(path: PathBuf, text: String) -> Result<(), ReportError> {
    envpg_core::io::write_atomic(&path, text.as_bytes()).map_err(|e| ReportError::io(path, e))
}

fn check_plan_file(plan: &TablePlan, dir: &Path) -> Result<(), ReportError> {
    let path = dir.join("plan.json");
    let rec = plan.recorded();
    if path.is_file() {
        let text = std::fs::read_to_string(&path).map_err(|e| ReportError::io(&path, e))?;
        let old: Recorded = serde_json::from_str(&text)
            .map_err(|e| ReportError::Plan(format!("{}: not a table plan ({e})", path.display())))?;
        if old != rec {
            let what = [
                (old.instance != rec.instance, "instance"),
                (old.eta != rec.eta, "η"),
                (old.config != rec.config, "Algorithm 1 settings"),
                (old.restarts != rec.restarts || old.oracle_seed != rec.oracle_seed, "oracle settings"),
            ]
            .iter()
            .filter(|(d, _)| *d)
            .map(|(_, n)| *n)
            .collect::<Vec<_>>()
            .join(", ");
            return Err(ReportError::Plan(format!(
                "{} holds a table made with other settings (differs in: {what}); use another output directory",
                dir.display()
            )));
        }
    }
    let text = serde_json::to_string_pretty(&rec).expect("plan serializes");
    write(path, text)
}

fn preamble(plan: &TablePlan, runner: &dyn Alg1Runner, files: &[(Job, ResultFile)], wall: f64) -> Vec<String> {
    let c = &plan.config;
    let compute: f64 = files.iter().filter_map(|(_, r)| r.seconds).sum();
    let seeds = plan.seeds.iter().map(u64::to_string).collect::<Vec<_>>().join(", ");
    let mut lines = vec![
        format!(
            "Instance `{}` ({} users, {} UAVs), η = {}, seeds {seeds}.",
            plan.instance.name,
            plan.instance.n_users(),
            plan.instance.n_uav,
            plan.eta
        ),
        format!(
            "Algorithm 1: {} iterations × {} episodes (+{} exploration), σ = {}, α {} → {}, estimator {:?}{}; {}.",
            c.iterations,
            c.episodes,
            c.explore_episodes,
            if c.sigma_anneal == 1.0 {
                c.sigma.to_string()
            } else {
                format!("{} → {}", c.sigma, c.sigma * c.sigma_anneal)
            },
            c.alpha0,
            c.alpha_final,
            c.zeta_estimator,
            if c.polish_iterations > 0 {
                format!(
                    ", then ζ polish: {} iterations × {} episodes, {} routing rounds, best of {} starts \
                     (spread {}, {} screening iterations each)",
                    c.polish_iterations,
                    c.polish_episodes,
                    c.polish_routing,
                    c.polish_candidates,
                    c.polish_spread,
                    c.polish_screen
                )
            } else {
                String::new()
            },
            runner.describe()
        ),
        format!(
            "Oracle: same ζ₀ = one warm restart from each seed's ζ₀ over α {} → {}; best = {} restarts (seed {}).",
            c.alpha0, c.alpha_final, plan.restarts, plan.oracle_seed
        ),
        format!(
            "Run time: {:.0} s of runs, this invocation {:.0} s wall with {} parallel jobs.",
            compute, wall, plan.jobs
        ),
    ];
    lines.extend(plan.preamble.iter().cloned());
    lines
}

/// The table's figures: placements (Algorithm 1's median seed above the best oracle, one
/// column per κ), gradient norm and learning curves of every seed, and the median seeds' ζ
/// trajectories.
fn table_figures(plan: &TablePlan, files: &[(Job, ResultFile)], dir: &Path) -> Result<Vec<PathBuf>, ReportError> {
    let mut kappas = plan.kappas.clone();
    kappas.sort_by(|a, b| b.total_cmp(a));
    let alg1: Vec<&ResultFile> =
        files.iter().filter(|(j, r)| matches!(j, Job::Alg1 { .. }) && r.j.is_some()).map(|(_, r)| r).collect();
    let best: Vec<(f64, &ResultFile)> =
        files.iter().filter(|(j, _)| matches!(j, Job::Best { .. })).map(|(j, r)| (j.kappa(), r)).collect();
    let median: Vec<Option<&ResultFile>> = kappas
        .iter()
        .map(|&k| {
            let at: Vec<&ResultFile> = alg1.iter().copied().filter(|r| r.kappa == k).collect();
            let js: Vec<f64> = at.iter().map(|r| r.j.unwrap_or(f64::INFINITY)).collect();
            stats::median_index(&js).map(|i| at[i])
        })
        .collect();
    let titles_alg1: Vec<String> =
        median.iter().map(|r| r.map(|r| format!("{} (median seed)", figures::title(r))).unwrap_or_default()).collect();
    let titles_best: Vec<String> = kappas
        .iter()
        .map(|k| {
            best.iter()
                .find(|(bk, _)| bk == k)
                .map(|(_, r)| {
                    format!("Oracle · κ = {k} · best of {} · J = {:.3}", plan.restarts, r.j.unwrap_or(f64::NAN))
                })
                .unwrap_or_default()
        })
        .collect();
    let mut cells = Vec::new();
    for (r, t) in median.iter().zip(&titles_alg1) {
        cells.push(r.map(|r| figures::Panel { result: r, title: t }));
    }
    for (k, t) in kappas.iter().zip(&titles_best) {
        cells.push(best.iter().find(|(bk, _)| bk == k).map(|(_, r)| figures::Panel { result: r, title: t }));
    }
    let mut out = figures::placements(&cells, kappas.len(), dir, "placements")?;
    if !alg1.is_empty() {
        out.extend(figures::grad_norm(&alg1, plan.window, dir, "grad_norm")?);
        out.extend(figures::learning_curves(&alg1, &best, plan.window, dir, "learning_curves")?);
        let panels: Vec<figures::Panel> = median
            .iter()
            .zip(&titles_alg1)
            .filter_map(|(r, t)| Some(figures::Panel { result: (*r)?, title: t }))
            .collect();
        let designs: Vec<&ResultFile> = best.iter().map(|(_, r)| *r).collect();
        out.extend(figures::trajectories(&panels, &designs, dir, "trajectories")?);
    }
    Ok(out)
}
