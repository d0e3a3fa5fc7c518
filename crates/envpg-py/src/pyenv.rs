//! [`PyEnv`]: an environment written in Python, registered as `python`.
//!
//! Its instance names the class and how to rebuild it — `{"env": "python", "name": …,
//! "class": "module:Qualname", "script": "/path/to/script.py" (for a class of a script run as
//! `__main__`), "config": {constructor keyword arguments}}` — so every process of a run (the
//! learner, each worker) imports the user's module and builds the same environment, and the
//! result file says exactly what was trained on.
//!
//! Sizes, bounds, valid actions and terminal states are read once when the environment is
//! built; `step`, `initial_state` and the model's `outcomes` call into Python with the GIL,
//! with envpg's per-(seed, iteration, episode) stream as a [`Rng`]. A Python exception or an
//! invalid return ends the run with the traceback ([`fail`]).

use std::sync::atomic::{AtomicBool, Ordering};

use envpg_core::{
    Env, EnvRng, EnvSpec, InstanceError, InstanceFile, ModelMdp, Outcomes, ParamMdp, ParamSpec, ZetaSpace,
};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};
use rand::RngExt;

/// Set in processes started by the launcher (learner, workers, tools): there a failing
/// environment ends the process; elsewhere (the user's interpreter) it unwinds to the call.
static ROLE_PROCESS: AtomicBool = AtomicBool::new(false);

/// Marks this process as one of a run's (see [`fail`]).
pub fn set_role_process() {
    ROLE_PROCESS.store(true, Ordering::Relaxed);
}

/// The payload of the unwinding [`fail`] raises in the user's interpreter, turned into
/// `envpg.EnvError` where the call entered Rust.
#[derive(Debug)]
pub struct EnvPanic(pub String);

/// Stops because the environment failed: in a run's process, the run stops with `message`
/// (`envpg_launch::abort_env`); in the user's interpreter, the call raises `envpg.EnvError`.
pub fn fail(message: String) -> ! {
    if ROLE_PROCESS.load(Ordering::Relaxed) {
        envpg_launch::abort_env(&message)
    }
    std::panic::panic_any(EnvPanic(message))
}

/// A Python exception as its traceback text.
pub fn traceback(py: Python<'_>, err: &PyErr) -> String {
    let formatted = py
        .import("traceback")
        .and_then(|tb| tb.call_method1("format_exception", (err.get_type(py), err.value(py), err.traceback(py))));
    match formatted.and_then(|lines| lines.extract::<Vec<String>>()) {
        Ok(lines) => lines.concat().trim_end().to_owned(),
        Err(_) => err.to_string(),
    }
}

/// One of envpg's random streams, lent to Python for the length of one call: `random()` is
/// Rust's `rng.random::<f64>()`, `integers(low, high)` its `rng.random_range(low..high)` over
/// `usize`, so a Python port of a Rust environment draws the same numbers.
#[pyclass(module = "envpg._native", name = "Rng")]
pub struct Rng {
    inner: Option<EnvRng>,
}

impl Rng {
    fn get(&mut self) -> PyResult<&mut EnvRng> {
        self.inner.as_mut().ok_or_else(|| {
            pyo3::exceptions::PyRuntimeError::new_err(
                "this rng was lent to one call of the environment and that call has returned",
            )
        })
    }
}

#[pymethods]
impl Rng {
    /// A float uniform in [0, 1).
    fn random(&mut self) -> PyResult<f64> {
        Ok(self.get()?.random::<f64>())
    }

    /// An integer uniform in [low, high), 0 ≤ low < high.
    fn integers(&mut self, low: usize, high: usize) -> PyResult<usize> {
        if low >= high {
            return Err(pyo3::exceptions::PyValueError::new_err(format!(
                "integers(low, high) needs low < high, got {low} and {high}"
            )));
        }
        Ok(self.get()?.random_range(low..high))
    }
}

