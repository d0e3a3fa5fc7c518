//! [`Sampler`]: one environment's sampler with its own random stream, for the Gymnasium
//! adapter (`envpg.gym`).

use envpg_core::{EnvRng, LoadedEnv, Purpose, Streams};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

use crate::{InputError, registry};

/// The sampler of an instance (its canonical JSON), stepped one transition at a time with a
/// stream seeded by `seed`; the model is never touched.
#[pyclass(module = "envpg._native")]
pub struct Sampler {
    env: LoadedEnv,
    rng: EnvRng,
}

impl Sampler {
    fn state(&self, s: usize) -> PyResult<usize> {
        if s < self.env.sampler().n_states() {
            Ok(s)
        } else {
            Err(PyValueError::new_err(format!("state {s} is not in 0..{}", self.env.sampler().n_states())))
        }
    }
}

#[pymethods]
impl Sampler {
    /// The sampler of the instance `instance_json` (canonical, as `envpg.load_instance` gives).
    #[new]
    fn new(instance_json: &str) -> PyResult<Self> {
        let value: serde_json::Value =
            serde_json::from_str(instance_json).map_err(|e| InputError::new_err(format!("instance JSON: {e}")))?;
        let env = registry().from_value(&value, "<instance>").map_err(|e| InputError::new_err(e.to_string()))?;
        Ok(Self { env, rng: Streams::new(0).stream(Purpose::Other, 0, 0) })
    }

    /// Restarts the stream from `seed`.
    fn seed(&mut self, seed: u64) {
        self.rng = Streams::new(seed).stream(Purpose::Other, 0, 0);
    }

    #[getter]
    fn n_states(&self) -> usize {
        self.env.sampler().n_states()
    }

    #[getter]
    fn n_actions(&self) -> usize {
        self.env.sampler().n_actions()
    }

    #[getter]
    fn gamma(&self) -> f64 {
        self.env.sampler().gamma()
    }

    #[getter]
    fn cost_scale(&self) -> f64 {
        self.env.sampler().cost_scale()
    }

    #[getter]
    fn zeta_names(&self) -> Vec<String> {
        self.env.sampler().zeta_space().names().to_vec()
    }

    #[getter]
    fn zeta_low(&self) -> Vec<f64> {
        self.env.sampler().zeta_space().lower().to_vec()
    }

    #[getter]
    fn zeta_high(&self) -> Vec<f64> {
        self.env.sampler().zeta_space().upper().to_vec()
    }

    /// The environment's own initial design, or the centre of its bounds.
    fn initial_design(&self) -> Vec<f64> {
        let sim = self.env.sampler();
        sim.heuristic_design().unwrap_or_else(|| sim.zeta_space().origin().to_vec())
    }

    /// Checks a design against the bounds (raises `ValueError` naming the coordinate).
    fn check_zeta(&self, zeta: Vec<f64>) -> PyResult<()> {
        self.env.sampler().zeta_space().check(&zeta).map_err(|e| PyValueError::new_err(e.to_string()))
    }

    fn valid_actions(&self, s: usize) -> PyResult<Vec<usize>> {
        Ok(self.env.sampler().valid_actions(self.state(s)?).to_vec())
    }

    fn is_terminal(&self, s: usize) -> PyResult<bool> {
        Ok(self.env.sampler().is_terminal(self.state(s)?))
    }

    /// Draws an initial state.
    fn initial_state(&mut self) -> usize {
        self.env.sampler().sample_initial(&mut self.rng)
    }

    /// One transition from `s` under the valid action `a` at design `zeta` (checked):
    /// `(next_state, cost)`.
    fn step(&mut self, s: usize, a: usize, zeta: Vec<f64>) -> PyResult<(usize, f64)> {
        let sim = self.env.sampler();
        let s = self.state(s)?;
        if !sim.valid_actions(s).contains(&a) {
            return Err(PyValueError::new_err(format!(
                "action {a} is not valid in state {s} (valid: {:?})",
                sim.valid_actions(s)
            )));
        }
        sim.zeta_space().check(&zeta).map_err(|e| PyValueError::new_err(e.to_string()))?;
        Ok(sim.step(s, a, &zeta, &mut self.rng))
    }
}
