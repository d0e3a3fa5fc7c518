//! Small random parameterized MDPs and policies, smooth in ζ, for checking the theorem.
//!
//! `p_ζ(·|s,a)` is a softmax over a random support of logits `L + Bζ + ½C(ζ∘ζ)`;
//! `c_ζ = ½ + (g + f·ζ)²`; the policy is a softmax of `b + Wζ + 0.3 sin(Vζ)`.
//! With `ssp = true` the last state is terminal and reachable from every pair.

use envpg_core::{EnvRng, ModelMdp, Outcomes, ParamMdp, ZetaSpace};
use rand::{Rng, RngExt, SeedableRng};
use rand_chacha::ChaCha12Rng;

use crate::grad::ParamPolicy;

/// A random parameterized MDP.
#[derive(Debug, Clone)]
pub struct RandomMdp {
    n: usize,
    n_actions: usize,
    d: usize,
    space: ZetaSpace,
    gamma: f64,
    ssp: bool,
    mu: Vec<(usize, f64)>,
    actions: Vec<Vec<usize>>,
    /// Per (s, a): support, logits L, B (|support|×d), C, cost g, f (|support|×d).
    pairs: Vec<Vec<PairParams>>,
}

#[derive(Debug, Clone)]
struct PairParams {
    support: Vec<usize>,
    l: Vec<f64>,
    b: Vec<f64>,
    c: Vec<f64>,
    g: Vec<f64>,
    f: Vec<f64>,
}

fn normal<R: Rng + ?Sized>(rng: &mut R) -> f64 {
    // Sum of uniforms: smooth enough for test parameters, no extra dependency on distributions.
    (0..4).map(|_| rng.random::<f64>() - 0.5).sum::<f64>()
}

impl RandomMdp {
    /// A random MDP with `n` states, `n_actions` global actions (each non-terminal state allows a
    /// random non-empty subset), ζ of dimension `d`, discount `gamma`; with `ssp`, state `n−1`
    /// is terminal and `gamma` should be 1.
    pub fn new(seed: u64, n: usize, n_actions: usize, d: usize, gamma: f64, ssp: bool) -> Self {
        assert!(n >= 2 && n_actions >= 1 && d >= 1);
        let mut rng = ChaCha12Rng::seed_from_u64(seed);
        let term = if ssp { Some(n - 1) } else { None };
        let mut actions = Vec::new();
        let mut pairs = Vec::new();
        for s in 0..n {
            if Some(s) == term {
                actions.push(vec![]);
                pairs.push(vec![]);
                continue;
            }
            let mut acts: Vec<usize> = (0..n_actions).filter(|_| rng.random::<f64>() < 0.7).collect();
            if acts.is_empty() {
                acts.push(rng.random_range(0..n_actions));
            }
            let mut pp = Vec::new();
            for _ in &acts {
                let mut support: Vec<usize> = (0..n).filter(|_| rng.random::<f64>() < 0.6).collect();
                if let Some(t) = term
                    && !support.contains(&t)
                {
                    support.push(t);
                }
                if support.is_empty() {
                    support.push(rng.random_range(0..n));
                }
                support.sort_unstable();
                let k = support.len();
                pp.push(PairParams {
                    l: (0..k).map(|_| normal(&mut rng)).collect(),
                    b: (0..k * d).map(|_| normal(&mut rng)).collect(),
                    c: (0..k * d).map(|_| 0.5 * normal(&mut rng)).collect(),
                    g: (0..k).map(|_| normal(&mut rng)).collect(),
                    f: (0..k * d).map(|_| normal(&mut rng)).collect(),
                    support,
                });
            }
            actions.push(acts);
            pairs.push(pp);
        }
        let starts: Vec<usize> = (0..n).filter(|&s| Some(s) != term).collect();
        let w: Vec<f64> = starts.iter().map(|_| 0.1 + rng.random::<f64>()).collect();
        let tot: f64 = w.iter().sum();
        let mu = starts.iter().zip(&w).map(|(&s, &w)| (s, w / tot)).collect();
        let space = ZetaSpace::unbounded((0..d).map(|i| format!("z{i}")).collect());
        Self { n, n_actions, d, space, gamma, ssp, mu, actions, pairs }
    }
}

impl ParamMdp for RandomMdp {
    fn n_states(&self) -> usize {
        self.n
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
        self.ssp && s == self.n - 1
    }
    fn sample_initial(&self, rng: &mut EnvRng) -> usize {
        let mut u: f64 = rng.random();
        for &(s, p) in &self.mu {
            if u < p {
                return s;
            }
            u -= p;
        }
        self.mu.last().expect("non-empty").0
    }
    fn step(&self, s: usize, a: usize, zeta: &[f64], rng: &mut EnvRng) -> (usize, f64) {
        let mut o = Outcomes::default();
        self.outcomes(s, a, zeta, false, &mut o);
        let mut u: f64 = rng.random();
        for k in 0..o.len() {
            if u < o.prob[k] {
                return (o.next[k], o.cost[k]);
            }
            u -= o.prob[k];
        }
        (*o.next.last().expect("outcome"), *o.cost.last().expect("outcome"))
    }
    fn gamma(&self) -> f64 {
        self.gamma
    }
}