/// Calls `f` with `rng` lent to Python as a [`Rng`], and takes it back.
fn with_rng<'py, T>(
    py: Python<'py>,
    rng: &mut EnvRng,
    f: impl FnOnce(&Bound<'py, Rng>) -> PyResult<T>,
) -> Result<T, String> {
    // Any stream holds the place while Python has the real one; a fixed key costs no mixing.
    let placeholder = <EnvRng as rand::SeedableRng>::from_seed([0; 32]);
    let lent = Bound::new(py, Rng { inner: Some(std::mem::replace(rng, placeholder)) }).map_err(|e| e.to_string())?;
    let out = f(&lent);
    *rng = lent.borrow_mut().inner.take().expect("the stream is taken back once");
    out.map_err(|e| traceback(py, &e))
}

/// An environment written in Python (see the module docs).
pub struct PyEnv {
    obj: Py<PyAny>,
    class: String,
    n_states: usize,
    n_actions: usize,
    space: ZetaSpace,
    gamma: f64,
    actions: Vec<Vec<usize>>,
    terminal: Vec<bool>,
    cost_scale: Option<f64>,
    exploring_start: bool,
    clustered_design: bool,
    initial_design: Option<Vec<f64>>,
    model: bool,
}

/// `obj.name`, called if it is a method; `None` if absent or `None`.
fn optional<'py>(obj: &Bound<'py, PyAny>, name: &str) -> PyResult<Option<Bound<'py, PyAny>>> {
    if !obj.hasattr(name)? {
        return Ok(None);
    }
    let v = obj.getattr(name)?;
    let v = if v.is_callable() { v.call0()? } else { v };
    Ok(if v.is_none() { None } else { Some(v) })
}

/// `obj.name`, required.
fn required<'py>(obj: &Bound<'py, PyAny>, name: &str) -> PyResult<Bound<'py, PyAny>> {
    optional(obj, name)?.ok_or_else(|| {
        pyo3::exceptions::PyAttributeError::new_err(format!("the environment has no `{name}` (see envpg.Env)"))
    })
}

/// The class `module:Qualname`, importing the module (or the script at `script`).
fn import_class<'py>(py: Python<'py>, class: &str, script: Option<&str>) -> PyResult<Bound<'py, PyAny>> {
    let (module, qualname) = class.split_once(':').ok_or_else(|| {
        pyo3::exceptions::PyValueError::new_err(format!("`{class}` is not of the form module:Qualname"))
    })?;
    let module = match script {
        Some(path) => py.import("envpg._pyenv")?.call_method1("import_script", (path,))?,
        None => py.import(module)?.into_any(),
    };
    let mut obj = module;
    for part in qualname.split('.') {
        obj = obj.getattr(part)?;
    }
    Ok(obj)
}

/// The most states (and actions) an environment may have: ids travel as `u32`.
const MAX_IDS: usize = u32::MAX as usize;

