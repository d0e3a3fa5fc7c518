//! Checks every environment should pass, for its authors' tests: the model's ζ-derivatives
//! against central differences, its per-state fast paths against the per-action definition,
//! the sampler's frequencies against the model's probabilities, and a feature map's chain rule
//! against central differences. Each panics with a message naming the state, action, outcome
//! and coordinate that disagree.
//!
//! ```text
//! #[test]
//! fn my_env_passes_the_environment_checks() {
//!     let env = MyEnv::new(...);
//!     let zeta = [0.3, 0.7];
//!     envpg_core::checks::outcome_derivatives(&env, &zeta, 1e-6, 1e-6);
//!     envpg_core::checks::state_paths(&env, &zeta);
//!     envpg_core::checks::sampler_frequencies(&env, 0, 0, &zeta, 100_000);
//! }
//! ```

use crate::features::FeatureMap;
use crate::mdp::{ModelMdp, Outcomes};
use crate::rng::{Purpose, Streams};

/// `∂p/∂ζ` and `∂c/∂ζ` of every outcome of every valid pair at `zeta` against central
/// differences with step `h`, to relative tolerance `tol`. Outcomes must come in the same order
/// at nearby designs (they do when the support does not change).
pub fn outcome_derivatives<M: ModelMdp + ?Sized>(model: &M, zeta: &[f64], h: f64, tol: f64) {
    let (mut o, mut op, mut om) = (Outcomes::default(), Outcomes::default(), Outcomes::default());
    let d = zeta.len();
    for s in 0..model.n_states() {
        for &a in model.valid_actions(s) {
            model.outcomes(s, a, zeta, true, &mut o);
            assert_eq!(o.dprob.len(), o.len() * d, "s{s} a{a}: ∂p rows");
            assert_eq!(o.dcost.len(), o.len() * d, "s{s} a{a}: ∂c rows");
            for i in 0..d {
                let (mut zp, mut zm) = (zeta.to_vec(), zeta.to_vec());
                zp[i] += h;
                zm[i] -= h;
                model.outcomes(s, a, &zp, false, &mut op);
                model.outcomes(s, a, &zm, false, &mut om);
                assert_eq!((op.next.as_slice(), om.next.as_slice()), (o.next.as_slice(), o.next.as_slice()));
                for k in 0..o.len() {
                    let fp = (op.prob[k] - om.prob[k]) / (2.0 * h);
                    let fc = (op.cost[k] - om.cost[k]) / (2.0 * h);
                    let (ep, ec) = (o.dprob[k * d + i], o.dcost[k * d + i]);
                    assert!((fp - ep).abs() <= tol * (1.0 + fp.abs()), "∂p s{s} a{a} o{k} ζ{i}: fd {fp} vs {ep}");
                    assert!((fc - ec).abs() <= tol * (1.0 + fc.abs()), "∂c s{s} a{a} o{k} ζ{i}: fd {fc} vs {ec}");
                }
            }
        }
    }
}

/// The per-state paths ([`ModelMdp::state_outcomes`], [`ModelMdp::accumulate_state_grad`])
/// against the per-action outcomes, with arbitrary contraction coefficients; every pair's
/// probabilities sum to 1 and are non-negative; the whole-model expansion
/// ([`ModelMdp::all_outcomes`]) appends exactly the per-state outcomes, bit for bit, and so
/// does [`ModelMdp::outcome_values`] where the model implements it.
pub fn state_paths<M: ModelMdp + ?Sized>(model: &M, zeta: &[f64]) {
    let mut o = Outcomes::default();
    let d = zeta.len();
    let bits = |x: &[f64]| x.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    let (mut next, mut prob, mut cost, mut ends) = (vec![7], vec![1.0], vec![0.5], vec![0, 1]);
    for s in 0..model.n_states() {
        model.state_outcomes(s, zeta, &mut next, &mut prob, &mut cost, &mut ends);
    }
    let (mut next2, mut prob2, mut cost2, mut ends2) = (vec![7], vec![1.0], vec![0.5], vec![0, 1]);
    model.all_outcomes(zeta, &mut next2, &mut prob2, &mut cost2, &mut ends2);
    assert_eq!(next2, next, "all_outcomes: successors");
    assert_eq!(ends2, ends, "all_outcomes: ends");
    assert_eq!(bits(&prob2), bits(&prob), "all_outcomes: probabilities");
    assert_eq!(bits(&cost2), bits(&cost), "all_outcomes: costs");
    // Where the model fills in values only, they are all_outcomes' bits, and its successors are
    // the same at another design.
    let (mut prob3, mut cost3) = (vec![1.0], vec![0.5]);
    if model.outcome_values(zeta, &mut prob3, &mut cost3) {
        assert_eq!(bits(&prob3), bits(&prob), "outcome_values: probabilities");
        assert_eq!(bits(&cost3), bits(&cost), "outcome_values: costs");
        let mut other: Vec<f64> = zeta.iter().map(|z| z + 0.25 * (1.0 + z.abs())).collect();
        model.zeta_space().project(&mut other);
        let (mut next4, mut prob4, mut cost4, mut ends4) = (vec![7], vec![1.0], vec![0.5], vec![0, 1]);
        model.all_outcomes(&other, &mut next4, &mut prob4, &mut cost4, &mut ends4);
        assert!(next4 == next && ends4 == ends, "outcome_values: the successors change with ζ");
    } else {
        assert!(prob3 == [1.0] && cost3 == [0.5], "outcome_values: appended, then declined");
    }
    for s in 0..model.n_states() {
        let (mut next, mut prob, mut cost, mut ends) = (vec![], vec![], vec![], vec![]);
        model.state_outcomes(s, zeta, &mut next, &mut prob, &mut cost, &mut ends);
        assert_eq!(ends.len(), model.valid_actions(s).len(), "s{s}: one end per valid action");
        // After other states' entries, the same outcomes are appended, ends counting from them.
        let (mut next2, mut prob2, mut cost2, mut ends2) = (vec![7], vec![1.0], vec![0.5], vec![0, 1]);
        model.state_outcomes(s, zeta, &mut next2, &mut prob2, &mut cost2, &mut ends2);
        assert!(next2[1..] == next[..] && prob2[1..] == prob[..] && cost2[1..] == cost[..], "s{s}: appends");
        assert!(ends2[2..].iter().zip(&ends).all(|(&e2, &e)| e2 == e + 1), "s{s}: ends count the whole of next");
        let cp: Vec<f64> = (0..next.len()).map(|i| (i as f64 * 0.7).sin()).collect();
        let cc: Vec<f64> = (0..next.len()).map(|i| (i as f64 * 1.3).cos()).collect();
        let mut dense = vec![0.0; d];
        let mut base = 0;
        for (k, &a) in model.valid_actions(s).iter().enumerate() {
            model.outcomes(s, a, zeta, true, &mut o);
            assert_eq!(ends[k], base + o.len(), "s{s} a{a}: outcome count");
            let sum: f64 = o.prob.iter().sum();
            assert!((sum - 1.0).abs() < 1e-12, "s{s} a{a}: probabilities sum to {sum}");
            assert!(o.prob.iter().all(|&p| p >= 0.0), "s{s} a{a}: a negative probability");
            for j in 0..o.len() {
                assert_eq!(next[base + j], o.next[j], "s{s} a{a} o{j}: successor");
                assert!((prob[base + j] - o.prob[j]).abs() <= 1e-15, "s{s} a{a} o{j}: probability");
                assert_eq!(cost[base + j], o.cost[j], "s{s} a{a} o{j}: cost");
                for i in 0..d {
                    dense[i] += cp[base + j] * o.dprob[j * d + i] + cc[base + j] * o.dcost[j * d + i];
                }
            }
            base += o.len();
        }
        let mut sparse = vec![0.0; d];
        model.accumulate_state_grad(s, zeta, &prob, &cp, &cc, &mut sparse);
        for i in 0..d {
            assert!(
                (sparse[i] - dense[i]).abs() <= 1e-11 * (1.0 + dense[i].abs()),
                "s{s} ζ{i}: contraction {} vs dense {}",
                sparse[i],
                dense[i]
            );
        }
    }
}

