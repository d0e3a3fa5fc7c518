//! # envpg-model
//!
//! Model-based tools: everything that may read the transition model. Used to validate and
//! score the model-free algorithm, never to steer it.
//!
//! ## Main types and functions
//! - [`Snapshot`]: the whole model at one ζ as flat tables, decomposed into strongly connected
//!   components so solves go component by component (one M×M system for the UAV network).
//! - [`evaluate()`] / [`visits`]: exact J or J_H of any policy and its expected visit counts.
//! - [`solve_soft`]: soft value iteration (soft policy iteration per component) with divergence
//!   detection; α = 0 gives the hard optimum. [`solve_horizon`]: the bounded-horizon variant.
//! - [`corollary_gradient`], [`horizon_gradient`], [`theorem_gradient`]: exact ζ-gradients
//!   (visits × local derivative, the EnvPG theorem evaluated with the model); [`fd_gradient`]:
//!   central differences.
//! - [`Objective`]: `J_H(ζ)` with gradient at one temperature; [`oracle::run_oracle`]: the
//!   annealed, multi-restart co-design oracle, inside the design bounds ([`lbfgs::minimize_in`]).
//! - [`random`]: random smooth parameterized MDPs and policies for the theorem checks.
//!
//! Everything is generic over `M: ModelMdp + ?Sized`: it runs on any environment with a model,
//! concrete or registered (`dyn ModelMdp`).
//!
//! ## Data flow
//! `ModelMdp` + ζ → [`Snapshot`] → [`solve_soft`]/[`solve_horizon`] (values, Gibbs policy) →
//! [`visits`] → gradient pass over pairs → L-BFGS step on ζ ([`lbfgs`]) → next temperature.
//!
//! ```
//! use envpg_model::oracle::{OracleConfig, run_oracle};
//! use envpg_model::{Snapshot, evaluate, solve_soft, uniform};
//!
//! let env = envpg_envs::registry().load("flpo-n10m4", &[])?;
//! let model = env.model()?;
//! // At the instance's starting facilities: exact J of the uniform and of the optimal policy.
//! let zeta0 = model.heuristic_design().expect("flpo-n10m4 has starting facilities");
//! let snap = Snapshot::build(model, &zeta0);
//! let j_uniform = evaluate(&snap, &uniform(&snap), 0.0)?.j;
//! let j_opt = evaluate(&snap, &solve_soft(&snap, 0.0, None)?.pi, 0.0)?.j; // α = 0: hard optimum
//! assert!(j_opt < j_uniform);
//! // One oracle restart from there moves the facilities, lowering J further.
//! let cfg = OracleConfig { restarts: 1, threads: 1, init: Some(zeta0), ..OracleConfig::for_env(model) };
//! let out = run_oracle(model, &cfg)?;
//! assert!(out.restarts[out.best].j < j_opt, "{} !< {j_opt}", out.restarts[out.best].j);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

pub mod error;
pub mod evaluate;
pub mod grad;
pub mod horizon;
pub mod lbfgs;
pub mod objective;
pub mod oracle;
pub mod random;
pub mod snapshot;
pub mod soft;

pub use error::ModelError;
pub use evaluate::{PolicyValue, Rescored, evaluate, greedy_j, mu_dense, optimal_greedy, rescore, visits};
pub use grad::{
    ParamPolicy, accumulate_local, corollary_gradient, fd_gradient, horizon_gradient, policy_table, theorem_gradient,
};
pub use horizon::{HorizonSolution, solve_horizon};
pub use objective::{Evaluated, Form, GradientKind, Objective, Solved};
pub use snapshot::{Scc, Snapshot};
pub use soft::{SoftSolution, greedy, solve_soft, uniform};