impl PyEnv {
    fn build(py: Python<'_>, class: &str, script: Option<&str>, config: &serde_json::Value) -> PyResult<Self> {
        let cls = import_class(py, class, script)?;
        let kwargs = py.import("json")?.call_method1("loads", (config.to_string(),))?;
        let obj = cls.call((), Some(kwargs.cast::<PyDict>()?))?;
        let n_states: usize = required(&obj, "n_states")?.extract()?;
        let n_actions: usize = required(&obj, "n_actions")?.extract()?;
        let value_error = |m: String| pyo3::exceptions::PyValueError::new_err(m);
        if n_states == 0 || n_actions == 0 {
            return Err(value_error(format!(
                "n_states and n_actions must be positive, got {n_states} and {n_actions}"
            )));
        }
        // Episodes carry states and actions as 32-bit ids; a larger count would wrap silently.
        if n_states > MAX_IDS || n_actions > MAX_IDS {
            return Err(value_error(format!(
                "n_states and n_actions must be at most {MAX_IDS} (episodes carry 32-bit ids), got {n_states} and \
                 {n_actions}"
            )));
        }
        let low: Option<Vec<f64>> = optional(&obj, "zeta_low")?.map(|v| v.extract()).transpose()?;
        let high: Option<Vec<f64>> = optional(&obj, "zeta_high")?.map(|v| v.extract()).transpose()?;
        let dim: Option<usize> = optional(&obj, "zeta_dim")?.map(|v| v.extract()).transpose()?;
        let (low, high) = match (low, high, dim) {
            (Some(l), Some(h), _) => (l, h),
            (None, None, Some(d)) => (vec![f64::NEG_INFINITY; d], vec![f64::INFINITY; d]),
            _ => return Err(value_error("give the design's bounds `zeta_low` and `zeta_high`, or `zeta_dim`".into())),
        };
        let names: Vec<String> = match optional(&obj, "zeta_names")? {
            Some(v) => v.extract()?,
            None => (0..low.len()).map(|i| format!("zeta{i}")).collect(),
        };
        let space = ZetaSpace::new(names, low, high).map_err(|e| value_error(format!("the design space: {e}")))?;
        let gamma: f64 = optional(&obj, "gamma")?.map(|v| v.extract()).transpose()?.unwrap_or(1.0);
        if !(gamma > 0.0 && gamma <= 1.0) {
            return Err(value_error(format!("gamma must be in (0, 1], got {gamma}")));
        }
        // Grown as the environment answers, not reserved up front: a mistaken n_states of
        // billions is then a slow loop the user can interrupt, not an allocation that aborts.
        let (mut actions, mut terminal) = (Vec::new(), Vec::new());
        for s in 0..n_states {
            if s % 4096 == 4095 {
                py.check_signals()?;
            }
            let t: bool = obj.call_method1("is_terminal", (s,))?.extract()?;
            let a: Vec<usize> = obj.call_method1("valid_actions", (s,))?.extract()?;
            if a.windows(2).any(|w| w[0] >= w[1]) || a.last().is_some_and(|&x| x >= n_actions) {
                return Err(value_error(format!(
                    "valid_actions({s}) = {a:?}: must be increasing global actions below n_actions = {n_actions}"
                )));
            }
            if t != a.is_empty() {
                return Err(value_error(format!(
                    "state {s}: valid_actions must be empty exactly for terminal states (is_terminal = {t}, {} actions)",
                    a.len()
                )));
            }
            actions.push(a);
            terminal.push(t);
        }
        let cost_scale: Option<f64> = optional(&obj, "cost_scale")?.map(|v| v.extract()).transpose()?;
        if let Some(c) = cost_scale
            && !(c.is_finite() && c > 0.0)
        {
            return Err(value_error(format!("cost_scale must be positive and finite, got {c}")));
        }
        let initial_design: Option<Vec<f64>> = optional(&obj, "initial_design")?.map(|v| v.extract()).transpose()?;
        if let Some(z) = &initial_design {
            space.check(z).map_err(|e| value_error(format!("initial_design: {e}")))?;
        }
        let callable = |name: &str| -> PyResult<bool> { Ok(obj.getattr(name).is_ok_and(|m| m.is_callable())) };
        let exploring_start = callable("exploring_start")?;
        let clustered_design = callable("clustered_design")?;
        let model = callable("outcomes")? && callable("initial_distribution")?;
        Ok(Self {
            obj: obj.unbind(),
            class: class.to_owned(),
            n_states,
            n_actions,
            space,
            gamma,
            actions,
            terminal,
            cost_scale,
            exploring_start,
            clustered_design,
            initial_design,
            model,
        })
    }

    /// A state returned by Python, checked.
    fn state(&self, what: &str, v: &Bound<'_, PyAny>) -> Result<usize, String> {
        match v.extract::<usize>() {
            Ok(s) if s < self.n_states => Ok(s),
            _ => Err(format!("{}.{what} returned {v}, not a state in 0..{}", self.class, self.n_states)),
        }
    }

