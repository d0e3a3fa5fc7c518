//! Errors of the exact solvers.

/// Why an exact computation failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ModelError {
    /// Under the policy, some states never reach a terminal state (γ = 1): their value is
    /// infinite. For the UAV network this is a routing loop between UAVs.
    #[error("policy is improper: from states {states:?} the terminal state is never reached (infinite cost)")]
    Improper {
        /// The states that cannot terminate.
        states: Vec<usize>,
    },
    /// Soft value iteration diverged: at this temperature, looping earns entropy faster than it
    /// costs, so the soft values run to −∞.
    #[error(
        "soft value iteration diverged at alpha = {alpha}: looping among states {states:?} earns entropy faster than it costs (values below {value:.3e}); lower alpha or use a finite horizon"
    )]
    Diverged {
        /// The temperature.
        alpha: f64,
        /// The states of the looping component.
        states: Vec<usize>,
        /// The most negative value reached.
        value: f64,
    },
    /// The iteration did not converge within its budget.
    #[error("{what} did not converge in {iterations} iterations (residual {residual:.3e})")]
    NotConverged {
        /// Which solver.
        what: &'static str,
        /// Iterations used.
        iterations: usize,
        /// Final residual.
        residual: f64,
    },
    /// A linear system was singular or produced non-finite numbers.
    #[error("singular or ill-conditioned linear system in {0}")]
    Singular(&'static str),
    /// An argument is out of range.
    #[error("invalid argument: {0}")]
    Invalid(String),
}
