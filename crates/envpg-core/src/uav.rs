//! The UAV relay network of the paper's Section V.
//!
//! States: users `0..N`, UAVs `N..N+M`, destination `N+M` (terminal, cost-free).
//! Global actions: `0..M` = "send to UAV j", `M` = "send to the destination".
//! From a user the valid actions are the M UAVs; from UAV j the other UAVs and the destination.
//!
//! Transition kernel: the target of the chosen action with probability κ, otherwise (prob 1−κ)
//! one of the targets of the *other* valid actions of `s`, drawn from the Gibbs distribution
//! `q(s') ∝ exp(−η‖x_{s'} − x_s‖²)`. The cost is `‖x_{s'} − x_s‖²` of the hop actually taken.
//! UAV positions are ζ = (x₀, y₀, x₁, y₁, …).

use rand::{Rng, RngExt};

use crate::instance::Instance;
use crate::mdp::{ModelMdp, Observable, Outcomes, ParamMdp};

/// Why the network parameters are unusable.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum UavParamError {
    /// κ outside (0, 1] or not finite.
    #[error("kappa must be in (0, 1], got {0}")]
    Kappa(f64),
    /// η negative or not finite.
    #[error("eta must be finite and non-negative, got {0}")]
    Eta(f64),
}

/// The UAV relay network with fixed κ and η; ζ is supplied per call.
#[derive(Debug, Clone)]
pub struct UavNetwork {
    instance: Instance,
    kappa: f64,
    eta: f64,
    /// Valid actions per state, flattened; `action_ranges[s]` indexes into it.
    actions: Vec<usize>,
    action_ranges: Vec<(u32, u32)>,
}

/// Squared distance.
#[inline]
fn dist2(a: [f64; 2], b: [f64; 2]) -> f64 {
    let dx = a[0] - b[0];
    let dy = a[1] - b[1];
    dx * dx + dy * dy
}

impl UavNetwork {
    /// Builds the network for `instance` with target probability `kappa` and concentration `eta`.
    pub fn new(instance: Instance, kappa: f64, eta: f64) -> Result<Self, UavParamError> {
        if !(kappa.is_finite() && kappa > 0.0 && kappa <= 1.0) {
            return Err(UavParamError::Kappa(kappa));
        }
        if !(eta.is_finite() && eta >= 0.0) {
            return Err(UavParamError::Eta(eta));
        }
        let n = instance.n_users();
        let m = instance.n_uav;
        let mut actions = Vec::new();
        let mut action_ranges = Vec::with_capacity(n + m + 1);
        for s in 0..n + m + 1 {
            let start = actions.len() as u32;
            if s < n {
                actions.extend(0..m);
            } else if s < n + m {
                let j = s - n;
                actions.extend((0..=m).filter(|&a| a != j));
            }
            action_ranges.push((start, actions.len() as u32));
        }
        Ok(Self { instance, kappa, eta, actions, action_ranges })
    }

    /// The instance.
    pub fn instance(&self) -> &Instance {
        &self.instance
    }
    /// κ, the probability of reaching the intended target.
    pub fn kappa(&self) -> f64 {
        self.kappa
    }
    /// η, the concentration of off-target moves.
    pub fn eta(&self) -> f64 {
        self.eta
    }
    /// Number of users N.
    pub fn n_users(&self) -> usize {
        self.instance.n_users()
    }
    /// Number of UAVs M.
    pub fn n_uav(&self) -> usize {
        self.instance.n_uav
    }
    /// The destination state `N + M`.
    pub fn dest_state(&self) -> usize {
        self.n_users() + self.n_uav()
    }
    /// The state of UAV `j`.
    pub fn uav_state(&self, j: usize) -> usize {
        self.n_users() + j
    }
    /// The UAV index of state `s`, if it is a UAV.
    pub fn uav_of(&self, s: usize) -> Option<usize> {
        let n = self.n_users();
        (s >= n && s < n + self.n_uav()).then(|| s - n)
    }
    /// The destination action `M`.
    pub fn dest_action(&self) -> usize {
        self.n_uav()
    }

