//! Table I as a set of independent jobs, for any environment with a model: Algorithm 1 and the
//! same-start oracle for every (column, seed), and the best-of-restarts oracle for every column.
//! A column is the instance with one environment parameter set to one value (`--vary
//! kappa=1,0.9`), or the instance as it is.
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
use envpg_core::{LoadedEnv, Registry, ResultFile};
use envpg_model::oracle::{OracleConfig, Strategy, run_oracle};
use serde::{Deserialize, Serialize};
use serde_json::Value;

use crate::ReportError;
use crate::summary::{Method, Row, Summary};

mod writeup;

use writeup::{preamble, table_figures};

/// Runs Algorithm 1 for one spec and writes its result file to `out` (atomically).
pub trait Alg1Runner: Sync {
    /// Trains `spec`; the result file is at `out` when this returns `Ok`.
    fn run(&self, spec: &RunSpec, out: &Path) -> Result<ResultFile, String>;
    /// How runs are executed, for the table's preamble.
    fn describe(&self) -> String;
}

/// Algorithm 1 in this process (the serial trainer of `envpg-ac`), on the environments of a
/// registry.
#[derive(Debug, Clone)]
pub struct InProcess(pub Registry);

impl Alg1Runner for InProcess {
    fn run(&self, spec: &RunSpec, out: &Path) -> Result<ResultFile, String> {
        let r = envpg_ac::trainer::train(spec, &self.0, |_| true).map_err(|e| e.to_string())?;
        r.save(out).map_err(|e| format!("{}: {e}", out.display()))?;
        Ok(r)
    }

    fn describe(&self) -> String {
        "Algorithm 1 in process (serial trainer)".into()
    }
}

/// One environment parameter over several values: the table's columns.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Vary {
    /// The parameter (a key of the instance's `params`).
    pub key: String,
    /// Its values, one column each.
    pub values: Vec<f64>,
}

/// Everything that defines a table.
#[derive(Debug, Clone)]
pub struct TablePlan {
    /// The environments known.
    pub registry: Registry,
    /// The instance (canonical form), with the parameters every column shares.
    pub instance: Value,
    /// The columns: one parameter over several values (None: one column, the instance).
    pub vary: Option<Vary>,
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
    instance: Value,
    vary: Option<Vary>,
    config: AcConfig,
    restarts: usize,
    oracle_seed: u64,
}

/// One run of the table (columns by index into [`TablePlan::columns`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Job {
    /// Algorithm 1 at (column, seed).
    Alg1 {
        /// Column.
        col: usize,
        /// Seed.
        seed: u64,
    },
    /// The oracle warm-started from Algorithm 1's ζ₀ of `seed`, over the same α range.
    SameStart {
        /// Column.
        col: usize,
        /// Seed.
        seed: u64,
    },
    /// The oracle's best of its restarts in a column.
    Best {
        /// Column.
        col: usize,
    },
}

/// One column of a table: its label, file-name tag and environment.
#[derive(Debug, Clone)]
pub struct TableColumn {
    /// `kappa = 0.9`, or the instance's name.
    pub label: String,
    /// `kappa0.9`, or `base`: the part of the column's file names.
    pub tag: String,
    /// The environment of the column.
    pub env: LoadedEnv,
}

impl Job {
    /// The table row the job fills.
    pub fn method(&self) -> Method {
        match self {
            Job::Alg1 { .. } => Method::Algorithm1,
            Job::SameStart { .. } => Method::OracleSameStart,
            Job::Best { .. } => Method::OracleBest,
        }
    }

    /// The column of the job.
    pub fn col(&self) -> usize {
        match *self {
            Job::Alg1 { col, .. } | Job::SameStart { col, .. } | Job::Best { col } => col,
        }
    }

    /// The result file's name in the table directory.
    pub fn file(&self, columns: &[TableColumn]) -> String {
        let tag = &columns[self.col()].tag;
        match self {
            Job::Alg1 { seed, .. } => format!("runs/algorithm1_{tag}_s{seed}.json"),
            Job::SameStart { seed, .. } => format!("runs/oracle-same-start_{tag}_s{seed}.json"),
            Job::Best { .. } => format!("runs/oracle-best_{tag}.json"),
        }
    }

    /// The job in words.
    pub fn describe(&self, columns: &[TableColumn]) -> String {
        let label = &columns[self.col()].label;
        match self {
            Job::Alg1 { seed, .. } => format!("Algorithm 1, {label}, seed {seed}"),
            Job::SameStart { seed, .. } => format!("oracle from seed {seed}'s ζ₀, {label}"),
            Job::Best { .. } => format!("oracle best of restarts, {label}"),
        }
    }
}

