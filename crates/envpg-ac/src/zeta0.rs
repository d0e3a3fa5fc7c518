//! Initial designs ζ₀ without the model: the environment's random design, its own heuristic
//! one (observable data only), or a given one inside the design bounds.

use envpg_core::{ParamMdp, Purpose, Streams};

use crate::config::Zeta0;

/// ζ₀ for `env` under `spec` and run `seed`. `Random` uses the same stream as the oracle's
/// restart 0 with that seed, so `envpg oracle --strategy warm --restarts 1 --seed S` starts
/// where a model-free run with seed S does.
pub fn initial_design<E: ParamMdp + ?Sized>(env: &E, spec: &Zeta0, seed: u64) -> Result<Vec<f64>, String> {
    match spec {
        Zeta0::Given(z) => {
            env.zeta_space().check(z).map_err(|e| format!("zeta0: {e}"))?;
            Ok(z.clone())
        }
        Zeta0::Random => Ok(env.random_design(&mut Streams::new(seed).stream(Purpose::Zeta0, 0, 0))),
        Zeta0::Env => env
            .heuristic_design()
            .ok_or_else(|| "zeta0 = env: this environment has no initial design of its own".to_string()),
    }
}
