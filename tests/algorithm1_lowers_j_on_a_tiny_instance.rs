//! A short model-free run on a tiny instance (20 users, 3 UAVs) lowers J substantially from
//! where it started: below 80% of the best J the starting design allows.

mod support;

use envpg_ac::trainer::train;
use envpg_model::optimal_greedy;

#[test]
fn a_short_run_lowers_j_substantially() {
    for (kappa, seed) in [(1.0, 3), (0.9, 4)] {
        let spec = support::tiny_spec(kappa, seed, 600);
        let r = train(&spec, &support::registry(), |_| true).unwrap();
        let env = support::tiny_env(kappa);
        let (_, _, j_start) = optimal_greedy(env.model().unwrap(), &r.zeta0).unwrap();
        let j = r.j.expect("the final greedy policy reaches the destination");
        assert!(j < 0.8 * j_start, "kappa {kappa}: J went from {j_start} (best at ζ₀) to {j}");
    }
}
