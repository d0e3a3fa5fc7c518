//! # envpg-py
//!
//! `envpg._native`, the Rust core of the `envpg` Python package (the Python side is in
//! `python/envpg`): the launcher and the tools run in-process on argument lists, built with
//! envpg's environments plus [`pyenv::PyEnv`] (environments written in Python), and a
//! [`Sampler`] for the Gymnasium adapter.
//!
//! Data flow: `envpg.train(...)` → `launch` (GIL released) → `envpg_launch::run_args` →
//! learner and worker processes started as `python -m envpg._launch …` → `launch_main` in
//! each of them → the same Rust learner and worker loops as `envpg-launch`, a Python
//! environment's `step` called back with the GIL. Results are `envpg.result.v2` files, read and
//! written by the same code as the CLI's.

mod pyenv;
mod sampler;

use std::panic::AssertUnwindSafe;

use envpg_core::exit::{self, Failure};
use envpg_core::{Registry, ResultFile};
use pyo3::create_exception;
use pyo3::exceptions::{PyAssertionError, PyKeyboardInterrupt, PyRuntimeError, PyValueError};
use pyo3::prelude::*;

pub use pyenv::{PyEnv, Rng};
pub use sampler::Sampler;

create_exception!(_native, InputError, PyValueError, "Bad input: arguments, settings, instance or result files.");
create_exception!(_native, RunError, PyRuntimeError, "A run or a computation failed.");
create_exception!(_native, EnvError, RunError, "The environment failed (an exception or an invalid return).");
create_exception!(_native, EnvCheckError, PyAssertionError, "An environment check found a disagreement.");

/// envpg's environments and the `python` environment.
fn registry() -> Registry {
    envpg_envs::registry().register::<PyEnv>()
}

/// A [`Failure`] as the Python exception for its exit code.
fn raise(f: Failure) -> PyErr {
    match f.code {
        exit::INPUT => InputError::new_err(f.message),
        exit::INTERRUPTED => PyKeyboardInterrupt::new_err(f.message),
        _ if f.message.contains("the environment failed: ") => EnvError::new_err(f.message),
        _ => RunError::new_err(f.message),
    }
}

/// Runs `f` (with the GIL released), turning a failing Python environment's unwinding
/// ([`pyenv::fail`]) into `EnvError`.
fn guarded<T: Send>(py: Python<'_>, f: impl FnOnce() -> Result<T, Failure> + Send) -> PyResult<T> {
    quiet_env_panics();
    match py.detach(|| std::panic::catch_unwind(AssertUnwindSafe(f))) {
        Ok(r) => r.map_err(raise),
        Err(payload) => match payload.downcast::<pyenv::EnvPanic>() {
            Ok(e) => Err(EnvError::new_err(format!("the environment failed: {}", e.0))),
            Err(other) => std::panic::resume_unwind(other),
        },
    }
}

/// Set while [`check_env`] runs: its failed assertions become exceptions, not panic reports.
static CHECKING: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// The panic hook stays quiet about [`pyenv::EnvPanic`] and failed checks (they become
/// exceptions).
fn quiet_env_panics() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        let default = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            let quiet = info.payload().downcast_ref::<pyenv::EnvPanic>().is_some()
                || CHECKING.load(std::sync::atomic::Ordering::Relaxed);
            if !quiet {
                default(info);
            }
        }));
    });
}

fn program(program: Vec<String>, display: String) -> PyResult<envpg_launch::Program> {
    let mut it = program.into_iter();
    let exe = it.next().ok_or_else(|| PyValueError::new_err("program: give the interpreter first"))?;
    Ok(envpg_launch::Program { program: exe.into(), prefix: it.map(Into::into).collect(), display })
}

/// Runs `envpg-launch` on `argv` (its name first) in this process, starting its learner and
/// workers with `program` (`[sys.executable, "-m", "envpg._launch"]`). Raises `InputError`,
/// `RunError`, `EnvError` or `KeyboardInterrupt` as the run ends.
#[pyfunction]
fn launch(py: Python<'_>, argv: Vec<String>, program: Vec<String>, display: String) -> PyResult<()> {
    let program = self::program(program, display)?;
    guarded(py, move || envpg_launch::run_args(registry(), program, argv))
}

