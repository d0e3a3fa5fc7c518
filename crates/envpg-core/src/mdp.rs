//! The two views of a finite parameterized MDP: the black-box sampler ([`ParamMdp`]) and the
//! model ([`ModelMdp`]). States and actions are dense indices; actions are *global* indices
//! (`0..n_actions`) of which each state allows a subset.
//!
//! Both traits are object safe: envpg's tools hold environments as `dyn` trait objects built by
//! a [`crate::Registry`], and algorithms are generic over `E: ParamMdp + ?Sized`, so they run on
//! a concrete type as well as on a registered one.

use std::ops::Range;

use crate::rng::StreamRng;
use crate::zeta::ZetaSpace;

/// The randomness an environment draws from: one of envpg's reproducible streams (ChaCha12),
/// always supplied by the caller, so that the same episode replays bit for bit wherever it
/// runs. Draw from it with [`rand::RngExt`] (`rng.random::<f64>()`, `rng.random_range(0..n)`).
pub type EnvRng = StreamRng;

/// A finite MDP whose dynamics depend on a real parameter vector ζ, seen as a black box.
///
/// This is everything model-free code may use: which actions are valid, where episodes start,
/// when they end, what one step at a given ζ returns, and a few optional hooks whose defaults
/// suit any environment. The sampler is only ever called with a ζ inside
/// [`ParamMdp::zeta_space`]'s bounds.
pub trait ParamMdp: Send + Sync {
    /// Number of states `|S|`.
    fn n_states(&self) -> usize;
    /// Number of global actions `|A|`.
    fn n_actions(&self) -> usize;
    /// The design space: ζ's dimension, coordinate names and box bounds.
    fn zeta_space(&self) -> &ZetaSpace;
    /// The valid actions of `s`, in increasing order; empty exactly for terminal states.
    fn valid_actions(&self, s: usize) -> &[usize];
    /// Whether `s` is terminal (absorbing and cost-free).
    fn is_terminal(&self, s: usize) -> bool;
    /// Draws an initial state from μ.
    fn sample_initial(&self, rng: &mut EnvRng) -> usize;
    /// Takes action `a` in state `s` with the environment at parameter `zeta`; returns the
    /// successor state and the cost of the transition. All randomness comes from `rng`.
    fn step(&self, s: usize, a: usize, zeta: &[f64], rng: &mut EnvRng) -> (usize, f64);

    /// Discount factor γ ∈ (0, 1]; γ = 1 (the default) is a stochastic shortest path problem,
    /// which needs cost-free terminal states that every proper policy reaches.
    fn gamma(&self) -> f64 {
        1.0
    }
    /// Dimension of ζ.
    fn zeta_dim(&self) -> usize {
        self.zeta_space().dim()
    }

    /// Hook: a start state for *exploring starts* — a non-terminal state outside μ's usual
    /// reach that a simulator can be put in directly. Defaults to [`ParamMdp::sample_initial`].
    fn sample_exploring_start(&self, rng: &mut EnvRng) -> usize {
        self.sample_initial(rng)
    }
    /// Hook: the order of magnitude of one episode's cost, from observable data (for the UAV
    /// network, the squared extent of users and destination). Scale-free settings of Algorithm 1
    /// give temperatures in this unit, and the oracle's default temperatures derive from it.
    /// Defaults to 1.
    fn cost_scale(&self) -> f64 {
        1.0
    }
    /// Hook: a random initial design (the `random` ζ₀ of Algorithm 1 and of the oracle's
    /// restarts). Defaults to [`ZetaSpace::sample`]: uniform over the bounds.
    fn random_design(&self, rng: &mut EnvRng) -> Vec<f64> {
        self.zeta_space().sample(rng)
    }
    /// Hook: a random design drawn from the problem's structure rather than uniformly, from
    /// observable data only — for the UAV network, UAVs at the k-means centres of the users from
    /// a k-means++ seeding, so that different draws give different clusterings. The oracle's
    /// portfolio starts its warm restarts there, and Algorithm 1's `clustered` ζ₀ is one draw.
    /// `None` (the default) when the environment has none.
    fn clustered_design(&self, _rng: &mut EnvRng) -> Option<Vec<f64>> {
        None
    }
    /// Hook: a problem-specific initial design built from observable data only (the `env` ζ₀),
    /// if the environment has one.
    fn heuristic_design(&self) -> Option<Vec<f64>> {
        None
    }
    /// Hook: the *design elements* — groups of ζ coordinates that place something the process
    /// visits (a relay, a facility), with the states that visit it. Algorithm 1 tracks their
    /// visits to find idle ones (see [`ParamMdp::relocate`]) and routes the ζ input by them.
    fn design_elements(&self) -> Vec<DesignElement> {
        Vec::new()
    }
    /// Hook: new coordinates for the idle design element `element` that would serve the hop
    /// `from → to` observed in an episode (Algorithm 1's relocation of idle elements, whose
    /// ζ-gradient is exactly zero). `None`: leave it where it is (the default).
    fn relocate(&self, element: &DesignElement, zeta: &[f64], from: usize, to: usize) -> Option<Vec<f64>> {
        let _ = (element, zeta, from, to);
        None
    }
}

