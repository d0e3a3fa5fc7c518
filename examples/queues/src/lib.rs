//! # envpg-example-queues
//!
//! A co-design problem from outside geometry, written against envpg's public API only: two
//! servers in parallel, each with a queue of at most `buffer` jobs. A job arrives with
//! probability λ per step and the policy routes it — to server 1, to server 2, or away
//! (rejected, at a cost). Each busy server finishes its current job with probability ζ_j, its
//! *speed*: the design. Speed costs `w_j ζ_j²` per step, waiting costs `h` per job and step, a
//! rejection `r`. The speeds and the routing are learned together; costs are discounted (γ).
//!
//! - States: `q₁ · (buffer + 1) + q₂` for queue lengths `q₁, q₂ ∈ 0..=buffer`; none is
//!   terminal. μ: both queues empty.
//! - Actions: `0` = to server 1, `1` = to server 2 (each only while its queue has room),
//!   `2` = reject.
//! - Step: arrival A ~ Bernoulli(λ), departures D_j ~ Bernoulli(ζ_j) from busy servers; then
//!   `q_j ← q_j − D_j + A·[a = j]`. Cost `h(q₁ + q₂) + w₁ζ₁² + w₂ζ₂² + rλ[a = reject]`.
//! - ζ = (ζ₁, ζ₂) ∈ [0.05, 0.95]².
//!
//! [`Queues`] implements the sampler ([`ParamMdp`]), the model ([`ModelMdp`]) and [`EnvSpec`];
//! [`QueuesSim`] is the same system as a black box (no model): Algorithm 1 trains on it, the
//! oracle and exact evaluation refuse it. [`registry`] is envpg's registry with both added,
//! with their settings ([`PRESETS`]), which the crate's two binaries run: `queues-launch` (the
//! launcher) and `queues-tools` (oracle, evaluate, table, plot, sweep).
//!
//! ```
//! use envpg_core::{Outcomes, Purpose, Streams};
//!
//! let registry = envpg_example_queues::registry();
//! let env = registry.load("queues", &[("lambda".into(), 0.8)])?;
//! assert_eq!((env.name, env.param("lambda")), ("queues", Some(0.8)));
//! let (sim, model) = (env.sampler(), env.model()?);
//! assert_eq!(sim.n_states(), 25); // queue lengths 0..=4 each (buffer 4)
//! let (s, zeta) = (6, [0.5, 0.7]); // one job at each server: q = (1, 1)
//! assert_eq!(sim.valid_actions(s), [0, 1, 2]);
//! let mut rng = Streams::new(1).stream(Purpose::Other, 0, 0);
//! let (next, cost) = sim.step(s, 0, &zeta, &mut rng); // an arriving job goes to server 1
//! assert!((cost - (2.0 + 2.0 * 0.25 + 2.5 * 0.49)).abs() < 1e-12); // h(q₁ + q₂) + w₁ζ₁² + w₂ζ₂²
//! // The model agrees: the sampled state is a possible outcome, and the outcomes sum to 1.
//! let mut out = Outcomes::default();
//! model.outcomes(s, 0, &zeta, false, &mut out);
//! assert!(out.next.iter().zip(&out.prob).any(|(&t, &p)| t == next && p > 0.0));
//! assert!((out.prob.iter().sum::<f64>() - 1.0).abs() < 1e-12);
//! // The simulator-only variant trains too, but has no model to score it.
//! assert!(registry.load("queues-sim", &[])?.model().is_err());
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use envpg_core::{
    Env, EnvRng, EnvSpec, InstanceError, InstanceFile, ModelMdp, OracleHints, Outcomes, ParamMdp, ParamSpec, Registry,
    ZetaSpace,
};
use rand::RngExt;

/// The example instance, `instances/queues.json`.
pub const INSTANCE: &str = include_str!("../instances/queues.json");
/// The same instance for the simulator without a model, `instances/queues-sim.json`.
pub const INSTANCE_SIM: &str = include_str!("../instances/queues-sim.json");
/// Algorithm 1's settings for both, `presets.toml` (envpg's `default` with a wider σ).
pub const PRESETS: &str = include_str!("../presets.toml");

/// Two servers with designed speeds (see the crate docs).
#[derive(Debug, Clone)]
pub struct Queues {
    buffer: usize,
    lambda: f64,
    hold: f64,
    w: [f64; 2],
    reject: f64,
    gamma: f64,
    space: ZetaSpace,
    /// Valid actions per state.
    actions: Vec<Vec<usize>>,
}

