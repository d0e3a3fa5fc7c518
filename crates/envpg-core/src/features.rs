//! [`FeatureMap`]: an environment's own dense network inputs of a state–action pair at a design
//! ζ, with their ζ-Jacobian.
//!
//! Algorithm 1 works without one: its default inputs are the one-hot state, the one-hot action
//! and the centred ζ block. An environment supplies a feature map when it has observable
//! structure that generalises across states — positions, distances — and may then drop the
//! one-hot state (an environment with 10,000 states need not have 10,000 input columns).
//! Because the features may depend on ζ (a relay's position *is* part of ζ), the map also
//! back-propagates a gradient with respect to its features to ζ ([`FeatureMap::chain`]), so the
//! networks' input gradients reach ζ.

/// Dense features of `(s, a)` at a design ζ, and their chain rule back to ζ.
pub trait FeatureMap: Send + Sync {
    /// Whether the one-hot state index is an input too (default: yes).
    fn onehot_state(&self) -> bool {
        true
    }
    /// Whether the one-hot action index is an input too (default: yes).
    fn onehot_action(&self) -> bool {
        true
    }
    /// Number of dense features.
    fn dim(&self) -> usize;
    /// Writes the features of `(s, a)` at `zeta` into `out` (length [`FeatureMap::dim`]).
    fn write(&self, s: usize, a: usize, zeta: &[f64], out: &mut [f32]);
    /// Adds `scale · (∂features/∂ζ)ᵀ g` for `(s, a)` at `zeta` into `out` (length d), where `g`
    /// is a gradient with respect to the features (length [`FeatureMap::dim`]).
    fn chain(&self, s: usize, a: usize, zeta: &[f64], g: &[f32], scale: f64, out: &mut [f64]);
}
