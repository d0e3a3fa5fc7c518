//! Sensitivity sweeps: one setting over a list of values × seeds.
//!
//! Each (value, seed) trains Algorithm 1 to the end (final J) and, separately, runs the
//! estimator study of `envpg-ac` at a fixed point of the same run (trained for a fraction of
//! the iterations, then frozen): the spread and bias of every ζ-gradient estimator against the
//! exact gradient of the frozen policy, which the model computes for reporting only. Writes
//! `sweep.md`, `sweep.csv`, `sweep.svg/png` and every run's files under `runs/`.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};

use envpg_ac::study::{Study, estimator_study};
use envpg_ac::trainer::RunSpec;
use envpg_ac::{AcConfig, ZetaEstimator};
use envpg_core::{Registry, ResultFile};
use serde_json::Value;

use crate::stats::{mean, mean_std};
use crate::{Alg1Runner, ReportError, figures};

/// A sweep.
#[derive(Debug, Clone)]
pub struct SweepPlan {
    /// The environments known.
    pub registry: Registry,
    /// The instance (canonical form), with every parameter but a swept one.
    pub instance: Value,
    /// Seeds per value.
    pub seeds: Vec<u64>,
    /// Base settings.
    pub config: AcConfig,
    /// The swept setting: a parameter of the instance's environment (`kappa`, `deviation`, …)
    /// or any Algorithm 1 setting.
    pub param: String,
    /// Its values, as text (as in a preset file).
    pub values: Vec<String>,
    /// The study freezes the run after this fraction of its iterations.
    pub study_at: f64,
    /// Independent batches per estimator in the study.
    pub study_samples: usize,
    /// Runs at once.
    pub jobs: usize,
    /// Extra lines for the preamble.
    pub preamble: Vec<String>,
}

/// One (value, seed) of a sweep.
#[derive(Debug, Clone)]
pub struct SweepRow {
    /// The value, as given.
    pub value: String,
    /// Seed.
    pub seed: u64,
    /// Final exact J (None: no proper final policy).
    pub j: Option<f64>,
    /// Final exact J_H.
    pub j_h: Option<f64>,
    /// Seconds of the training run.
    pub seconds: Option<f64>,
    /// The estimator the run used.
    pub estimator: ZetaEstimator,
    /// The study at the frozen point.
    pub study: Study,
    /// The run's result file, relative to the sweep directory.
    pub file: String,
}

impl SweepRow {
    /// Study statistics of `kind`.
    pub fn of(&self, kind: ZetaEstimator) -> Option<&envpg_ac::study::EstimatorStats> {
        self.study.estimators.iter().find(|e| e.estimator == kind)
    }
}

/// Every estimator, in the order of the CSV columns.
pub const KINDS: [ZetaEstimator; 4] =
    [ZetaEstimator::Sampled, ZetaEstimator::Baseline, ZetaEstimator::Expected, ZetaEstimator::Corollary];

/// The estimator's name as in settings.
pub fn kind_name(k: ZetaEstimator) -> &'static str {
    match k {
        ZetaEstimator::Sampled => "sampled",
        ZetaEstimator::Baseline => "baseline",
        ZetaEstimator::Expected => "expected",
        ZetaEstimator::Corollary => "corollary",
    }
}

fn file_safe(s: &str) -> String {
    s.chars().map(|c| if c.is_ascii_alphanumeric() || matches!(c, '.' | '-' | '_') { c } else { '_' }).collect()
}

impl SweepPlan {
    /// Whether the swept setting is a parameter of the environment (else of Algorithm 1).
    fn sweeps_env(&self) -> bool {
        self.instance.get("params").and_then(|p| p.get(&self.param)).is_some()
    }

    /// The run spec of (value, seed), validated.
    pub fn spec(&self, value: &str, seed: u64) -> Result<RunSpec, ReportError> {
        let bad = |m: String| ReportError::Plan(m);
        let mut instance: Value = self.instance.clone();
        let mut config = self.config.clone();
        if self.sweeps_env() {
            let x = value
                .trim()
                .parse::<f64>()
                .map_err(|e| bad(format!("--values: {} value {value:?}: {e}", self.param)))?;
            instance["params"][self.param.as_str()] = x.into();
        } else {
            config = config.set(&self.param, value).map_err(|e| bad(e.to_string()))?;
        }
        let env = self.registry.from_value(&instance, "<sweep instance>").map_err(|e| bad(e.to_string()))?;
        env.model().map_err(|e| bad(format!("the sweep's estimator study: {e}")))?;
        Ok(RunSpec::new(&env, seed, config))
    }

