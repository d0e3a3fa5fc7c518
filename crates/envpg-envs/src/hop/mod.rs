//! [`HopNetwork`]: the kernel that the UAV relay network and facility location with path
//! optimisation share — states placed in the plane (fixed points, or points read from ζ), each
//! valid action aiming at a *target* state, and a hop that reaches its target with probability
//! κ and otherwise one of the state's *other* targets, drawn from the Gibbs distribution
//! `q(s') ∝ exp(−η‖x_{s'} − x_s‖²)`. The cost of a hop is the squared distance actually
//! travelled.
//!
//! A state with a single valid action always reaches its target (there is no other target to
//! deviate to).
//!
//! Besides the sampler and the model (with sparse ζ-derivatives), the network provides the
//! geometric features of a hop ([`HopFeatures`]), its design elements (every point read from ζ,
//! with the states placed there) and the relocation of an idle one to the midpoint of a hop; those
//! live in `observe`, the kernel's sampler and model here.

use envpg_core::{EnvRng, Outcomes};
use rand::RngExt;

mod observe;

pub use observe::HopFeatures;

/// Where a state sits.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Place {
    /// A fixed point.
    Fixed([f64; 2]),
    /// The point `(ζ[i], ζ[i+1])`.
    Zeta(usize),
}

/// The hop kernel over a fixed layout of states and targets (see the module docs).
#[derive(Debug, Clone)]
pub struct HopNetwork {
    n_actions: usize,
    kappa: f64,
    eta: f64,
    places: Vec<Place>,
    /// Valid actions per state, flattened; `ranges[s]` indexes into it and into `targets`.
    actions: Vec<usize>,
    /// The target state of each valid action.
    targets: Vec<usize>,
    ranges: Vec<(u32, u32)>,
    /// The target of `(s, a)` at `s · n_actions + a` (`u32::MAX`: invalid): the hot path's
    /// lookup.
    target_of: Vec<u32>,
}

/// Squared distance.
#[inline]
pub fn dist2(a: [f64; 2], b: [f64; 2]) -> f64 {
    let dx = a[0] - b[0];
    let dy = a[1] - b[1];
    dx * dx + dy * dy
}

impl HopNetwork {
    /// A network with `n_actions` global actions; state `s` sits at `places[s]` and allows the
    /// actions `moves[s]` as `(action, target state)` pairs in increasing action order (empty:
    /// terminal).
    pub fn new(n_actions: usize, kappa: f64, eta: f64, places: Vec<Place>, moves: Vec<Vec<(usize, usize)>>) -> Self {
        assert_eq!(places.len(), moves.len(), "one list of moves per state");
        let mut actions = Vec::new();
        let mut targets = Vec::new();
        let mut ranges = Vec::with_capacity(moves.len());
        for m in &moves {
            let start = actions.len() as u32;
            for &(a, t) in m {
                debug_assert!(a < n_actions && t < places.len());
                actions.push(a);
                targets.push(t);
            }
            ranges.push((start, actions.len() as u32));
        }
        let mut target_of = vec![u32::MAX; places.len() * n_actions];
        for (s, m) in moves.iter().enumerate() {
            for &(a, t) in m {
                target_of[s * n_actions + a] = t as u32;
            }
        }
        Self { n_actions, kappa, eta, places, actions, targets, ranges, target_of }
    }

    /// Number of states.
    pub fn n_states(&self) -> usize {
        self.places.len()
    }
    /// Number of global actions.
    pub fn n_actions(&self) -> usize {
        self.n_actions
    }
    /// κ.
    pub fn kappa(&self) -> f64 {
        self.kappa
    }
    /// η.
    pub fn eta(&self) -> f64 {
        self.eta
    }
    /// The valid actions of `s`.
    #[inline]
    pub fn valid_actions(&self, s: usize) -> &[usize] {
        let (a, b) = self.ranges[s];
        &self.actions[a as usize..b as usize]
    }
    /// The targets of the valid actions of `s`, in the same order.
    #[inline]
    pub fn targets(&self, s: usize) -> &[usize] {
        let (a, b) = self.ranges[s];
        &self.targets[a as usize..b as usize]
    }
    /// The target of action `a` in state `s`.
    #[inline]
    pub fn target(&self, s: usize, a: usize) -> usize {
        let t = self.target_of[s * self.n_actions + a];
        debug_assert!(t != u32::MAX, "action {a} invalid in state {s}");
        t as usize
    }
    /// Whether `s` is terminal (no valid action).
    pub fn is_terminal(&self, s: usize) -> bool {
        let (a, b) = self.ranges[s];
        a == b
    }
    /// Where `s` sits.
    pub fn place(&self, s: usize) -> Place {
        self.places[s]
    }