    fn start(&self, method: &str, rng: &mut EnvRng) -> usize {
        Python::attach(|py| {
            let obj = self.obj.bind(py);
            let v = with_rng(py, rng, |r| obj.call_method1(method, (r,)))?;
            self.state(&format!("{method}(rng)"), &v)
        })
        .unwrap_or_else(|m| fail(m))
    }
}

impl EnvSpec for PyEnv {
    const NAME: &'static str = "python";
    const ABOUT: &'static str = "an environment written in Python (a class with the sampler methods, see envpg.Env)";

    fn params() -> Vec<ParamSpec> {
        Vec::new()
    }

    fn from_instance(file: &InstanceFile) -> Result<Self, InstanceError> {
        file.expect_fields(&["class", "script", "config"])?;
        let class: String = file.field("class")?;
        let script: Option<String> = file.optional_field("script")?;
        let config: serde_json::Value = file.optional_field("config")?.unwrap_or_else(|| serde_json::json!({}));
        if !config.is_object() {
            return Err(file.invalid("config", "must be an object of keyword arguments".into()));
        }
        Python::attach(|py| {
            Self::build(py, &class, script.as_deref(), &config)
                .map_err(|e| file.invalid("class", format!("building {class}: {}", traceback(py, &e))))
        })
    }
}

impl ParamMdp for PyEnv {
    fn n_states(&self) -> usize {
        self.n_states
    }
    fn n_actions(&self) -> usize {
        self.n_actions
    }
    fn zeta_space(&self) -> &ZetaSpace {
        &self.space
    }
    fn valid_actions(&self, s: usize) -> &[usize] {
        &self.actions[s]
    }
    fn is_terminal(&self, s: usize) -> bool {
        self.terminal[s]
    }
    fn gamma(&self) -> f64 {
        self.gamma
    }
    fn sample_initial(&self, rng: &mut EnvRng) -> usize {
        self.start("initial_state", rng)
    }
    fn sample_exploring_start(&self, rng: &mut EnvRng) -> usize {
        if self.exploring_start { self.start("exploring_start", rng) } else { self.sample_initial(rng) }
    }
    fn cost_scale(&self) -> f64 {
        self.cost_scale.unwrap_or(1.0)
    }
    fn heuristic_design(&self) -> Option<Vec<f64>> {
        self.initial_design.clone()
    }
    /// The class's `clustered_design(rng)`, if it has one (checked against the bounds by its
    /// callers: the oracle and `zeta0 = clustered`).
    fn clustered_design(&self, rng: &mut EnvRng) -> Option<Vec<f64>> {
        if !self.clustered_design {
            return None;
        }
        let design = Python::attach(|py| {
            let obj = self.obj.bind(py);
            let v = with_rng(py, rng, |r| obj.call_method1("clustered_design", (r,)))?;
            v.extract::<Vec<f64>>()
                .map_err(|_| format!("{}.clustered_design(rng) returned {v}, not a list of numbers", self.class))
        });
        Some(design.unwrap_or_else(|m| fail(m)))
    }
    fn step(&self, s: usize, a: usize, zeta: &[f64], rng: &mut EnvRng) -> (usize, f64) {
        Python::attach(|py| {
            let obj = self.obj.bind(py);
            let z = PyTuple::new(py, zeta).map_err(|e| e.to_string())?;
            let out = with_rng(py, rng, |r| obj.call_method1("step", (s, a, z, r)))?;
            let what = || format!("step({s}, {a}, zeta, rng)");
            let (next, cost): (Bound<'_, PyAny>, f64) = out
                .extract()
                .map_err(|_| format!("{}.{} returned {out}, not a pair (next_state, cost)", self.class, what()))?;
            let next = self.state(&what(), &next)?;
            if !cost.is_finite() {
                return Err(format!("{}.{} returned the cost {cost}: costs must be finite", self.class, what()));
            }
            Ok((next, cost))
        })
        .unwrap_or_else(|m| fail(m))
    }
}

/// `outcomes(s, a, zeta, True)` as Python returns it: next states, probabilities, costs, and
/// per outcome the d derivatives of its probability and of its cost.
type GradOutcomes = (Vec<usize>, Vec<f64>, Vec<f64>, Vec<Vec<f64>>, Vec<Vec<f64>>);

impl ModelMdp for PyEnv {
    fn initial_distribution(&self) -> Vec<(usize, f64)> {
        Python::attach(|py| {
            let v = self.obj.bind(py).call_method0("initial_distribution").map_err(|e| traceback(py, &e))?;
            let pairs: Vec<(usize, f64)> = v.extract().map_err(|_| {
                format!("{}.initial_distribution() returned {v}, not (state, probability) pairs", self.class)
            })?;
            if let Some(&(s, p)) = pairs.iter().find(|(s, p)| *s >= self.n_states || !(p.is_finite() && *p >= 0.0)) {
                return Err(format!("{}.initial_distribution() has the pair ({s}, {p})", self.class));
            }
            Ok(pairs)
        })
        .unwrap_or_else(|m| fail(m))
    }