    /// Checks a design vector: right length, finite entries.
    pub fn check_zeta(&self, zeta: &[f64]) -> Result<(), String> {
        if zeta.len() != self.zeta_dim() {
            return Err(format!("zeta has {} entries, the instance needs {} (2 per UAV)", zeta.len(), self.zeta_dim()));
        }
        if let Some(i) = zeta.iter().position(|z| !z.is_finite()) {
            return Err(format!("zeta[{i}] is not finite ({})", zeta[i]));
        }
        Ok(())
    }
}

/// The targets of one state's valid actions with their squared distances and the exponentials
/// shared by every action's off-target distribution.
///
/// Lives in a per-thread scratch ([`with_geometry`]) so the hot loops over states neither
/// allocate nor clear large fixed arrays.
#[derive(Default)]
struct StateGeometry {
    len: usize,
    target: Vec<usize>,
    xs: [f64; 2],
    xt: Vec<[f64; 2]>,
    d2: Vec<f64>,
    /// `exp(z_l − max z)` with `z = −η d²`.
    e: Vec<f64>,
    sum: f64,
    argmax: usize,
    /// `exp(z_l − second max)` for `l ≠ argmax`, used when the argmax action itself is taken.
    e2: Vec<f64>,
    sum2: f64,
    /// Off-target distribution of the last [`StateGeometry::off_target`] call.
    q: Vec<f64>,
}

thread_local! {
    static GEOMETRY: std::cell::RefCell<StateGeometry> = std::cell::RefCell::new(StateGeometry::default());
}

/// Runs `f` with the geometry of state `s` at `zeta`.
fn with_geometry<R>(net: &UavNetwork, s: usize, zeta: &[f64], f: impl FnOnce(&mut StateGeometry) -> R) -> R {
    GEOMETRY.with(|cell| {
        let mut g = cell.borrow_mut();
        g.fill(net, s, zeta);
        f(&mut g)
    })
}

impl StateGeometry {
    fn fill(&mut self, net: &UavNetwork, s: usize, zeta: &[f64]) {
        let xs = net.position(s, zeta);
        let acts = net.valid_actions(s);
        self.len = acts.len();
        self.xs = xs;
        self.target.clear();
        self.xt.clear();
        self.d2.clear();
        for &a in acts {
            let t = net.action_target(a);
            let xt = net.position(t, zeta);
            self.target.push(t);
            self.xt.push(xt);
            self.d2.push(dist2(xt, xs));
        }
        self.e.clear();
        self.e2.clear();
        self.q.clear();
        self.q.resize(self.len, 0.0);
        self.sum = 0.0;
        self.sum2 = 0.0;
        self.argmax = 0;
        if net.kappa < 1.0 && self.len > 1 {
            let eta = net.eta;
            let mut m1 = f64::NEG_INFINITY;
            for (k, &d) in self.d2.iter().enumerate() {
                if -eta * d > m1 {
                    m1 = -eta * d;
                    self.argmax = k;
                }
            }
            let m2 = (0..self.len)
                .filter(|&k| k != self.argmax)
                .map(|k| -eta * self.d2[k])
                .fold(f64::NEG_INFINITY, f64::max);
            for k in 0..self.len {
                let z = -eta * self.d2[k];
                let e = (z - m1).exp();
                self.e.push(e);
                self.sum += e;
                let e2 = if k == self.argmax { 0.0 } else { (z - m2).exp() };
                self.e2.push(e2);
                self.sum2 += e2;
            }
        }
    }