    /// Checks the plan, including every value.
    pub fn validate(&self) -> Result<(), ReportError> {
        let bad = |m: String| Err(ReportError::Plan(m));
        if self.values.is_empty() || self.seeds.is_empty() {
            return bad("a sweep needs at least one value and one seed".into());
        }
        if !(self.study_at.is_finite() && (0.0..=1.0).contains(&self.study_at)) {
            return bad(format!("the study point must be a fraction in [0, 1], got {}", self.study_at));
        }
        if self.study_samples < 2 || self.jobs == 0 {
            return bad("the study needs at least 2 samples and 1 job".into());
        }
        for v in &self.values {
            self.spec(v, self.seeds[0])?;
        }
        Ok(())
    }

    fn stem(&self, value: &str, seed: u64) -> String {
        format!("runs/{}={}_s{seed}", file_safe(&self.param), file_safe(value))
    }
}

fn run_one(plan: &SweepPlan, runner: &dyn Alg1Runner, dir: &Path, value: &str, seed: u64) -> Result<SweepRow, String> {
    let spec = plan.spec(value, seed).map_err(|e| e.to_string())?;
    let stem = plan.stem(value, seed);
    let result_path = dir.join(format!("{stem}.json"));
    let study_path = dir.join(format!("{stem}.study.json"));
    let existing = result_path
        .is_file()
        .then(|| ResultFile::load(&result_path).ok())
        .flatten()
        .filter(|r| r.seed == seed && r.instance == spec.instance)
        .filter(|r| {
            r.config.as_ref().and_then(|c| serde_json::from_value::<AcConfig>(c.clone()).ok())
                == Some(spec.config.clone())
        });
    // A study belongs to its run: it is read back only beside a run that was (same settings,
    // same study point and size), never beside one made afresh.
    let reused = existing.is_some();
    let result = match existing {
        Some(r) => r,
        None => runner.run(&spec, &result_path)?,
    };
    let train = (plan.study_at * spec.config.iterations as f64).round() as usize;
    let kept = if reused {
        std::fs::read_to_string(&study_path).ok().and_then(|t| serde_json::from_str::<Study>(&t).ok())
    } else {
        None
    };
    let study = match kept {
        Some(s) if s.samples == plan.study_samples && s.trained == train => s,
        _ => {
            let s = estimator_study(&spec, &plan.registry, train, plan.study_samples).map_err(|e| e.to_string())?;
            let text = serde_json::to_string_pretty(&s).expect("study serializes");
            envpg_core::io::write_atomic(&study_path, text.as_bytes())
                .map_err(|e| format!("{}: {e}", study_path.display()))?;
            s
        }
    };
    Ok(SweepRow {
        value: value.to_owned(),
        seed,
        j: result.j,
        j_h: result.j_h,
        seconds: result.seconds,
        estimator: spec.config.zeta_estimator,
        study,
        file: format!("{stem}.json"),
    })
}

/// Progress callback of [`run_sweep`]: (finished, total, value, seed, outcome).
pub type OnRun<'a> = dyn Fn(usize, usize, &str, u64, &Result<SweepRow, String>) + Sync + 'a;

/// Runs (or resumes: finished runs and studies are read back) the sweep in `dir` and writes
/// its table, CSV and figure. `on_run` sees each (value, seed) as it finishes.
pub fn run_sweep(
    plan: &SweepPlan,
    dir: &Path,
    runner: &dyn Alg1Runner,
    on_run: &OnRun<'_>,
) -> Result<Vec<SweepRow>, ReportError> {
    plan.validate()?;
    std::fs::create_dir_all(dir.join("runs")).map_err(|e| ReportError::io(dir, e))?;
    let work: Vec<(&str, u64)> =
        plan.values.iter().flat_map(|v| plan.seeds.iter().map(move |&s| (v.as_str(), s))).collect();
    let out: Mutex<Vec<Option<Result<SweepRow, String>>>> = Mutex::new(vec![None; work.len()]);
    let next = AtomicUsize::new(0);
    let done = AtomicUsize::new(0);
    std::thread::scope(|scope| {
        for _ in 0..plan.jobs.min(work.len()) {
            scope.spawn(|| {
                loop {
                    let i = next.fetch_add(1, Ordering::SeqCst);
                    let Some(&(value, seed)) = work.get(i) else { break };
                    let r = run_one(plan, runner, dir, value, seed);
                    let n = done.fetch_add(1, Ordering::SeqCst) + 1;
                    on_run(n, work.len(), value, seed, &r);
                    out.lock().unwrap()[i] = Some(r);
                }
            });
        }
    });
    let mut rows = Vec::new();
    let mut failures = Vec::new();
    for ((value, seed), r) in work.iter().zip(out.into_inner().unwrap()) {
        match r.expect("every run ran") {
            Ok(row) => rows.push(row),
            Err(e) => failures.push(format!("{} = {value}, seed {seed}: {e}", plan.param)),
        }
    }
    let write = |name: &str, text: String| {
        let path = dir.join(name);
        envpg_core::io::write_atomic(&path, text.as_bytes()).map_err(|e| ReportError::io(path, e))
    };
    write("sweep.md", markdown(plan, &rows))?;
    write("sweep.csv", csv(plan, &rows))?;
    figures::sweep(&plan.param, &plan.values, &rows, dir, "sweep")?;
    if let Some(first) = failures.first() {
        return Err(ReportError::Runs { failed: failures.len(), total: work.len(), first: first.clone() });
    }
    Ok(rows)
}