    /// The position of state `s` when the design is `zeta`.
    #[inline]
    pub fn position(&self, s: usize, zeta: &[f64]) -> [f64; 2] {
        match self.places[s] {
            Place::Fixed(p) => p,
            Place::Zeta(i) => [zeta[i], zeta[i + 1]],
        }
    }

    /// If the position of `s` is read from ζ, the index of its x-coordinate (y follows).
    #[inline]
    pub fn zeta_index(&self, s: usize) -> Option<usize> {
        match self.places[s] {
            Place::Fixed(_) => None,
            Place::Zeta(i) => Some(i),
        }
    }

    /// Centre and half-diagonal of the fixed positions: the observable geometry's origin and
    /// length scale.
    pub fn fixed_frame(&self) -> ([f64; 2], f64) {
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for p in &self.places {
            if let Place::Fixed(x) = p {
                for k in 0..2 {
                    lo[k] = lo[k].min(x[k]);
                    hi[k] = hi[k].max(x[k]);
                }
            }
        }
        let center = [(lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0];
        let scale = (((hi[0] - lo[0]).powi(2) + (hi[1] - lo[1]).powi(2)).sqrt() / 2.0).max(1e-9);
        (center, scale)
    }

    /// Whether an off-target move is possible from `s`.
    #[inline]
    fn deviates(&self, s: usize) -> bool {
        self.kappa < 1.0 && self.targets(s).len() > 1
    }

    /// One hop: the target of `a` with probability κ, otherwise another target of `s` from
    /// the off-target Gibbs kernel; the cost is the squared distance travelled.
    pub fn step(&self, s: usize, a: usize, zeta: &[f64], rng: &mut EnvRng) -> (usize, f64) {
        debug_assert!(self.valid_actions(s).contains(&a), "action {a} invalid in state {s}");
        // Exactly one uniform decides on-/off-target, and one more picks the off-target state,
        // so the stream's consumption does not depend on κ's value beyond that branch.
        let u: f64 = rng.random();
        let next = if u < self.kappa || !self.deviates(s) {
            self.target(s, a)
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

    /// The outcomes of every valid action of `s` (see `ModelMdp::state_outcomes`).
    pub fn state_outcomes(
        &self,
        s: usize,
        zeta: &[f64],
        next: &mut Vec<usize>,
        prob: &mut Vec<f64>,
        cost: &mut Vec<f64>,
        ends: &mut Vec<usize>,
    ) {
        if !self.deviates(s) {
            // Every hop reaches its target: no off-target kernel, so no geometry scratch.
            // Whole-slice extends: one capacity check per state, not per outcome.
            let xs = self.position(s, zeta);
            let targets = self.targets(s);
            let first = next.len();
            next.extend_from_slice(targets);
            prob.extend(std::iter::repeat_n(1.0, targets.len()));
            cost.extend(targets.iter().map(|&t| dist2(self.position(t, zeta), xs)));
            ends.extend(first + 1..=next.len());
            return;
        }
        with_geometry(self, s, zeta, |g| {
            for k in 0..g.len {
                next.push(g.target[k]);
                prob.push(self.kappa);
                cost.push(g.d2[k]);
                g.off_target(k);
                for l in (0..g.len).filter(|&l| l != k) {
                    next.push(g.target[l]);
                    prob.push((1.0 - self.kappa) * g.q[l]);
                    cost.push(g.d2[l]);
                }
                ends.push(next.len());
            }
        });
    }

    /// The outcomes of every state (see `ModelMdp::all_outcomes`). With κ = 1 every hop
    /// reaches its target: the outcomes are the targets themselves, and each position is
    /// computed once instead of once per hop that reaches it (per outcome, reading it was
    /// most of the expansion of a large network).
    pub fn all_outcomes(
        &self,
        zeta: &[f64],
        next: &mut Vec<usize>,
        prob: &mut Vec<f64>,
        cost: &mut Vec<f64>,
        ends: &mut Vec<usize>,
    ) {
        if self.kappa < 1.0 {
            for s in 0..self.n_states() {
                self.state_outcomes(s, zeta, next, prob, cost, ends);
            }
            return;
        }
        let first = next.len();
        next.extend_from_slice(&self.targets);
        self.outcome_values(zeta, prob, cost);
        ends.extend(first + 1..=next.len());
    }

    /// The probabilities and costs of [`HopNetwork::all_outcomes`] at κ = 1, where every hop
    /// reaches its target whatever ζ (see `ModelMdp::outcome_values`); `false` below κ = 1.
    pub fn outcome_values(&self, zeta: &[f64], prob: &mut Vec<f64>, cost: &mut Vec<f64>) -> bool {
        if self.kappa < 1.0 {
            return false;
        }
        let pos: Vec<[f64; 2]> = (0..self.n_states()).map(|s| self.position(s, zeta)).collect();
        prob.resize(prob.len() + self.targets.len(), 1.0);
        cost.reserve(self.targets.len());
        for (s, &xs) in pos.iter().enumerate() {
            cost.extend(self.targets(s).iter().map(|&t| dist2(pos[t], xs)));
        }
        true
    }

    /// The gradient contraction of every valid action of `s` (see
    /// `ModelMdp::accumulate_state_grad`).
    pub fn accumulate_state_grad(
        &self,
        s: usize,
        zeta: &[f64],
        prob: &[f64],
        cp: &[f64],
        cc: &[f64],
        grad: &mut [f64],
    ) {
        let targets = self.targets(s);
        let k_n = targets.len();
        // Every derivative here is a combination of ∂d_l (d_l = ‖x_{t_l} − x_s‖²): collect one
        // coefficient per target, then scatter the sparse ∂d_l once. The off-target
        // probabilities come from `prob`, so no exponential is recomputed.
        if !self.deviates(s) {
            // One outcome per target, its own (∂p = 0, ∂c = ∂d_k): the coefficients are `cc`
            // itself, with no scratch to zero (a third of this call's cost at κ = 1).
            self.scatter_distance_grads(s, zeta, cc, grad);
            return;
        }
        // Zeroing a scratch sized for the largest network on every call showed in profiles.
        let mut small = [0.0f64; 32];
        let mut large = Vec::new();
        let coef: &mut [f64] = if k_n <= small.len() {
            &mut small[..k_n]
        } else {
            large.resize(k_n, 0.0);
            &mut large
        };
        let mut o = 0;
        for k in 0..k_n {
            coef[k] += cc[o]; // target outcome: ∂p = 0, ∂c = ∂d_k
            o += 1;
            // p_l = (1−κ) q_l and ∂p_l = η p_l (Σ_{l'} q_{l'} ∂d_{l'} − ∂d_l).
            let others = o..o + k_n - 1;
            let a_k: f64 = others.clone().map(|oo| cp[oo] * prob[oo]).sum::<f64>() / (1.0 - self.kappa);
            for (oo, l) in others.clone().zip((0..k_n).filter(|&l| l != k)) {
                coef[l] += self.eta * prob[oo] * (a_k - cp[oo]) + cc[oo];
            }
            o = others.end;
        }
        self.scatter_distance_grads(s, zeta, coef, grad);
    }

    /// Adds `Σ_l coef[l] ∂d_l/∂ζ` to `grad`, `d_l` the squared distance from `s` to its `l`-th
    /// target.
    fn scatter_distance_grads(&self, s: usize, zeta: &[f64], coef: &[f64], grad: &mut [f64]) {
        let xs = self.position(s, zeta);
        let is = self.zeta_index(s);
        for (&c, &t) in coef.iter().zip(self.targets(s)) {
            if c == 0.0 {
                continue;
            }
            // One look at where `t` sits gives both its position and its coordinates in ζ. A
            // point's two coordinates as one two-wide slice: one bounds check, not two.
            let (xt, it) = match self.places[t] {
                Place::Fixed(p) => (p, None),
                Place::Zeta(i) => {
                    let z = &zeta[i..i + 2];
                    ([z[0], z[1]], Some(i))
                }
            };
            let gx = 2.0 * c * (xt[0] - xs[0]);
            let gy = 2.0 * c * (xt[1] - xs[1]);
            if let Some(i) = it {
                let g = &mut grad[i..i + 2];
                g[0] += gx;
                g[1] += gy;
            }
            if let Some(i) = is {
                let g = &mut grad[i..i + 2];
                g[0] -= gx;
                g[1] -= gy;
            }
        }
    }

    /// The outcomes of `(s, a)`, with dense derivatives when `grad` (see `ModelMdp::outcomes`).
    pub fn outcomes(&self, s: usize, a: usize, zeta: &[f64], grad: bool, out: &mut Outcomes) {
        out.clear();
        let d = zeta.len();
        let k = self.valid_actions(s).iter().position(|&b| b == a).expect("valid action");
        let is = self.zeta_index(s);
        let deviates = self.deviates(s);
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
                out.push(g.target[l], p, g.d2[l], grad, d);
                if grad {
                    add_dd(out.last_dcost(d), g, l, 1.0);
                }
            };
            push(out, g, k, if deviates { self.kappa } else { 1.0 });
            if deviates {
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

/// The model paths of an environment that is a [`HopNetwork`] in its field `hop` (`outcomes`,
/// `state_outcomes`, `all_outcomes`, `outcome_values`, `accumulate_state_grad`), for use inside
/// its `impl ModelMdp`: the UAV network and flpo share the kernel, so they share these too.
macro_rules! hop_model_paths {
    () => {
        fn outcomes(&self, s: usize, a: usize, zeta: &[f64], grad: bool, out: &mut envpg_core::Outcomes) {
            self.hop.outcomes(s, a, zeta, grad, out)
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
            self.hop.state_outcomes(s, zeta, next, prob, cost, ends)
        }
        fn all_outcomes(
            &self,
            zeta: &[f64],
            next: &mut Vec<usize>,
            prob: &mut Vec<f64>,
            cost: &mut Vec<f64>,
            ends: &mut Vec<usize>,
        ) {
            self.hop.all_outcomes(zeta, next, prob, cost, ends)
        }
        fn outcome_values(&self, zeta: &[f64], prob: &mut Vec<f64>, cost: &mut Vec<f64>) -> bool {
            self.hop.outcome_values(zeta, prob, cost)
        }
        fn accumulate_state_grad(
            &self,
            s: usize,
            zeta: &[f64],
            prob: &[f64],
            cp: &[f64],
            cc: &[f64],
            grad: &mut [f64],
        ) {
            self.hop.accumulate_state_grad(s, zeta, prob, cp, cc, grad)
        }
    };
}
pub(crate) use hop_model_paths;

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
fn with_geometry<R>(net: &HopNetwork, s: usize, zeta: &[f64], f: impl FnOnce(&mut StateGeometry) -> R) -> R {
    GEOMETRY.with(|cell| {
        let mut g = cell.borrow_mut();
        g.fill(net, s, zeta);
        f(&mut g)
    })
}

impl StateGeometry {
    fn fill(&mut self, net: &HopNetwork, s: usize, zeta: &[f64]) {
        let xs = net.position(s, zeta);
        let targets = net.targets(s);
        self.len = targets.len();
        self.xs = xs;
        self.target.clear();
        self.xt.clear();
        self.d2.clear();
        for &t in targets {
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