/// The `python -m envpg._launch` program (a run's learner and workers): returns the exit code.
#[pyfunction]
fn launch_main(py: Python<'_>, argv: Vec<String>, program: Vec<String>, display: String) -> PyResult<u8> {
    pyenv::set_role_process();
    let program = self::program(program, display)?;
    Ok(py.detach(move || exit_code(envpg_launch::run_args(registry(), program, argv))))
}

/// The `python -m envpg._tools` program (the `envpg` tools): returns the exit code.
#[pyfunction]
fn tools_main(py: Python<'_>, argv: Vec<String>) -> u8 {
    pyenv::set_role_process();
    py.detach(move || exit_code(envpg_cli::run_args(registry(), "envpg-launch", argv)))
}

/// A program's exit code, its error printed as the CLI prints it.
fn exit_code(r: Result<(), Failure>) -> u8 {
    match r {
        Ok(()) => 0,
        Err(f) => {
            eprintln!("error: {}", f.message);
            f.code
        }
    }
}

/// An instance by bundled name or path (or, with `is_json`, the instance's JSON text), with
/// parameter overrides: `(env, canonical JSON)`.
#[pyfunction]
fn load_instance(
    py: Python<'_>,
    spec: String,
    is_json: bool,
    params: Vec<(String, f64)>,
) -> PyResult<(String, String)> {
    guarded(py, move || {
        let r = registry();
        let env = if is_json {
            envpg_core::InstanceFile::parse(&spec, "<instance>").and_then(|f| r.build(f, &params))
        } else {
            r.load(&spec, &params)
        }
        .map_err(|e| Failure { code: exit::INPUT, message: e.to_string() })?;
        Ok((env.name.to_owned(), env.instance.to_string()))
    })
}

/// The registered environments (name, about, parameters with defaults) and bundled instances,
/// as JSON.
#[pyfunction]
fn envs() -> String {
    let r = registry();
    let envs: Vec<_> = r
        .envs()
        .into_iter()
        .map(|(name, about, params)| {
            let params: serde_json::Map<_, _> = params
                .iter()
                .map(|p| (p.name.to_owned(), serde_json::json!({"default": p.default, "about": p.about})))
                .collect();
            serde_json::json!({"name": name, "about": about, "params": params})
        })
        .collect();
    serde_json::json!({"envs": envs, "bundled": r.bundled()}).to_string()
}

/// Recomputes `(J, J_H)` of a result file's text exactly from its own contents (environment,
/// instance, ζ, policy); `J` is `None` when the policy does not terminate from some state.
#[pyfunction]
fn evaluate(py: Python<'_>, result_json: String, origin: String) -> PyResult<(Option<f64>, Option<f64>)> {
    guarded(py, move || {
        let input = |e: String| Failure { code: exit::INPUT, message: format!("{origin}: {e}") };
        let r = ResultFile::from_json_str(&result_json, &origin).map_err(|e| input(e.to_string()))?;
        let env = r.load_env(&registry(), &origin).map_err(|e| input(e.to_string()))?;
        let model = env.model().map_err(|e| input(e.to_string()))?;
        let rescored = envpg_model::rescore(model, &r).map_err(|e| input(e.to_string()))?;
        Ok((rescored.j.ok(), rescored.j_h))
    })
}

/// Checks a result file's text against the schema and writes it to `path` atomically, as the
/// CLI writes its results.
#[pyfunction]
fn save_result(py: Python<'_>, result_json: String, path: String) -> PyResult<()> {
    guarded(py, move || {
        let r = ResultFile::from_json_str(&result_json, &path)
            .map_err(|e| Failure { code: exit::INPUT, message: e.to_string() })?;
        r.save(&path).map_err(|e| Failure { code: exit::INPUT, message: format!("{path}: {e}") })
    })
}