    /// Writes into `self.q` the off-target distribution of action `k` over the other targets
    /// (entry `k` is 0), normalised without cancellation: for `k ≠ argmax` the denominator
    /// `Σe − e_k` keeps the maximal term 1, and for the argmax action it is re-based on the
    /// second maximum.
    fn off_target(&mut self, k: usize) {
        let (src, den) = if k == self.argmax { (&self.e2, self.sum2) } else { (&self.e, self.sum - self.e[k]) };
        for l in 0..self.len {
            self.q[l] = if l == k { 0.0 } else { src[l] / den };
        }
    }
}

impl ParamMdp for UavNetwork {
    fn n_states(&self) -> usize {
        self.n_users() + self.n_uav() + 1
    }
    fn n_actions(&self) -> usize {
        self.n_uav() + 1
    }
    fn zeta_dim(&self) -> usize {
        2 * self.n_uav()
    }
    fn valid_actions(&self, s: usize) -> &[usize] {
        let (a, b) = self.action_ranges[s];
        &self.actions[a as usize..b as usize]
    }
    fn is_terminal(&self, s: usize) -> bool {
        s == self.dest_state()
    }
    fn sample_initial<R: Rng + ?Sized>(&self, rng: &mut R) -> usize {
        rng.random_range(0..self.n_users())
    }
    /// A uniformly drawn UAV: the relay states μ only reaches through the policy.
    fn sample_exploring_start<R: Rng + ?Sized>(&self, rng: &mut R) -> usize {
        self.uav_state(rng.random_range(0..self.n_uav()))
    }
    fn step<R: Rng + ?Sized>(&self, s: usize, a: usize, zeta: &[f64], rng: &mut R) -> (usize, f64) {
        debug_assert!(self.valid_actions(s).contains(&a), "action {a} invalid in state {s}");
        // Exactly one uniform decides on-/off-target, and one more picks the off-target state,
        // so the stream's consumption does not depend on κ's value beyond that branch.
        let u: f64 = rng.random();
        let next = if u < self.kappa {
            self.action_target(a)
        } else {
            let k = self.valid_actions(s).iter().position(|&b| b == a).expect("valid action");
            let mut r: f64 = rng.random();
            with_geometry(self, s, zeta, |g| {
                g.off_target(k);
                let mut pick = None;
                for l in (0..g.len).filter(|&l| l != k) {
                    pick = Some(g.target[l]);
                    if r < g.q[l] {
                        break;
                    }
                    r -= g.q[l];
                }
                pick.expect("at least two valid actions")
            })
        };
        (next, dist2(self.position(next, zeta), self.position(s, zeta)))
    }
    fn gamma(&self) -> f64 {
        1.0
    }
}

impl Observable for UavNetwork {
    fn action_target(&self, a: usize) -> usize {
        if a < self.n_uav() { self.uav_state(a) } else { self.dest_state() }
    }
    #[inline]
    fn position(&self, s: usize, zeta: &[f64]) -> [f64; 2] {
        let n = self.n_users();
        if s < n {
            self.instance.users[s]
        } else if s < n + self.n_uav() {
            let j = s - n;
            [zeta[2 * j], zeta[2 * j + 1]]
        } else {
            self.instance.dest
        }
    }
    fn zeta_index(&self, s: usize) -> Option<usize> {
        self.uav_of(s).map(|j| 2 * j)
    }
}

impl ModelMdp for UavNetwork {
    fn initial_distribution(&self) -> Vec<(usize, f64)> {
        let n = self.n_users();
        (0..n).map(|i| (i, 1.0 / n as f64)).collect()
    }

    fn state_outcomes(
        &self,
        s: usize,
        zeta: &[f64],
        next: &mut Vec<usize>,
        prob: &mut Vec<f64>,
        cost: &mut Vec<f64>,
        ends: &mut Vec<usize>,
    ) {
        with_geometry(self, s, zeta, |g| {
            for k in 0..g.len {
                next.push(g.target[k]);
                prob.push(self.kappa);
                cost.push(g.d2[k]);
                if self.kappa < 1.0 {
                    g.off_target(k);
                    for l in (0..g.len).filter(|&l| l != k) {
                        next.push(g.target[l]);
                        prob.push((1.0 - self.kappa) * g.q[l]);
                        cost.push(g.d2[l]);
                    }
                }
                ends.push(next.len());
            }
        });
    }