    fn outcomes(&self, s: usize, a: usize, zeta: &[f64], grad: bool, out: &mut Outcomes) {
        let d = zeta.len();
        let res = Python::attach(|py| -> Result<(), String> {
            let obj = self.obj.bind(py);
            let z = PyTuple::new(py, zeta).map_err(|e| e.to_string())?;
            let v = obj.call_method1("outcomes", (s, a, z, grad)).map_err(|e| traceback(py, &e))?;
            let what = format!("{}.outcomes({s}, {a}, zeta, grad={grad})", self.class);
            let shape = || {
                format!(
                    "{what} returned {v}: expected (next, prob, cost) lists, with grad also (dprob, dcost), each a list of d = {d} derivatives per outcome"
                )
            };
            out.clear();
            if grad {
                let (next, prob, cost, dprob, dcost): GradOutcomes = v.extract().map_err(|_| shape())?;
                let n = next.len();
                if [prob.len(), cost.len(), dprob.len(), dcost.len()].iter().any(|&l| l != n)
                    || dprob.iter().chain(&dcost).any(|r| r.len() != d)
                {
                    return Err(shape());
                }
                for k in 0..n {
                    out.push(next[k], prob[k], cost[k], true, d);
                    out.last_dprob(d).copy_from_slice(&dprob[k]);
                    out.last_dcost(d).copy_from_slice(&dcost[k]);
                }
            } else {
                let t = v.cast::<PyTuple>().map_err(|_| shape())?;
                if t.len() < 3 {
                    return Err(shape());
                }
                let next: Vec<usize> = t.get_item(0).and_then(|x| x.extract()).map_err(|_| shape())?;
                let prob: Vec<f64> = t.get_item(1).and_then(|x| x.extract()).map_err(|_| shape())?;
                let cost: Vec<f64> = t.get_item(2).and_then(|x| x.extract()).map_err(|_| shape())?;
                if prob.len() != next.len() || cost.len() != next.len() {
                    return Err(shape());
                }
                for k in 0..next.len() {
                    out.push(next[k], prob[k], cost[k], false, d);
                }
            }
            if let Some(k) = (0..out.len()).find(|&k| {
                out.next[k] >= self.n_states
                    || !(out.prob[k].is_finite() && out.prob[k] >= 0.0)
                    || !out.cost[k].is_finite()
            }) {
                return Err(format!(
                    "{what}: outcome {k} is (next {}, prob {}, cost {}); next must be a state, prob and cost finite, prob ≥ 0",
                    out.next[k], out.prob[k], out.cost[k]
                ));
            }
            if out.dprob.iter().chain(&out.dcost).any(|x| !x.is_finite()) {
                return Err(format!("{what}: a derivative is not finite"));
            }
            Ok(())
        });
        res.unwrap_or_else(|m| fail(m))
    }
}

impl Env for PyEnv {
    fn model(&self) -> Option<&dyn ModelMdp> {
        if self.model { Some(self) } else { None }
    }
}