impl ModelMdp for RandomMdp {
    fn initial_distribution(&self) -> Vec<(usize, f64)> {
        self.mu.clone()
    }
    fn outcomes(&self, s: usize, a: usize, zeta: &[f64], grad: bool, out: &mut Outcomes) {
        out.clear();
        let d = self.d;
        let k_a = self.actions[s].iter().position(|&x| x == a).expect("valid action");
        let pp = &self.pairs[s][k_a];
        let k = pp.support.len();
        let logits: Vec<f64> = (0..k)
            .map(|o| {
                pp.l[o]
                    + (0..d).map(|i| pp.b[o * d + i] * zeta[i] + 0.5 * pp.c[o * d + i] * zeta[i] * zeta[i]).sum::<f64>()
            })
            .collect();
        let mx = logits.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let e: Vec<f64> = logits.iter().map(|l| (l - mx).exp()).collect();
        let z: f64 = e.iter().sum();
        for o in 0..k {
            let lin = pp.g[o] + (0..d).map(|i| pp.f[o * d + i] * zeta[i]).sum::<f64>();
            out.next.push(pp.support[o]);
            out.prob.push(e[o] / z);
            out.cost.push(0.5 + lin * lin);
            if grad {
                for i in 0..d {
                    out.dcost.push(2.0 * lin * pp.f[o * d + i]);
                }
            }
        }
        if grad {
            // ∂p_o = p_o (∂l_o − Σ_j p_j ∂l_j)
            let dl = |o: usize, i: usize| pp.b[o * d + i] + pp.c[o * d + i] * zeta[i];
            for o in 0..k {
                for i in 0..d {
                    let mean: f64 = (0..k).map(|j| out.prob[j] * dl(j, i)).sum();
                    out.dprob.push(out.prob[o] * (dl(o, i) - mean));
                }
            }
        }
    }
}

/// Logit parameters of one action: `b + w·ζ + 0.3 sin(v·ζ)`.
type ActionParams = (f64, Vec<f64>, Vec<f64>);

/// A random differentiable policy for a given MDP's valid actions.
#[derive(Debug, Clone)]
pub struct RandomPolicy {
    d: usize,
    /// Per state: per valid action.
    params: Vec<Vec<ActionParams>>,
}

impl RandomPolicy {
    /// A random policy for `mdp`.
    pub fn new<M: ParamMdp + ?Sized>(seed: u64, mdp: &M) -> Self {
        let mut rng = ChaCha12Rng::seed_from_u64(seed ^ 0x5eed);
        let d = mdp.zeta_dim();
        let params = (0..mdp.n_states())
            .map(|s| {
                mdp.valid_actions(s)
                    .iter()
                    .map(|_| {
                        (
                            normal(&mut rng),
                            (0..d).map(|_| normal(&mut rng)).collect(),
                            (0..d).map(|_| normal(&mut rng)).collect(),
                        )
                    })
                    .collect()
            })
            .collect();
        Self { d, params }
    }

    fn logits(&self, s: usize, zeta: &[f64]) -> Vec<f64> {
        self.params[s]
            .iter()
            .map(|(b, w, v)| {
                let lin: f64 = (0..self.d).map(|i| w[i] * zeta[i]).sum();
                let arg: f64 = (0..self.d).map(|i| v[i] * zeta[i]).sum();
                b + lin + 0.3 * arg.sin()
            })
            .collect()
    }

    fn dlogit(&self, s: usize, k: usize, zeta: &[f64], i: usize) -> f64 {
        let (_, w, v) = &self.params[s][k];
        let arg: f64 = (0..self.d).map(|j| v[j] * zeta[j]).sum();
        w[i] + 0.3 * arg.cos() * v[i]
    }
}

impl ParamPolicy for RandomPolicy {
    fn probs(&self, s: usize, zeta: &[f64], out: &mut [f64]) {
        let l = self.logits(s, zeta);
        let mx = l.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let mut z = 0.0;
        for (o, l) in out.iter_mut().zip(&l) {
            *o = (l - mx).exp();
            z += *o;
        }
        out.iter_mut().for_each(|o| *o /= z);
    }
    fn grad_log(&self, s: usize, k: usize, zeta: &[f64], out: &mut [f64]) {
        let mut p = vec![0.0; self.params[s].len()];
        self.probs(s, zeta, &mut p);
        for (i, o) in out.iter_mut().enumerate() {
            let mean: f64 = (0..p.len()).map(|j| p[j] * self.dlogit(s, j, zeta, i)).sum();
            *o = self.dlogit(s, k, zeta, i) - mean;
        }
    }
}