/// `sweep.csv`: one row per (value, seed), with every estimator's variance and bias.
pub fn csv(plan: &SweepPlan, rows: &[SweepRow]) -> String {
    let mut s = String::from("param,value,seed,J,J_H,seconds,estimator,variance,rel_bias,cos_exact");
    for k in KINDS {
        let n = kind_name(k);
        let _ = write!(s, ",variance_{n},rel_bias_{n}");
    }
    s += ",critic_error_fixed_states,critic_error_design_states,critic_value_rmse,file\n";
    let f = |x: Option<f64>| x.map_or(String::new(), |x| format!("{x}"));
    for r in rows {
        let own = r.of(r.estimator);
        let _ = write!(
            s,
            "{},{},{},{},{},{},{},{},{},{}",
            plan.param,
            r.value,
            r.seed,
            f(r.j),
            f(r.j_h),
            r.seconds.map_or(String::new(), |x| format!("{x:.2}")),
            kind_name(r.estimator),
            f(own.map(|e| e.variance)),
            f(own.map(|e| e.rel_bias)),
            f(own.map(|e| e.cos_exact))
        );
        for k in KINDS {
            let e = r.of(k);
            let _ = write!(s, ",{},{}", f(e.map(|e| e.variance)), f(e.map(|e| e.rel_bias)));
        }
        let audit = r.study.critic.as_ref();
        let _ = write!(
            s,
            ",{},{},{}",
            f(audit.map(|a| a.fixed_states.rel_error)),
            f(audit.map(|a| a.design_states.rel_error)),
            f(audit.map(|a| a.value_rmse))
        );
        let _ = writeln!(s, ",{}", r.file);
    }
    s
}

/// Per value: the final J values and the rows at that value.
pub fn per_value<'a>(values: &'a [String], rows: &'a [SweepRow]) -> Vec<(&'a str, Vec<f64>, Vec<&'a SweepRow>)> {
    values
        .iter()
        .map(|v| {
            let at: Vec<&SweepRow> = rows.iter().filter(|r| &r.value == v).collect();
            (v.as_str(), at.iter().filter_map(|r| r.j).collect(), at)
        })
        .collect()
}