impl Queues {
    /// The queue lengths of state `s`.
    pub fn lengths(&self, s: usize) -> [usize; 2] {
        [s / (self.buffer + 1), s % (self.buffer + 1)]
    }
    /// The state with queue lengths `q`.
    pub fn state(&self, q: [usize; 2]) -> usize {
        q[0] * (self.buffer + 1) + q[1]
    }
    /// The cost of taking `a` in `s` at design `zeta` (it does not depend on the outcome).
    fn cost(&self, s: usize, a: usize, zeta: &[f64]) -> f64 {
        let [q1, q2] = self.lengths(s);
        let speed = self.w[0] * zeta[0] * zeta[0] + self.w[1] * zeta[1] * zeta[1];
        self.hold * (q1 + q2) as f64 + speed + if a == 2 { self.reject * self.lambda } else { 0.0 }
    }
    /// The next state for arrival `arrive` and departures `d`.
    fn next(&self, s: usize, a: usize, arrive: bool, d: [bool; 2]) -> usize {
        let mut q = self.lengths(s);
        for j in 0..2 {
            q[j] -= usize::from(d[j] && q[j] > 0);
        }
        if arrive && a < 2 {
            q[a] += 1;
        }
        self.state(q)
    }
}

impl EnvSpec for Queues {
    const NAME: &'static str = "queues";
    const ABOUT: &'static str = "two servers whose speeds are designed, jobs routed between them (discounted)";

    fn params() -> Vec<ParamSpec> {
        vec![
            ParamSpec { name: "lambda", default: 0.6, about: "arrival probability per step" },
            ParamSpec { name: "hold", default: 1.0, about: "cost per waiting job and step" },
            ParamSpec { name: "w1", default: 2.0, about: "cost of speed ζ₁ per step: w₁ζ₁²" },
            ParamSpec { name: "w2", default: 2.5, about: "cost of speed ζ₂ per step: w₂ζ₂²" },
            ParamSpec { name: "reject", default: 8.0, about: "cost of a rejected job" },
            ParamSpec { name: "gamma", default: 0.95, about: "discount factor in (0, 1)" },
        ]
    }

    fn from_instance(file: &InstanceFile) -> Result<Self, InstanceError> {
        file.expect_fields(&["buffer"])?;
        let buffer: usize = file.field("buffer")?;
        if !(1..=50).contains(&buffer) {
            return Err(file.invalid("buffer", format!("must be in 1..=50, got {buffer}")));
        }
        let p = |k: &str| file.param(k);
        let (lambda, gamma) = (p("lambda")?, p("gamma")?);
        if !(0.0..=1.0).contains(&lambda) {
            return Err(file.invalid("params.lambda", format!("must be in [0, 1], got {lambda}")));
        }
        if !(gamma > 0.0 && gamma < 1.0) {
            return Err(file.invalid("params.gamma", format!("must be in (0, 1), got {gamma}")));
        }
        for k in ["hold", "w1", "w2", "reject"] {
            if p(k)? < 0.0 {
                return Err(file.invalid(&format!("params.{k}"), "must be >= 0".into()));
            }
        }
        let names = vec!["speed1".into(), "speed2".into()];
        let space =
            ZetaSpace::new(names, vec![0.05; 2], vec![0.95; 2]).map_err(|e| file.invalid("params", e.to_string()))?;
        let mut env = Queues {
            buffer,
            lambda,
            hold: p("hold")?,
            w: [p("w1")?, p("w2")?],
            reject: p("reject")?,
            gamma,
            space,
            actions: Vec::new(),
        };
        env.actions = (0..(buffer + 1) * (buffer + 1))
            .map(|s| {
                let q = env.lengths(s);
                (0..3).filter(|&a| a == 2 || q[a] < buffer).collect()
            })
            .collect();
        Ok(env)
    }
}

impl ParamMdp for Queues {
    fn n_states(&self) -> usize {
        (self.buffer + 1) * (self.buffer + 1)
    }
    fn n_actions(&self) -> usize {
        3
    }
    fn zeta_space(&self) -> &ZetaSpace {
        &self.space
    }
    fn valid_actions(&self, s: usize) -> &[usize] {
        &self.actions[s]
    }
    fn is_terminal(&self, _s: usize) -> bool {
        false
    }
    fn gamma(&self) -> f64 {
        self.gamma
    }
    fn sample_initial(&self, _rng: &mut EnvRng) -> usize {
        0
    }
    /// Any state: a simulator can be started with jobs already waiting.
    fn sample_exploring_start(&self, rng: &mut EnvRng) -> usize {
        rng.random_range(0..self.n_states())
    }
    /// Costs of the order of a discounted horizon of waiting jobs.
    fn cost_scale(&self) -> f64 {
        self.hold * self.buffer as f64 / (1.0 - self.gamma)
    }
    fn step(&self, s: usize, a: usize, zeta: &[f64], rng: &mut EnvRng) -> (usize, f64) {
        // Three uniforms per step, whatever happens: the stream's use does not depend on ζ.
        let arrive = rng.random::<f64>() < self.lambda;
        let d = [rng.random::<f64>() < zeta[0], rng.random::<f64>() < zeta[1]];
        (self.next(s, a, arrive, d), self.cost(s, a, zeta))
    }
}

