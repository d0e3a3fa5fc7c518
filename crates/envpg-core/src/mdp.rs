//! The two views of a finite parameterized MDP: the black-box sampler ([`ParamMdp`]) and the
//! model ([`ModelMdp`]). States and actions are dense indices; actions are *global* indices
//! (`0..n_actions`) of which each state allows a subset.

use rand::Rng;

/// A finite MDP whose dynamics depend on a real parameter vector ζ, seen as a black box.
///
/// This is everything model-free code may use: which actions are valid, where episodes start,
/// when they end and what one step at a given ζ returns.
pub trait ParamMdp {
    /// Number of states `|S|`.
    fn n_states(&self) -> usize;
    /// Number of global actions `|A|`.
    fn n_actions(&self) -> usize;
    /// Dimension of ζ.
    fn zeta_dim(&self) -> usize;
    /// The valid actions of `s`, in increasing order; empty exactly for terminal states.
    fn valid_actions(&self, s: usize) -> &[usize];
    /// Whether `s` is terminal (absorbing and cost-free).
    fn is_terminal(&self, s: usize) -> bool;
    /// Draws an initial state from μ.
    fn sample_initial<R: Rng + ?Sized>(&self, rng: &mut R) -> usize;
    /// Draws a start state for *exploring starts*: a non-terminal state outside μ's usual
    /// reach that a simulator can be put in directly. Defaults to [`ParamMdp::sample_initial`].
    fn sample_exploring_start<R: Rng + ?Sized>(&self, rng: &mut R) -> usize {
        self.sample_initial(rng)
    }
    /// Takes action `a` in state `s` with the environment at parameter `zeta`; returns the
    /// successor state and the cost of the transition.
    fn step<R: Rng + ?Sized>(&self, s: usize, a: usize, zeta: &[f64], rng: &mut R) -> (usize, f64);
    /// Discount factor γ ∈ (0, 1]; γ = 1 is a stochastic shortest path problem.
    fn gamma(&self) -> f64;
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
}

/// The model view of a [`ParamMdp`]: exact transition probabilities, costs and derivatives.
pub trait ModelMdp: ParamMdp {
    /// The initial-state distribution μ as `(state, probability)` pairs.
    fn initial_distribution(&self) -> Vec<(usize, f64)>;

    /// Fills `out` with the outcomes of `(s, a)` at `zeta`; with `grad`, also `∂p/∂ζ`, `∂c/∂ζ`.
    /// Outcomes with probability exactly zero may be omitted (their derivative must then be
    /// zero too).
    fn outcomes(&self, s: usize, a: usize, zeta: &[f64], grad: bool, out: &mut Outcomes);

    /// Appends the outcomes of every valid action of `s`, in order, to `next`/`prob`/`cost`;
    /// `ends[k]` receives the running outcome count after action `k`.
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
}

/// What a learner may observe about states and actions beyond their indices: 2-D positions.
///
/// For the UAV network the positions of UAV states *are* entries of ζ, so a learner's features
/// move with ζ; [`Observable::zeta_index`] tells which entries, so input gradients can be routed
/// back to ζ.
pub trait Observable: ParamMdp {
    /// The state an action aims at (its *target*).
    fn action_target(&self, a: usize) -> usize;
    /// The position of state `s` when the design is `zeta`.
    fn position(&self, s: usize, zeta: &[f64]) -> [f64; 2];
    /// If the position of `s` is read from ζ, the index of its x-coordinate (y follows).
    fn zeta_index(&self, s: usize) -> Option<usize>;
}