/// `sweep.md`.
pub fn markdown(plan: &SweepPlan, rows: &[SweepRow]) -> String {
    let mut s = format!("# Sweep of `{}`\n\n", plan.param);
    let seeds = plan.seeds.iter().map(u64::to_string).collect::<Vec<_>>().join(", ");
    let name = plan.instance.get("name").and_then(Value::as_str).unwrap_or("?");
    let env = plan.instance.get("env").and_then(Value::as_str).unwrap_or("?");
    let params = plan
        .instance
        .get("params")
        .and_then(Value::as_object)
        .map(|p| {
            p.iter()
                .filter(|(k, _)| **k != plan.param)
                .map(|(k, v)| format!("{k} = {v}"))
                .collect::<Vec<_>>()
                .join(", ")
        })
        .unwrap_or_default();
    let _ = writeln!(
        s,
        "Instance `{name}` (environment `{env}`), {params}, seeds {seeds}. The study freezes each run after \
         {:.0}% of its iterations and draws {} independent batches; variance is the trace of one \
         estimate's covariance, bias is ‖mean − exact‖/‖exact‖ against the exact ∇ζJ_H of the frozen \
         policy (model, reporting only). The critic columns isolate the critic's share: \
         Σ ρπ ∇ζQ_φ against Σ ρπ ∇ζQ̄ with the exact visits ρ, as ‖difference‖/‖exact‖ over the \
         pairs at states away from the design elements (UAV network: the users) and at them (the \
         UAVs), and the visit-weighted RMS error of Q_φ's values.  ",
        100.0 * plan.study_at,
        plan.study_samples
    );
    for line in &plan.preamble {
        let _ = writeln!(s, "{line}  ");
    }
    let _ = writeln!(
        s,
        "\n| {} | final J (mean ± std) | estimator | variance | rel. bias | cos(exact) | variance sampled | \
         variance baseline | critic error, other states | critic error, design states | critic value RMSE |",
        plan.param
    );
    s += "|---|---|---|---|---|---|---|---|---|---|---|\n";
    let m = |v: Vec<f64>| if v.is_empty() { "–".to_string() } else { format!("{:.4}", mean(&v)) };
    for (value, js, at) in per_value(&plan.values, rows) {
        // A run whose greedy policy never reaches the destination has J = ∞; leaving it out of
        // the mean would flatter the value, so the mean is ∞ and the finite runs are shown apart.
        let improper = at.len() - js.len();
        let j = match (improper, js.is_empty()) {
            (0, true) => "–".into(),
            (0, false) => mean_std(&js),
            (n, true) => format!("∞ ({n} of {n} runs improper)"),
            (n, false) => {
                format!("∞ ({n} of {} runs improper; others {})", at.len(), mean_std(&js))
            }
        };
        let est = at.first().map_or("–", |r| kind_name(r.estimator));
        type Stat = fn(&envpg_ac::study::EstimatorStats) -> f64;
        let own = |f: Stat| m(at.iter().filter_map(|r| r.of(r.estimator).map(f)).collect());
        let kind =
            |k, f: fn(&envpg_ac::study::EstimatorStats) -> f64| m(at.iter().filter_map(|r| r.of(k).map(f)).collect());
        type Audit = fn(&envpg_ac::study::CriticAudit) -> f64;
        let audit = |f: Audit| m(at.iter().filter_map(|r| r.study.critic.as_ref().map(f)).collect());
        let _ = writeln!(
            s,
            "| {value} | {j} | {est} | {} | {} | {} | {} | {} | {} | {} | {} |",
            own(|e| e.variance),
            own(|e| e.rel_bias),
            own(|e| e.cos_exact),
            kind(ZetaEstimator::Sampled, |e| e.variance),
            kind(ZetaEstimator::Baseline, |e| e.variance),
            audit(|a| a.fixed_states.rel_error),
            audit(|a| a.design_states.rel_error),
            audit(|a| a.value_rmse),
        );
    }
    s
}

/// The files a sweep writes besides its runs.
pub fn outputs(dir: &Path) -> Vec<PathBuf> {
    ["sweep.md", "sweep.csv", "sweep.svg", "sweep.png"].iter().map(|n| dir.join(n)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(value: &str, seed: u64, j: Option<f64>) -> SweepRow {
        let study = Study {
            trained: 1,
            samples: 1,
            exact: vec![],
            exact_fixed_policy: vec![],
            estimators: vec![],
            critic: None,
        };
        SweepRow {
            value: value.into(),
            seed,
            j,
            j_h: j,
            seconds: None,
            estimator: ZetaEstimator::Corollary,
            study,
            file: String::new(),
        }
    }

    #[test]
    fn a_run_with_infinite_j_makes_the_mean_infinite_instead_of_being_dropped() {
        let registry = envpg_envs::registry();
        let instance = registry.load("uav271", &[]).unwrap().instance;
        let plan = SweepPlan {
            registry,
            instance,
            seeds: vec![1, 2],
            config: AcConfig::default(),
            param: "sigma".into(),
            values: vec!["0.1".into(), "0.3".into()],
            study_at: 0.5,
            study_samples: 1,
            jobs: 1,
            preamble: vec![],
        };
        let rows =
            [row("0.1", 1, Some(10.0)), row("0.1", 2, None), row("0.3", 1, Some(10.0)), row("0.3", 2, Some(12.0))];
        let md = markdown(&plan, &rows);
        let line = |v: &str| md.lines().find(|l| l.starts_with(&format!("| {v} |"))).expect("row").to_owned();
        assert!(line("0.1").contains("| ∞ (1 of 2 runs improper; others 10.0000 ± 0.0000) |"), "{md}");
        assert!(line("0.3").contains("| 11.0000 ± "), "{md}");
    }
}