/// Checks a result file's text against the schema (v1 files are read as v2) and returns the
/// v2 text.
#[pyfunction]
fn read_result(result_json: String, origin: String) -> PyResult<String> {
    let r = ResultFile::from_json_str(&result_json, &origin).map_err(|e| InputError::new_err(e.to_string()))?;
    serde_json::to_string(&r).map_err(|e| RunError::new_err(e.to_string()))
}

/// envpg's environment checks (`envpg_core::checks`) on an instance at design `zeta`: the
/// model's ζ-derivatives against central differences (step `h`, relative tolerance `tol`), its
/// per-state outcomes against the per-action ones, and, for `samples` > 0, the sampler's
/// frequencies from every valid pair of the states in `states` against the model's
/// probabilities. Raises `EnvCheckError` naming what disagrees.
#[pyfunction]
#[allow(clippy::too_many_arguments)]
fn check_env(
    py: Python<'_>,
    instance_json: String,
    zeta: Vec<f64>,
    h: f64,
    tol: f64,
    states: Vec<usize>,
    samples: usize,
) -> PyResult<()> {
    quiet_env_panics();
    let outcome = py.detach(move || -> Result<Result<(), String>, Failure> {
        let input = |message: String| Failure { code: exit::INPUT, message };
        let value: serde_json::Value = serde_json::from_str(&instance_json).map_err(|e| input(e.to_string()))?;
        let env = registry().from_value(&value, "<instance>").map_err(|e| input(e.to_string()))?;
        let model = env.model().map_err(|e| input(e.to_string()))?;
        model.zeta_space().check(&zeta).map_err(|e| input(e.to_string()))?;
        if let Some(&s) = states.iter().find(|&&s| s >= model.n_states()) {
            return Err(input(format!("state {s} is not in 0..{}", model.n_states())));
        }
        CHECKING.store(true, std::sync::atomic::Ordering::Relaxed);
        let checked = std::panic::catch_unwind(AssertUnwindSafe(|| {
            envpg_core::checks::outcome_derivatives(model, &zeta, h, tol);
            envpg_core::checks::state_paths(model, &zeta);
            if samples > 0 {
                for &s in &states {
                    for &a in model.valid_actions(s) {
                        envpg_core::checks::sampler_frequencies(model, s, a, &zeta, samples);
                    }
                }
            }
        }));
        CHECKING.store(false, std::sync::atomic::Ordering::Relaxed);
        Ok(checked.map_err(|payload| match payload.downcast::<pyenv::EnvPanic>() {
            Ok(e) => format!("the environment failed: {}", e.0),
            Err(p) => p
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| p.downcast_ref::<&str>().map(|s| (*s).to_owned()))
                .unwrap_or_else(|| "a check failed".into()),
        }))
    });
    match outcome {
        Ok(Ok(())) => Ok(()),
        Ok(Err(message)) => Err(EnvCheckError::new_err(message)),
        Err(f) => Err(raise(f)),
    }
}

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(launch, m)?)?;
    m.add_function(wrap_pyfunction!(launch_main, m)?)?;
    m.add_function(wrap_pyfunction!(tools_main, m)?)?;
    m.add_function(wrap_pyfunction!(load_instance, m)?)?;
    m.add_function(wrap_pyfunction!(envs, m)?)?;
    m.add_function(wrap_pyfunction!(evaluate, m)?)?;
    m.add_function(wrap_pyfunction!(save_result, m)?)?;
    m.add_function(wrap_pyfunction!(read_result, m)?)?;
    m.add_function(wrap_pyfunction!(check_env, m)?)?;
    m.add_class::<Rng>()?;
    m.add_class::<Sampler>()?;
    m.add("InputError", m.py().get_type::<InputError>())?;
    m.add("RunError", m.py().get_type::<RunError>())?;
    m.add("EnvError", m.py().get_type::<EnvError>())?;
    m.add("EnvCheckError", m.py().get_type::<EnvCheckError>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