impl ModelMdp for Queues {
    fn initial_distribution(&self) -> Vec<(usize, f64)> {
        vec![(0, 1.0)]
    }

    /// Every (arrival, departures) combination, merged by next state.
    fn outcomes(&self, s: usize, a: usize, zeta: &[f64], grad: bool, out: &mut Outcomes) {
        out.clear();
        let cost = self.cost(s, a, zeta);
        let busy = self.lengths(s).map(|q| q > 0);
        for arrive in [false, true] {
            for d1 in [false, true] {
                for d2 in [false, true] {
                    if (d1 && !busy[0]) || (d2 && !busy[1]) {
                        continue;
                    }
                    // P = P(A) · P(D₁) · P(D₂), with P(D_j) = ζ_j or 1 − ζ_j for a busy server.
                    let pa = if arrive { self.lambda } else { 1.0 - self.lambda };
                    let f = |on: bool, busy: bool, z: f64| {
                        if !busy {
                            1.0
                        } else if on {
                            z
                        } else {
                            1.0 - z
                        }
                    };
                    let df = |on: bool, busy: bool| {
                        if !busy {
                            0.0
                        } else if on {
                            1.0
                        } else {
                            -1.0
                        }
                    };
                    let (f1, f2) = (f(d1, busy[0], zeta[0]), f(d2, busy[1], zeta[1]));
                    let next = self.next(s, a, arrive, [d1, d2]);
                    let k = match out.next.iter().position(|&t| t == next) {
                        Some(k) => k,
                        None => {
                            out.push(next, 0.0, cost, grad, 2);
                            if grad {
                                out.last_dcost(2)
                                    .copy_from_slice(&[2.0 * self.w[0] * zeta[0], 2.0 * self.w[1] * zeta[1]]);
                            }
                            out.len() - 1
                        }
                    };
                    out.prob[k] += pa * f1 * f2;
                    if grad {
                        out.dprob[2 * k] += pa * df(d1, busy[0]) * f2;
                        out.dprob[2 * k + 1] += pa * f1 * df(d2, busy[1]);
                    }
                }
            }
        }
    }

    /// The horizon of a discounted problem: 3 / (1 − γ) stages carry all but e⁻³ of the cost.
    fn oracle_hints(&self) -> OracleHints {
        OracleHints::from_cost_scale(self.cost_scale(), (3.0 / (1.0 - self.gamma)).ceil() as usize)
    }
}

impl Env for Queues {
    fn model(&self) -> Option<&dyn ModelMdp> {
        Some(self)
    }
}

/// The queues as a simulator only: a user's black box, without the model. Every result's `J`
/// is then null (nothing can score it exactly), and the oracle refuses it.
#[derive(Debug, Clone)]
pub struct QueuesSim(Queues);

impl EnvSpec for QueuesSim {
    const NAME: &'static str = "queues-sim";
    const ABOUT: &'static str = "the queues as a black-box simulator (no model)";
    fn params() -> Vec<ParamSpec> {
        Queues::params()
    }
    fn from_instance(file: &InstanceFile) -> Result<Self, InstanceError> {
        Queues::from_instance(file).map(QueuesSim)
    }
}

impl ParamMdp for QueuesSim {
    fn n_states(&self) -> usize {
        self.0.n_states()
    }
    fn n_actions(&self) -> usize {
        3
    }
    fn zeta_space(&self) -> &ZetaSpace {
        self.0.zeta_space()
    }
    fn valid_actions(&self, s: usize) -> &[usize] {
        self.0.valid_actions(s)
    }
    fn is_terminal(&self, _s: usize) -> bool {
        false
    }
    fn gamma(&self) -> f64 {
        self.0.gamma
    }
    fn sample_initial(&self, rng: &mut EnvRng) -> usize {
        self.0.sample_initial(rng)
    }
    fn sample_exploring_start(&self, rng: &mut EnvRng) -> usize {
        self.0.sample_exploring_start(rng)
    }
    fn cost_scale(&self) -> f64 {
        self.0.cost_scale()
    }
    fn step(&self, s: usize, a: usize, zeta: &[f64], rng: &mut EnvRng) -> (usize, f64) {
        self.0.step(s, a, zeta, rng)
    }
}

impl Env for QueuesSim {}

/// envpg's built-in environments and the two of this crate, with the example instances bundled
/// as `queues` and `queues-sim` and their presets.
pub fn registry() -> Registry {
    envpg_envs::registry()
        .register::<Queues>()
        .register::<QueuesSim>()
        .bundle("queues", INSTANCE)
        .bundle("queues-sim", INSTANCE_SIM)
        .presets(PRESETS)
}