    fn accumulate_state_grad(&self, s: usize, zeta: &[f64], prob: &[f64], cp: &[f64], cc: &[f64], grad: &mut [f64]) {
        let acts = self.valid_actions(s);
        let k_n = acts.len();
        // Every derivative here is a combination of ∂d_l (d_l = ‖x_{t_l} − x_s‖²): collect one
        // coefficient per target, then scatter the sparse ∂d_l once. The off-target
        // probabilities come from `prob`, so no exponential is recomputed.
        let mut coef = [0.0f64; crate::instance::MAX_UAVS];
        let mut o = 0;
        for k in 0..k_n {
            coef[k] += cc[o]; // target outcome: ∂p = 0, ∂c = ∂d_k
            o += 1;
            if self.kappa < 1.0 {
                // p_l = (1−κ) q_l and ∂p_l = η p_l (Σ_{l'} q_{l'} ∂d_{l'} − ∂d_l).
                let others = o..o + k_n - 1;
                let a_k: f64 = others.clone().map(|oo| cp[oo] * prob[oo]).sum::<f64>() / (1.0 - self.kappa);
                for (oo, l) in others.clone().zip((0..k_n).filter(|&l| l != k)) {
                    coef[l] += self.eta * prob[oo] * (a_k - cp[oo]) + cc[oo];
                }
                o = others.end;
            }
        }
        let xs = self.position(s, zeta);
        let is = self.zeta_index(s);
        for (l, &a) in acts.iter().enumerate() {
            if coef[l] == 0.0 {
                continue;
            }
            let t = self.action_target(a);
            let xt = self.position(t, zeta);
            let gx = 2.0 * coef[l] * (xt[0] - xs[0]);
            let gy = 2.0 * coef[l] * (xt[1] - xs[1]);
            if let Some(i) = self.zeta_index(t) {
                grad[i] += gx;
                grad[i + 1] += gy;
            }
            if let Some(i) = is {
                grad[i] -= gx;
                grad[i + 1] -= gy;
            }
        }
    }

