//! Actor and critic evaluation in batches of *columns*: one column per (state, action, ζ).
//!
//! The actor f_θ(s, a, ζ) gives one logit per column; π_θ(·|s, ζ) is the softmax over the
//! columns of the valid actions of s (a *query*). The critic Q_φ(s, a, ζ) gives one value per
//! column. Both are [`Mlp`]s in f32 over [`Features`].

use envpg_core::ParamMdp;
use envpg_nn::{Cache, Dense, Inputs, Mlp, MlpSpec};
use rand::Rng;

use crate::features::Features;

/// The valid actions of every state, flattened (copied out of the environment once).
#[derive(Debug, Clone)]
pub struct ActionSets {
    start: Vec<usize>,
    actions: Vec<usize>,
    terminal: Vec<bool>,
}

impl ActionSets {
    /// Reads the valid actions of every state of `env`.
    pub fn new<E: ParamMdp + ?Sized>(env: &E) -> Self {
        let mut start = vec![0];
        let mut actions = Vec::new();
        let mut terminal = Vec::new();
        for s in 0..env.n_states() {
            actions.extend_from_slice(env.valid_actions(s));
            start.push(actions.len());
            terminal.push(env.is_terminal(s));
        }
        Self { start, actions, terminal }
    }
    /// Valid actions of `s`.
    #[inline]
    pub fn of(&self, s: usize) -> &[usize] {
        &self.actions[self.start[s]..self.start[s + 1]]
    }
    /// Index of the first pair of `s` in the flattened layout.
    #[inline]
    pub fn first(&self, s: usize) -> usize {
        self.start[s]
    }
    /// Number of states.
    pub fn n_states(&self) -> usize {
        self.terminal.len()
    }
    /// Total number of state–action pairs.
    pub fn n_pairs(&self) -> usize {
        self.actions.len()
    }
    /// Whether `s` is terminal.
    #[inline]
    pub fn terminal(&self, s: usize) -> bool {
        self.terminal[s]
    }
    /// The deterministic policy taking `action[s]` in every state, one-hot per pair (states
    /// whose entry is not one of their valid actions, such as terminal ones, get no mass).
    pub fn one_hot(&self, action: &[usize]) -> Vec<f64> {
        let mut out = vec![0.0; self.n_pairs()];
        for (s, &a) in action.iter().enumerate().take(self.n_states()) {
            if let Some(i) = self.of(s).iter().position(|&x| x == a) {
                out[self.first(s) + i] = 1.0;
            }
        }
        out
    }
}

/// A batch of network columns.
///
/// A column's dense features are stored whole, or, when the [`Features`] are
/// [listed](Features::listed), as the few values that can be non-zero and the inputs they sit
/// at: with thousands of states a routed column has over a thousand dense inputs, a few dozen
/// of them non-zero.
#[derive(Debug, Clone, Default)]
pub struct Columns {
    onehot: Vec<u32>,
    /// [`Columns::width`] values per column.
    value: Vec<f32>,
    /// The dense input each value sits at, when listed (else empty).
    index: Vec<u32>,
    /// (state, action) of each column.
    pub sa: Vec<(u32, u32)>,
    /// Which ζ (index into the caller's list) each column was built at.
    pub zeta_id: Vec<u32>,
    width: usize,
    listed: bool,
}

impl Columns {
    /// An empty batch with room for `n` columns of `f`'s inputs. Building a batch of known
    /// size this way never reallocates: a growing batch would copy itself and, while copying,
    /// hold up to three times its size.
    pub fn with_capacity(f: &Features, n: usize) -> Self {
        let listed = f.listed();
        Self {
            onehot: Vec::with_capacity(n * f.onehot().len()),
            value: Vec::with_capacity(n * f.width()),
            index: Vec::with_capacity(if listed { n * f.width() } else { 0 }),
            sa: Vec::with_capacity(n),
            zeta_id: Vec::with_capacity(n),
            width: f.width(),
            listed,
        }
    }
    /// Empties the batch.
    pub fn clear(&mut self) {
        self.onehot.clear();
        self.value.clear();
        self.index.clear();
        self.sa.clear();
        self.zeta_id.clear();
    }
    /// Number of columns.
    pub fn len(&self) -> usize {
        self.sa.len()
    }
    /// Whether there are no columns.
    pub fn is_empty(&self) -> bool {
        self.sa.is_empty()
    }
    /// Appends the column `(s, a, zeta)`; `zeta_id` names `zeta` for [`Columns::zeta_id`].
    pub fn push(&mut self, f: &Features, s: usize, a: usize, zeta: &[f64], zeta_id: u32) {
        if self.is_empty() {
            (self.width, self.listed) = (f.width(), f.listed());
        }
        debug_assert_eq!((self.width, self.listed), (f.width(), f.listed()), "one feature map per batch");
        f.push_onehot(s, a, &mut self.onehot);
        f.push_column(s, a, zeta, &mut self.index, &mut self.value);
        self.sa.push((s as u32, a as u32));
        self.zeta_id.push(zeta_id);
    }
    /// The network inputs.
    pub fn inputs(&self) -> Inputs<'_, f32> {
        let dense = if self.listed {
            Dense::Listed { index: &self.index, value: &self.value, per_sample: self.width }
        } else {
            Dense::Full(&self.value)
        };
        Inputs { onehot: &self.onehot, dense, batch: self.sa.len() }
    }
    /// Values stored per column: of the dense features, and of their gradient from
    /// [`Net::backprop`] (what [`Features::chain`] takes).
    pub fn width(&self) -> usize {
        self.width
    }
}

