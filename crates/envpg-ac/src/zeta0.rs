//! Initial designs ζ₀ without the model: the environment's random design, its own heuristic
//! one or a clustered one (observable data only), or a given one inside the design bounds.

use envpg_core::{ParamMdp, Purpose, Streams};

use crate::config::Zeta0;

/// ζ₀ for `env` under `spec` and run `seed`. `Random` uses the same stream as the oracle's
/// restart 0 with that seed, so `envpg oracle --strategy warm --restarts 1 --seed S` starts
/// where a model-free run with seed S does.
pub fn initial_design<E: ParamMdp + ?Sized>(env: &E, spec: &Zeta0, seed: u64) -> Result<Vec<f64>, String> {
    let (what, design, missing) = match spec {
        Zeta0::Given(z) => {
            env.zeta_space().check(z).map_err(|e| format!("zeta0: {e}"))?;
            return Ok(z.clone());
        }
        Zeta0::Random => return Ok(env.random_design(&mut Streams::new(seed).stream(Purpose::Zeta0, 0, 0))),
        Zeta0::Clustered => (
            "clustered",
            env.clustered_design(&mut Streams::new(seed).stream(Purpose::Zeta0, 0, 0)),
            "no clustered design",
        ),
        Zeta0::Env => ("env", env.heuristic_design(), "no initial design of its own"),
    };
    // The environment's own design: a hook of a user's environment that returns one of the wrong
    // size or outside the bounds is an error, not a panic later.
    let z = design.ok_or_else(|| format!("zeta0 = {what}: this environment has {missing}"))?;
    env.zeta_space().check(&z).map_err(|e| format!("zeta0 = {what}: the environment's design is invalid: {e}"))?;
    Ok(z)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_clustered_start_is_the_seeds_draw_and_environments_without_one_are_an_error() {
        let env = envpg_envs::registry().load("uav271", &[]).unwrap();
        let sim = env.sampler();
        let z = initial_design(sim, &Zeta0::Clustered, 4).unwrap();
        assert_eq!(Some(z.clone()), sim.clustered_design(&mut Streams::new(4).stream(Purpose::Zeta0, 0, 0)));
        let flpo = envpg_envs::registry().load("flpo-n10m4", &[]).unwrap();
        let err = initial_design(flpo.sampler(), &Zeta0::Clustered, 4).unwrap_err();
        assert!(err.contains("no clustered design"), "{err}");
    }
}