    fn outcomes(&self, s: usize, a: usize, zeta: &[f64], grad: bool, out: &mut Outcomes) {
        out.clear();
        let d = self.zeta_dim();
        let k = self.valid_actions(s).iter().position(|&b| b == a).expect("valid action");
        let is = self.zeta_index(s);
        with_geometry(self, s, zeta, |g| {
            // Dense ∂d_l/∂ζ of target l, scaled, added into `row`.
            let add_dd = |row: &mut [f64], g: &StateGeometry, l: usize, scale: f64| {
                let gx = 2.0 * scale * (g.xt[l][0] - g.xs[0]);
                let gy = 2.0 * scale * (g.xt[l][1] - g.xs[1]);
                if let Some(i) = self.zeta_index(g.target[l]) {
                    row[i] += gx;
                    row[i + 1] += gy;
                }
                if let Some(i) = is {
                    row[i] -= gx;
                    row[i + 1] -= gy;
                }
            };
            let push = |out: &mut Outcomes, g: &StateGeometry, l: usize, p: f64| {
                out.next.push(g.target[l]);
                out.prob.push(p);
                out.cost.push(g.d2[l]);
                if grad {
                    let base = out.dcost.len();
                    out.dcost.resize(base + d, 0.0);
                    out.dprob.resize(base + d, 0.0);
                    add_dd(&mut out.dcost[base..base + d], g, l, 1.0);
                }
            };
            push(out, g, k, self.kappa);
            if self.kappa < 1.0 {
                g.off_target(k);
                let others: Vec<usize> = (0..g.len).filter(|&l| l != k).collect();
                for &l in &others {
                    push(out, g, l, (1.0 - self.kappa) * g.q[l]);
                }
                if grad {
                    // ∂p_l = (1−κ) η q_l (Σ_{l'} q_{l'} ∂d_{l'} − ∂d_l)
                    let mut mean = vec![0.0; d];
                    for &l in &others {
                        add_dd(&mut mean, g, l, g.q[l]);
                    }
                    for (o, &l) in others.iter().enumerate() {
                        let scale = (1.0 - self.kappa) * self.eta * g.q[l];
                        let row = &mut out.dprob[(o + 1) * d..(o + 2) * d];
                        for (r, m) in row.iter_mut().zip(&mean) {
                            *r += scale * m;
                        }
                        add_dd(row, g, l, -scale);
                    }
                }
            }
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::{Purpose, Streams};

    fn small(kappa: f64) -> UavNetwork {
        let inst =
            Instance { name: "t".into(), n_uav: 3, users: vec![[0.0, 0.0], [1.0, 0.5], [0.3, 1.2]], dest: [2.0, 2.0] };
        UavNetwork::new(inst, kappa, 100.0).unwrap()
    }
    const ZETA: [f64; 6] = [0.2, 0.1, 0.9, 0.9, 1.5, 1.4];

    #[test]
    fn layout_matches_the_paper() {
        let net = small(0.9);
        assert_eq!(net.n_states(), 3 + 3 + 1);
        assert_eq!(net.valid_actions(0), &[0, 1, 2]);
        assert_eq!(net.valid_actions(4), &[0, 2, 3]); // UAV 1: other UAVs + destination
        assert!(net.valid_actions(6).is_empty() && net.is_terminal(6));
    }

    #[test]
    fn rows_sum_to_one_and_kappa_one_is_deterministic() {
        let mut o = Outcomes::default();
        for kappa in [1.0, 0.85] {
            let net = small(kappa);
            for s in 0..6 {
                for &a in net.valid_actions(s) {
                    net.outcomes(s, a, &ZETA, false, &mut o);
                    let sum: f64 = o.prob.iter().sum();
                    assert!((sum - 1.0).abs() < 1e-15, "{sum}");
                    if kappa == 1.0 {
                        assert_eq!(o.next, vec![net.action_target(a)]);
                    }
                }
            }
        }
    }

    #[test]
    fn off_target_softmax_is_stable_for_large_eta() {
        // Targets far apart: the naive e/(Σe − e_a) form gives 0/0 here.
        let inst = Instance { name: "t".into(), n_uav: 3, users: vec![[0.0, 0.0]], dest: [50.0, 50.0] };
        let net = UavNetwork::new(inst, 0.5, 100.0).unwrap();
        let zeta = [0.1, 0.0, 30.0, 0.0, 31.0, 0.0];
        let mut o = Outcomes::default();
        net.outcomes(0, 0, &zeta, true, &mut o);
        assert!(o.prob.iter().chain(&o.dprob).all(|p| p.is_finite()));
        // The nearer of the two other UAVs takes essentially all the off-target mass.
        assert!((o.prob[1] - 0.5).abs() < 1e-12 && o.prob[2] < 1e-300);
    }

    #[test]
    fn derivatives_match_central_differences() {
        let mut o = Outcomes::default();
        let mut op = Outcomes::default();
        let mut om = Outcomes::default();
        let net = small(0.85);
        let d = net.zeta_dim();
        let h = 1e-6;
        for s in 0..6 {
            for &a in net.valid_actions(s) {
                net.outcomes(s, a, &ZETA, true, &mut o);
                for i in 0..d {
                    let mut zp = ZETA;
                    zp[i] += h;
                    let mut zm = ZETA;
                    zm[i] -= h;
                    net.outcomes(s, a, &zp, false, &mut op);
                    net.outcomes(s, a, &zm, false, &mut om);
                    for k in 0..o.len() {
                        let fp = (op.prob[k] - om.prob[k]) / (2.0 * h);
                        let fc = (op.cost[k] - om.cost[k]) / (2.0 * h);
                        assert!(
                            (fp - o.dprob[k * d + i]).abs() < 1e-6 * (1.0 + fp.abs()),
                            "dp s{s} a{a} o{k} i{i}: {fp} vs {}",
                            o.dprob[k * d + i]
                        );
                        assert!((fc - o.dcost[k * d + i]).abs() < 1e-6 * (1.0 + fc.abs()), "dc s{s} a{a} o{k} i{i}");
                    }
                }
            }
        }
    }

    #[test]
    fn shared_state_path_matches_per_action_outcomes_and_dense_gradients() {
        let mut o = Outcomes::default();
        for kappa in [1.0, 0.85] {
            let net = small(kappa);
            let d = net.zeta_dim();
            for s in 0..6 {
                let (mut next, mut prob, mut cost, mut ends) = (vec![], vec![], vec![], vec![]);
                net.state_outcomes(s, &ZETA, &mut next, &mut prob, &mut cost, &mut ends);
                // Arbitrary contraction coefficients.
                let cp: Vec<f64> = (0..next.len()).map(|i| (i as f64 * 0.7).sin()).collect();
                let cc: Vec<f64> = (0..next.len()).map(|i| (i as f64 * 1.3).cos()).collect();
                let mut dense = vec![0.0; d];
                let mut base = 0;
                for (k, &a) in net.valid_actions(s).iter().enumerate() {
                    net.outcomes(s, a, &ZETA, true, &mut o);
                    assert_eq!(ends[k], base + o.len());
                    for j in 0..o.len() {
                        assert_eq!(next[base + j], o.next[j]);
                        assert!((prob[base + j] - o.prob[j]).abs() <= 1e-15);
                        assert_eq!(cost[base + j], o.cost[j]);
                        for i in 0..d {
                            dense[i] += cp[base + j] * o.dprob[j * d + i] + cc[base + j] * o.dcost[j * d + i];
                        }
                    }
                    base += o.len();
                }
                let mut sparse = vec![0.0; d];
                net.accumulate_state_grad(s, &ZETA, &prob, &cp, &cc, &mut sparse);
                for i in 0..d {
                    assert!(
                        (sparse[i] - dense[i]).abs() <= 1e-12 * (1.0 + dense[i].abs()),
                        "s{s} i{i}: {} vs {}",
                        sparse[i],
                        dense[i]
                    );
                }
            }
        }
    }

    #[test]
    fn sampler_frequencies_match_the_model() {
        let net = small(0.7);
        let streams = Streams::new(3);
        let mut rng = streams.stream(Purpose::Other, 0, 0);
        let mut o = Outcomes::default();
        let (s, a) = (4, 2); // UAV 1 aiming at UAV 2
        net.outcomes(s, a, &ZETA, false, &mut o);
        let n = 200_000;
        let mut counts = vec![0usize; net.n_states()];
        for _ in 0..n {
            let (next, cost) = net.step(s, a, &ZETA, &mut rng);
            counts[next] += 1;
            let k = o.next.iter().position(|&t| t == next).unwrap();
            assert_eq!(cost, o.cost[k]);
        }
        for (k, &t) in o.next.iter().enumerate() {
            let p = o.prob[k];
            let se = (p * (1.0 - p) / n as f64).sqrt();
            let f = counts[t] as f64 / n as f64;
            assert!((f - p).abs() < 5.0 * se + 1e-9, "state {t}: {f} vs {p}");
        }
    }

    #[test]
    fn rejects_bad_kappa_and_eta() {
        let inst = small(1.0).instance().clone();
        for k in [0.0, -0.1, 1.01, f64::NAN] {
            assert!(UavNetwork::new(inst.clone(), k, 100.0).is_err());
        }
        assert!(UavNetwork::new(inst, 1.0, f64::INFINITY).is_err());
    }
}