/// What happened to one job, for progress reporting.
#[derive(Debug, Clone)]
pub struct JobReport {
    /// The job, in words.
    pub job: String,
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
    /// The columns: the instance with the varied parameter at each value (each built and
    /// checked by the registry), or the instance itself.
    pub fn columns(&self) -> Result<Vec<TableColumn>, ReportError> {
        let bad = |m: String| ReportError::Plan(m);
        let base = self.registry.from_value(&self.instance, "<table instance>").map_err(|e| bad(e.to_string()))?;
        let Some(vary) = &self.vary else {
            return Ok(vec![TableColumn { label: base.title.clone(), tag: "base".into(), env: base }]);
        };
        if base.param(&vary.key).is_none() {
            return Err(bad(format!(
                "--vary {}: environment `{}` has no parameter {:?} (its parameters: {})",
                vary.key,
                base.name,
                vary.key,
                base.params().keys().cloned().collect::<Vec<_>>().join(", ")
            )));
        }
        vary.values
            .iter()
            .map(|&v| {
                let mut inst = self.instance.clone();
                inst["params"][vary.key.as_str()] = v.into();
                let env = self
                    .registry
                    .from_value(&inst, "<table instance>")
                    .map_err(|e| bad(format!("--vary {} = {v}: {e}", vary.key)))?;
                Ok(TableColumn { label: format!("{} = {v}", vary.key), tag: format!("{}{v}", vary.key), env })
            })
            .collect()
    }

    /// Checks the plan (and builds its columns).
    pub fn validate(&self) -> Result<Vec<TableColumn>, ReportError> {
        let bad = |m: String| Err(ReportError::Plan(m));
        if self.seeds.is_empty() {
            return bad("the table needs at least one seed".into());
        }
        if let Some(v) = &self.vary {
            if v.values.is_empty() {
                return bad(format!("--vary {}: no values", v.key));
            }
            if has_duplicates(&v.values) {
                return bad(format!("--vary {}: values must be distinct", v.key));
            }
        }
        if has_duplicates(&self.seeds) {
            return bad("seeds must be distinct".into());
        }
        if self.restarts == 0 || self.jobs == 0 || self.window == 0 {
            return bad("restarts, jobs and the window must be at least 1".into());
        }
        if !(self.basin_tol.is_finite() && self.basin_tol >= 0.0) {
            return bad(format!("the basin tolerance must be finite and >= 0, got {}", self.basin_tol));
        }
        self.config.validate().map_err(|e| ReportError::Plan(e.to_string()))?;
        let columns = self.columns()?;
        for c in &columns {
            c.env.model().map_err(|e| ReportError::Plan(format!("the table's oracle rows: {e}")))?;
            for &seed in &self.seeds {
                initial_design(c.env.sampler(), &self.config.zeta0, seed)
                    .map_err(|e| ReportError::Plan(format!("{}: {e}", c.label)))?;
            }
        }
        Ok(columns)
    }

    /// Every job, longest first (the last column usually trains longest), so parallel runs
    /// finish together.
    pub fn jobs(&self, columns: &[TableColumn]) -> Vec<Job> {
        let cols: Vec<usize> = (0..columns.len()).rev().collect();
        let mut jobs = Vec::new();
        for &col in &cols {
            jobs.extend(self.seeds.iter().map(|&seed| Job::Alg1 { col, seed }));
        }
        jobs.extend(cols.iter().map(|&col| Job::Best { col }));
        for &col in &cols {
            jobs.extend(self.seeds.iter().map(|&seed| Job::SameStart { col, seed }));
        }
        jobs
    }

    fn recorded(&self) -> Recorded {
        Recorded {
            instance: self.instance.clone(),
            vary: self.vary.clone(),
            config: self.config.clone(),
            restarts: self.restarts,
            oracle_seed: self.oracle_seed,
        }
    }

