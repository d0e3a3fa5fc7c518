//! Initial designs ζ₀ without the model: random over the users' bounding box, or a relay
//! chain from the users' centroid to the destination (observable coordinates only).

use envpg_core::{Instance, Purpose, Streams};
use rand_distr::{Distribution, Uniform};

use crate::config::Zeta0;

/// ζ₀ for `instance` under `spec` and run `seed`. `Random` uses the same stream as the
/// oracle's restart 0 with that seed, so `envpg oracle --strategy warm --restarts 1 --seed S`
/// starts where a model-free run with seed S does.
pub fn initial_design(instance: &Instance, spec: &Zeta0, seed: u64) -> Result<Vec<f64>, String> {
    let m = instance.n_uav;
    match spec {
        Zeta0::Given(z) => {
            if z.len() != 2 * m {
                return Err(format!("zeta0 has {} entries, the instance needs {}", z.len(), 2 * m));
            }
            if let Some(i) = z.iter().position(|x| !x.is_finite()) {
                return Err(format!("zeta0[{i}] is not finite"));
            }
            Ok(z.clone())
        }
        Zeta0::Random => {
            let (lo, hi) = instance.user_bbox();
            let mut rng = Streams::new(seed).stream(Purpose::Zeta0, 0, 0);
            let ux = Uniform::new_inclusive(lo[0], hi[0]).map_err(|e| e.to_string())?;
            let uy = Uniform::new_inclusive(lo[1], hi[1]).map_err(|e| e.to_string())?;
            Ok((0..m).flat_map(|_| [ux.sample(&mut rng), uy.sample(&mut rng)]).collect())
        }
        Zeta0::Users => {
            let n = instance.n_users() as f64;
            let c = instance.users.iter().fold([0.0, 0.0], |a, u| [a[0] + u[0] / n, a[1] + u[1] / n]);
            let dst = instance.dest;
            Ok((0..m)
                .flat_map(|j| {
                    let t = j as f64 / m as f64;
                    [c[0] + t * (dst[0] - c[0]), c[1] + t * (dst[1] - c[1])]
                })
                .collect())
        }
    }
}