/// A group of ζ coordinates that places something the process visits (see
/// [`ParamMdp::design_elements`]).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct DesignElement {
    /// Its coordinates in ζ.
    pub coords: Range<usize>,
    /// The states at which the process is *at* this element (one for a relay; a facility that
    /// several destinations share has one state per destination).
    pub states: Vec<usize>,
}

/// The outcomes of one state–action pair at one ζ, optionally with their ζ-derivatives.
///
/// Buffers are reused between calls; `dprob`/`dcost` are row-major `len() × zeta_dim`.
#[derive(Debug, Clone, Default)]
pub struct Outcomes {
    /// Successor states with non-zero probability.
    pub next: Vec<usize>,
    /// `p_ζ(next | s, a)`.
    pub prob: Vec<f64>,
    /// `c_ζ(s, a, next)`.
    pub cost: Vec<f64>,
    /// `∂p/∂ζ`, filled only when gradients are requested.
    pub dprob: Vec<f64>,
    /// `∂c/∂ζ`, filled only when gradients are requested.
    pub dcost: Vec<f64>,
}

impl Outcomes {
    /// Number of outcomes.
    pub fn len(&self) -> usize {
        self.next.len()
    }

    /// Whether there are no outcomes.
    pub fn is_empty(&self) -> bool {
        self.next.is_empty()
    }

    /// Empties the buffers, keeping their capacity.
    pub fn clear(&mut self) {
        self.next.clear();
        self.prob.clear();
        self.cost.clear();
        self.dprob.clear();
        self.dcost.clear();
    }

    /// Appends one outcome; with `grad`, also zeroed derivative rows of length `d` that the
    /// caller fills through [`Outcomes::last_dprob`] and [`Outcomes::last_dcost`].
    pub fn push(&mut self, next: usize, prob: f64, cost: f64, grad: bool, d: usize) {
        self.next.push(next);
        self.prob.push(prob);
        self.cost.push(cost);
        if grad {
            self.dprob.resize(self.dprob.len() + d, 0.0);
            self.dcost.resize(self.dcost.len() + d, 0.0);
        }
    }

    /// `∂p/∂ζ` of the last outcome pushed.
    pub fn last_dprob(&mut self, d: usize) -> &mut [f64] {
        let n = self.dprob.len();
        &mut self.dprob[n - d..]
    }

    /// `∂c/∂ζ` of the last outcome pushed.
    pub fn last_dcost(&mut self, d: usize) -> &mut [f64] {
        let n = self.dcost.len();
        &mut self.dcost[n - d..]
    }
}

/// Scales from which the oracle derives its default temperatures and horizon
/// ([`ModelMdp::oracle_hints`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OracleHints {
    /// A typical cost of one episode (for the UAV network, the squared extent of the
    /// instance): the hot start of deterministic annealing is ten times this.
    pub cost_scale: f64,
    /// Starting temperature of warm restarts.
    pub warm_alpha0: f64,
    /// Last positive temperature.
    pub alpha_min: f64,
    /// Stages of the finite-horizon form (enough for every simple path through the states
    /// that loop).
    pub horizon: usize,
}

impl OracleHints {
    /// Hints proportional to `cost_scale`: warm restarts start at `cost_scale / 160` and the
    /// last temperature is `cost_scale / 80 000`.
    pub fn from_cost_scale(cost_scale: f64, horizon: usize) -> Self {
        Self { cost_scale, warm_alpha0: cost_scale / 160.0, alpha_min: cost_scale / 80_000.0, horizon }
    }
}

/// The model view of a [`ParamMdp`]: exact transition probabilities, costs and derivatives.
///
/// Used by the exact evaluator and the oracle (`envpg-model`), never by model-free training.
pub trait ModelMdp: ParamMdp {
    /// The initial-state distribution μ as `(state, probability)` pairs.
    fn initial_distribution(&self) -> Vec<(usize, f64)>;

