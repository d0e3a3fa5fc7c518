//! Bridges from the learned networks to the exact model, for tests and reports only: the actor
//! as a differentiable policy π_θ(a|s, ζ) that `envpg-model` can evaluate and differentiate.

use std::cell::RefCell;

use envpg_model::ParamPolicy;
use envpg_nn::Mlp;

use crate::features::Features;
use crate::nets::{ActionSets, Columns, Net, softmax};

/// The actor θ as a [`ParamPolicy`]: `π_θ(·|s, ζ)` and `∇ζ ln π_θ(a|s, ζ)` by backprop.
#[derive(Debug)]
pub struct ActorPolicy {
    net: RefCell<Net>,
    features: Features,
    sets: ActionSets,
}

impl ActorPolicy {
    /// Wraps actor parameters; `features` must be centred on the design of interest.
    pub fn new(actor: &Mlp<f32>, features: &Features, sets: &ActionSets) -> Self {
        Self { net: RefCell::new(Net::from_mlp(actor.clone())), features: features.clone(), sets: sets.clone() }
    }

    fn logits(&self, s: usize, zeta: &[f64]) -> (Columns, Vec<f32>) {
        let mut cols = Columns::default();
        for &a in self.sets.of(s) {
            cols.push(&self.features, s, a, zeta, 0);
        }
        let mut l = Vec::new();
        self.net.borrow_mut().eval(&cols, &mut l);
        (cols, l)
    }
}

impl ParamPolicy for ActorPolicy {
    fn probs(&self, s: usize, zeta: &[f64], out: &mut [f64]) {
        let (_, l) = self.logits(s, zeta);
        softmax(&l, out);
    }

    fn grad_log(&self, s: usize, k: usize, zeta: &[f64], out: &mut [f64]) {
        let (cols, l) = self.logits(s, zeta);
        let mut p = vec![0.0; l.len()];
        softmax(&l, &mut p);
        let dout: Vec<f32> = (0..l.len()).map(|j| (if j == k { 1.0 } else { 0.0 }) - p[j] as f32).collect();
        let mut di = Vec::new();
        self.net.borrow().backprop(&cols, &dout, None, Some(&mut di));
        out.iter_mut().for_each(|o| *o = 0.0);
        let dd = cols.width();
        for (c, &(s, a)) in cols.sa.iter().enumerate() {
            self.features.chain(s as usize, a as usize, zeta, &di[c * dd..(c + 1) * dd], 1.0, out);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use envpg_core::{Env, ParamMdp, Purpose, Streams};
    use envpg_envs::uav::{UavInstance, UavNetwork};
    use envpg_nn::{Mlp, MlpSpec};

    use crate::features::ZetaInput;

    #[test]
    fn grad_log_matches_central_differences() {
        let inst = UavInstance {
            name: "t".into(),
            n_uav: 3,
            users: vec![[0.0, 0.0], [2.0, 1.0], [1.0, 3.0]],
            dest: [4.0, 3.0],
        };
        let net = UavNetwork::new(inst, 0.9, 100.0).unwrap();
        let zeta = [1.0, 0.5, 2.5, 1.5, 3.0, 2.0];
        for input in [ZetaInput::Centered, ZetaInput::Absolute, ZetaInput::Routed] {
            let f = Features::new(&net, net.feature_map(), input).centered(&[0.9, 0.6, 2.4, 1.4, 3.1, 2.1]);
            let sets = ActionSets::new(&net);
            let spec = MlpSpec { onehot: f.onehot(), dense: f.dense_dim(), hidden: vec![16] };
            let actor = Mlp::<f32>::new(spec, &mut Streams::new(4).stream(Purpose::Init, 0, 0), false);
            let pol = ActorPolicy::new(&actor, &f, &sets);
            for s in [0, 3, 4] {
                for k in 0..net.valid_actions(s).len() {
                    let mut g = vec![0.0; 6];
                    pol.grad_log(s, k, &zeta, &mut g);
                    for i in 0..6 {
                        let h = 1e-3; // f32 network: a large step keeps rounding small
                        let lp = |z: &[f64]| {
                            let mut p = vec![0.0; net.valid_actions(s).len()];
                            pol.probs(s, z, &mut p);
                            p[k].ln()
                        };
                        let mut zp = zeta;
                        zp[i] += h;
                        let mut zm = zeta;
                        zm[i] -= h;
                        let fd = (lp(&zp) - lp(&zm)) / (2.0 * h);
                        assert!(
                            (fd - g[i]).abs() < 2e-3 * (1.0 + fd.abs()),
                            "{input:?} s{s} k{k} i{i}: {fd} vs {}",
                            g[i]
                        );
                    }
                }
            }
        }
    }
}