/// `n` samples of `step(s, a, zeta)`: every successor is an outcome of the model with the
/// model's cost, and its frequency is within 5 standard errors of its probability.
pub fn sampler_frequencies<M: ModelMdp + ?Sized>(model: &M, s: usize, a: usize, zeta: &[f64], n: usize) {
    let mut rng = Streams::new(3).stream(Purpose::Other, s as u64, a as u64);
    let mut o = Outcomes::default();
    model.outcomes(s, a, zeta, false, &mut o);
    let mut counts = vec![0usize; o.len()];
    for _ in 0..n {
        let (next, cost) = model.step(s, a, zeta, &mut rng);
        let k = o
            .next
            .iter()
            .position(|&t| t == next)
            .unwrap_or_else(|| panic!("s{s} a{a}: successor {next} is not an outcome"));
        assert!(
            (cost - o.cost[k]).abs() <= 1e-12 * (1.0 + cost.abs()),
            "s{s} a{a} → {next}: cost {cost} vs {}",
            o.cost[k]
        );
        counts[k] += 1;
    }
    for (k, &t) in o.next.iter().enumerate() {
        let p = o.prob[k];
        let se = (p * (1.0 - p) / n as f64).sqrt();
        let f = counts[k] as f64 / n as f64;
        assert!((f - p).abs() < 5.0 * se + 1e-9, "s{s} a{a} → {t}: frequency {f} vs probability {p}");
    }
}

/// A feature map's [`FeatureMap::chain`] against central differences of `w · features(ζ)` for
/// every valid pair of `model` at `zeta`, with an arbitrary weight vector `w`. Features are f32,
/// so the step is large (10⁻³) and the tolerance loose (2·10⁻⁴ relative).
pub fn feature_chain<M: ModelMdp + ?Sized>(model: &M, features: &dyn FeatureMap, zeta: &[f64]) {
    let d = zeta.len();
    let w: Vec<f32> = (0..features.dim()).map(|i| ((i as f32) * 0.7).cos()).collect();
    let dot = |z: &[f64], s: usize, a: usize| {
        let mut x = vec![0.0f32; features.dim()];
        features.write(s, a, z, &mut x);
        x.iter().zip(&w).map(|(x, w)| *x as f64 * *w as f64).sum::<f64>()
    };
    for s in 0..model.n_states() {
        for &a in model.valid_actions(s) {
            let mut g = vec![0.0; d];
            features.chain(s, a, zeta, &w, 1.0, &mut g);
            for i in 0..d {
                let h = 1e-3;
                let (mut zp, mut zm) = (zeta.to_vec(), zeta.to_vec());
                zp[i] += h;
                zm[i] -= h;
                let fd = (dot(&zp, s, a) - dot(&zm, s, a)) / (2.0 * h);
                assert!((fd - g[i]).abs() < 2e-4 * (1.0 + fd.abs()), "s{s} a{a} ζ{i}: fd {fd} vs chain {}", g[i]);
            }
        }
    }
}