    /// Fills `out` with the outcomes of `(s, a)` at `zeta`; with `grad`, also `∂p/∂ζ`, `∂c/∂ζ`.
    /// Outcomes with probability exactly zero may be omitted (their derivative must then be
    /// zero too).
    fn outcomes(&self, s: usize, a: usize, zeta: &[f64], grad: bool, out: &mut Outcomes);

    /// Appends the outcomes of every valid action of `s`, in order, to `next`/`prob`/`cost`,
    /// and to `ends` the length of `next` after each action. All four may hold other states'
    /// entries already (the exact evaluator appends state after state): append, never clear.
    ///
    /// The default calls [`ModelMdp::outcomes`] per action; models override it to share work
    /// between the actions of one state.
    fn state_outcomes(
        &self,
        s: usize,
        zeta: &[f64],
        next: &mut Vec<usize>,
        prob: &mut Vec<f64>,
        cost: &mut Vec<f64>,
        ends: &mut Vec<usize>,
    ) {
        let mut buf = Outcomes::default();
        for &a in self.valid_actions(s) {
            self.outcomes(s, a, zeta, false, &mut buf);
            next.extend_from_slice(&buf.next);
            prob.extend_from_slice(&buf.prob);
            cost.extend_from_slice(&buf.cost);
            ends.push(next.len());
        }
    }

    /// Appends the outcomes of every state, in state order, exactly as
    /// [`ModelMdp::state_outcomes`] called for each state in turn would (the same values, bit
    /// for bit): how the exact evaluator expands a whole model at one ζ.
    ///
    /// The default does just that; models override it to share work between states (the UAV
    /// network computes each position once, not once per hop that reaches it).
    fn all_outcomes(
        &self,
        zeta: &[f64],
        next: &mut Vec<usize>,
        prob: &mut Vec<f64>,
        cost: &mut Vec<f64>,
        ends: &mut Vec<usize>,
    ) {
        for s in 0..self.n_states() {
            self.state_outcomes(s, zeta, next, prob, cost, ends);
        }
    }

    /// Appends the probabilities and costs of every outcome, exactly as
    /// [`ModelMdp::all_outcomes`] would (bit for bit), and returns `true` — for models whose
    /// successors and outcome counts are the same at every ζ, which then need not be expanded
    /// again at each design. The default appends nothing and returns `false`, and the whole
    /// model is expanded with [`ModelMdp::all_outcomes`].
    ///
    /// The oracle expands a model at every design it evaluates; for the UAV network at κ = 1
    /// (every hop reaches its target) this skips writing and comparing the successors of every
    /// pair each time.
    fn outcome_values(&self, zeta: &[f64], prob: &mut Vec<f64>, cost: &mut Vec<f64>) -> bool {
        let _ = (zeta, prob, cost);
        false
    }

    /// Adds `Σ_o (cp[o]·∂p_o/∂ζ + cc[o]·∂c_o/∂ζ)` over the outcomes of every valid action of `s`
    /// (in [`ModelMdp::state_outcomes`] order) to `grad`; `prob` are those outcomes'
    /// probabilities at `zeta`, as [`ModelMdp::state_outcomes`] returned them.
    ///
    /// This contraction is all the exact gradients need, so models can exploit the sparsity of
    /// their derivatives instead of materialising them. The default uses
    /// [`ModelMdp::outcomes`] with gradients.
    fn accumulate_state_grad(&self, s: usize, zeta: &[f64], prob: &[f64], cp: &[f64], cc: &[f64], grad: &mut [f64]) {
        let _ = prob;
        let d = zeta.len();
        let mut buf = Outcomes::default();
        let mut base = 0;
        for &a in self.valid_actions(s) {
            self.outcomes(s, a, zeta, true, &mut buf);
            for k in 0..buf.len() {
                let (x, y) = (cp[base + k], cc[base + k]);
                if x == 0.0 && y == 0.0 {
                    continue;
                }
                for i in 0..d {
                    grad[i] += x * buf.dprob[k * d + i] + y * buf.dcost[k * d + i];
                }
            }
            base += buf.len();
        }
    }

    /// Hook: the scales of the oracle's defaults. The default derives them from
    /// [`ParamMdp::cost_scale`], with a horizon of one stage per non-terminal state (at most 64).
    fn oracle_hints(&self) -> OracleHints {
        let live = (0..self.n_states()).filter(|&s| !self.is_terminal(s)).count();
        OracleHints::from_cost_scale(self.cost_scale(), live.clamp(1, 64))
    }
}