    /// Oracle settings of a job: same start = one warm restart from the seed's ζ₀ over
    /// Algorithm 1's α range (in the column's units, when the settings are scale-free); best =
    /// the default restarts.
    fn oracle_config(&self, env: &LoadedEnv, job: Job) -> Result<OracleConfig, String> {
        let model = env.model().map_err(|e| e.to_string())?;
        let mut cfg = OracleConfig::for_env(model);
        if self.jobs > 1 {
            cfg.threads = 1;
        }
        match job {
            Job::SameStart { seed, .. } => {
                cfg.restarts = 1;
                cfg.seed = seed;
                cfg.strategy = Strategy::Warm;
                cfg.init = Some(initial_design(env.sampler(), &self.config.zeta0, seed)?);
                let abs = self.config.resolve(env.sampler());
                cfg.warm_alpha0 = abs.alpha0;
                cfg.alpha_min = abs.alpha_final;
            }
            Job::Best { .. } => {
                cfg.restarts = self.restarts;
                cfg.seed = self.oracle_seed;
            }
            Job::Alg1 { .. } => unreachable!("not an oracle job"),
        }
        cfg.validate(model).map_err(|e| e.to_string())?;
        Ok(cfg)
    }

    /// Whether an existing result file is this job's.
    fn matches(&self, job: Job, column: &TableColumn, r: &ResultFile) -> bool {
        let common = r.instance == column.env.instance;
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
                    && initial_design(column.env.sampler(), &self.config.zeta0, seed).is_ok_and(|z| z == r.zeta0)
            }
            Job::Best { .. } => common && r.method == "oracle" && r.seed == self.oracle_seed,
        }
    }
}

fn has_duplicates<T: PartialEq>(xs: &[T]) -> bool {
    xs.iter().enumerate().any(|(i, x)| xs[..i].contains(x))
}

fn run_job(
    plan: &TablePlan,
    job: Job,
    column: &TableColumn,
    runner: &dyn Alg1Runner,
    path: &Path,
) -> Result<ResultFile, String> {
    match job {
        Job::Alg1 { seed, .. } => runner.run(&RunSpec::new(&column.env, seed, plan.config.clone()), path),
        Job::SameStart { .. } | Job::Best { .. } => {
            let cfg = plan.oracle_config(&column.env, job)?;
            let model = column.env.model().map_err(|e| e.to_string())?;
            let out = run_oracle(model, &cfg).map_err(|e| e.to_string())?;
            let mut r = out.to_result(&column.env, &cfg).map_err(|e| e.to_string())?;
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
    let columns = plan.validate()?;
    let started = Instant::now();
    std::fs::create_dir_all(dir.join("runs")).map_err(|e| ReportError::io(dir, e))?;
    check_plan_file(plan, dir)?;
    let jobs = plan.jobs(&columns);
    let total = jobs.len();
    let results: Mutex<Vec<Option<Result<ResultFile, String>>>> = Mutex::new(vec![None; total]);
    let done = AtomicUsize::new(0);
    let mut pending = Vec::new();
    for (i, &job) in jobs.iter().enumerate() {
        let path = dir.join(job.file(&columns));
        let existing = path.is_file().then(|| ResultFile::load(&path)).transpose()?;
        match existing {
            Some(r) if plan.matches(job, &columns[job.col()], &r) => {
                let n = done.fetch_add(1, Ordering::SeqCst) + 1;
                let job = job.describe(&columns);
                on_job(&JobReport { job, done: n, total, outcome: Ok(r.j), skipped: true, seconds: 0.0 });
                results.lock().unwrap()[i] = Some(Ok(r));
            }
            Some(_) => {
                return Err(ReportError::Plan(format!(
                    "{} is not the run this table needs ({}); remove it or use another output directory",
                    path.display(),
                    job.describe(&columns)
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
                    let r = run_job(plan, job, &columns[job.col()], runner, &dir.join(job.file(&columns)));
                    let n = done.fetch_add(1, Ordering::SeqCst) + 1;
                    let outcome = r.as_ref().map(|r| r.j).map_err(Clone::clone);
                    let seconds = t.elapsed().as_secs_f64();
                    let job = job.describe(&columns);
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
                rows.push(Row::from_result(job.method(), job.col(), &r, &job.file(&columns)));
                files.push((*job, r));
            }
            Err(e) => failures.push(format!("{}: {e}", job.describe(&columns))),
        }
    }
    let summary = Summary {
        rows,
        columns: columns.iter().map(|c| c.label.clone()).collect(),
        seeds: plan.seeds.clone(),
        restarts: plan.restarts,
        basin_tol: plan.basin_tol,
        preamble: preamble(plan, &columns, runner, &files, started.elapsed().as_secs_f64()),
    };
    write(dir.join("table.md"), summary.markdown())?;
    write(dir.join("table.csv"), summary.csv())?;
    table_figures(plan, &columns, &files, dir)?;
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
                (old.vary != rec.vary, "columns"),
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