/// One network with its forward cache and a fixed output scale: the value it reports is
/// `scale · mlp(x)`, so a critic whose returns are in the hundreds still works with O(1)
/// network outputs (Adam moves each weight by at most ~lr per step).
#[derive(Debug)]
pub struct Net {
    /// The MLP.
    pub mlp: Mlp<f32>,
    cache: Cache<f32>,
    scale: f32,
}

/// A clone copies the parameters and the scale, not the scratch activations of the last forward
/// pass (every backprop follows its own forward; the activations of a large batch are megabytes
/// that a per-iteration copy would only move around).
impl Clone for Net {
    fn clone(&self) -> Self {
        Self { mlp: self.mlp.clone(), cache: Cache::default(), scale: self.scale }
    }
}

impl Net {
    /// A fresh network over `features`; `zero_output` starts it at a constant.
    pub fn new<R: Rng + ?Sized>(features: &Features, hidden: &[usize], rng: &mut R, zero_output: bool) -> Self {
        let spec = MlpSpec { onehot: features.onehot(), dense: features.dense_dim(), hidden: hidden.to_vec() };
        Self { mlp: Mlp::new(spec, rng, zero_output), cache: Cache::default(), scale: 1.0 }
    }

    /// The output scale.
    pub fn scale(&self) -> f32 {
        self.scale
    }

    /// Sets the output scale.
    pub fn set_scale(&mut self, scale: f32) {
        self.scale = scale;
    }

    /// Wraps existing parameters.
    pub fn from_mlp(mlp: Mlp<f32>) -> Self {
        Self { mlp, cache: Cache::default(), scale: 1.0 }
    }

    /// Evaluates every column into `out`, keeping the activations for [`Net::backprop`].
    pub fn eval(&mut self, cols: &Columns, out: &mut Vec<f32>) {
        out.clear();
        out.resize(cols.len(), 0.0);
        if !cols.is_empty() {
            self.mlp.forward(&cols.inputs(), &mut self.cache, out);
            if self.scale != 1.0 {
                out.iter_mut().for_each(|o| *o *= self.scale);
            }
        }
    }

    /// Evaluates every column into `out` without keeping activations (no [`Net::backprop`]
    /// afterwards): cheaper when only the values are needed.
    pub fn values(&self, cols: &Columns, out: &mut Vec<f32>) {
        out.clear();
        out.resize(cols.len(), 0.0);
        if !cols.is_empty() {
            self.mlp.eval(&cols.inputs(), out);
            if self.scale != 1.0 {
                out.iter_mut().for_each(|o| *o *= self.scale);
            }
        }
    }

    /// Backpropagates `dout` (per column) through the last [`Net::eval`] of `cols`: adds the
    /// parameter gradient into `grad` and writes dense-input gradients into `dinput`.
    pub fn backprop(&self, cols: &Columns, dout: &[f32], grad: Option<&mut [f32]>, dinput: Option<&mut Vec<f32>>) {
        if cols.is_empty() {
            return;
        }
        let di = dinput.map(|v| {
            v.clear();
            v.resize(cols.len() * cols.width(), 0.0);
            v.as_mut_slice()
        });
        if self.scale == 1.0 {
            self.mlp.backward(&cols.inputs(), &self.cache, dout, grad, di);
        } else {
            let scaled: Vec<f32> = dout.iter().map(|d| d * self.scale).collect();
            self.mlp.backward(&cols.inputs(), &self.cache, &scaled, grad, di);
        }
    }
}

/// Softmax of `logits` in f64, written into `out`.
pub fn softmax(logits: &[f32], out: &mut [f64]) {
    let mx = logits.iter().fold(f32::NEG_INFINITY, |m, &l| m.max(l)) as f64;
    let mut z = 0.0;
    for (o, &l) in out.iter_mut().zip(logits) {
        *o = (l as f64 - mx).exp();
        z += *o;
    }
    for o in out.iter_mut() {
        *o /= z;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::features::ZetaInput;
    use envpg_core::{Env, EnvSpec, InstanceFile};
    use envpg_envs::uav::UavNetwork;

    #[test]
    fn a_batch_built_with_its_capacity_never_reallocates() {
        let text = r#"{"name":"t","n_uav":3,"users":[[0,0],[2,1]],"dest":[4,3]}"#;
        let mut file = InstanceFile::parse(text, "t").unwrap();
        file.resolve_params(&UavNetwork::params(), &[]).unwrap();
        let net = UavNetwork::from_instance(&file).unwrap();
        let features = Features::new(&net, net.feature_map(), ZetaInput::Routed);
        let sets = ActionSets::new(&net);
        let n = sets.n_pairs();
        let mut cols = Columns::with_capacity(&features, n);
        let buffers = |c: &Columns| {
            (
                c.value.as_ptr(),
                c.value.capacity(),
                c.index.as_ptr(),
                c.index.capacity(),
                c.onehot.as_ptr(),
                c.onehot.capacity(),
            )
        };
        let before = buffers(&cols);
        let zeta = [1.0, 0.5, 2.5, 1.5, 3.0, 2.0];
        for s in 0..sets.n_states() {
            for &a in sets.of(s) {
                cols.push(&features, s, a, &zeta, 0);
            }
        }
        assert_eq!(cols.len(), n);
        assert_eq!(buffers(&cols), before, "no buffer moved or grew");
        let used = (cols.value.len(), cols.index.len(), cols.onehot.len());
        assert_eq!(used, (before.1, before.3, before.5), "and every reserved slot is used");
    }
}
