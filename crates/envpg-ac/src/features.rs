//! [`Features`]: the network inputs of a state–action pair at a design ζ.
//!
//! Three parts, each optional:
//! - the one-hot state and one-hot action (gathered, not multiplied) — on by default; an
//!   environment whose own features generalise across states may turn the state's off;
//! - the environment's own dense features ([`envpg_core::FeatureMap`]), which may depend on ζ
//!   (a relay's position is part of ζ) and come with their chain rule back to ζ;
//! - the ζ-block ([`ZetaInput`]), in units of the design space's per-coordinate scale.
//!
//! Without an environment feature map this is the problem-independent default: one-hot state
//! and action and the ζ-block. [`Features::chain`] maps a gradient with respect to the dense
//! features back to ζ, so the networks' input gradients reach ζ either way.
//!
//! The ζ-block is by default *centred* on the current design: `(ζ − ζ_k)/scale`. Within an
//! iteration ζ_k is constant, so an absolute ζ input is nearly constant too and the networks use
//! its weights as extra biases; as the critic's level moves those weights grow and show up as a
//! large, state-independent ∂Q/∂ζ that drags unused design elements away. Centred, the block is
//! the zero-mean perturbation, whose weights can only learn how Q actually varies with ζ.
//!
//! Routed ([`ZetaInput::Routed`]), the centred block is written into one slot per action and
//! one per source — the design element the state sits at, or one slot shared by every state
//! that is not at one — instead of one block shared by every pair, so that the slope one pair
//! needs does not leak into the others; the block is then zero outside those two slots, so a
//! column lists only them and the environment's features ([`Features::push_column`]), and the
//! MLP's first layer and input gradient touch nothing else.

use std::sync::Arc;

use envpg_core::{FeatureMap, ParamMdp};

/// How ζ itself enters the dense features.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ZetaInput {
    /// Not at all (only through the environment's features, if they depend on ζ).
    None,
    /// `(ζ − ζ_k)/scale`: the perturbation around the current design.
    Centered,
    /// `(ζ − origin)/scale`: the absolute design.
    Absolute,
    /// The centred block routed into per-action and per-source slots: `(ζ − ζ_k)/scale`
    /// written into the slot of the pair's action and into the slot of the design element its
    /// state sits at (one shared slot for the other states), zeros elsewhere. A single centred
    /// block is shared by every pair, so the slope one pair needs leaks into all others; routed,
    /// it is shared only by pairs with the same action or the same source.
    Routed,
}

/// Which one-hot column a state has.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum StateOnehot {
    /// One column per state: the networks tell every state apart, at the cost of input
    /// weights (and parameters) that grow with the number of states.
    #[default]
    PerState,
    /// One column per design element's states, and one shared by every other state: states
    /// outside the design elements are told apart only by the environment's own features
    /// (positions, distances), so θ no longer grows with them and what is learnt for one
    /// carries over to its neighbours. Needs an environment feature map.
    PerElement,
}

/// Feature map of one environment.
#[derive(Clone)]
pub struct Features {
    zeta_input: ZetaInput,
    /// Centre of the centred ζ-block (ζ_k).
    zeta_center: Vec<f64>,
    /// Origin and scale of each ζ coordinate (the design space's).
    origin: Vec<f64>,
    scale: Vec<f64>,
    n_states: usize,
    n_actions: usize,
    d: usize,
    /// The states' one-hot columns; `None` where the provider drops the one-hot state.
    state_onehot: Option<StateOnehot>,
    onehot_action: bool,
    provider: Option<Arc<dyn FeatureMap>>,
    /// Dense features of the provider (before the ζ-block).
    base: usize,
    /// Per state: its design element's index, or `n_elements` (the shared source slot).
    source: Vec<u32>,
    n_elements: usize,
}

impl std::fmt::Debug for Features {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Features")
            .field("zeta_input", &self.zeta_input)
            .field("state_onehot", &self.state_onehot)
            .field("onehot", &self.onehot())
            .field("dense", &self.dense_dim())
            .finish()
    }
}

impl Features {
    /// The feature map of `env`, with its own dense features `provider` (its
    /// `Env::feature_map`) if any, and ζ entering as `zeta_input`; one one-hot column per
    /// state (where the provider wants a one-hot state).
    pub fn new<E: ParamMdp + ?Sized>(env: &E, provider: Option<Arc<dyn FeatureMap>>, zeta_input: ZetaInput) -> Self {
        Self::with_state_onehot(env, provider, zeta_input, StateOnehot::PerState)
    }

    /// [`Features::new`] with the states' one-hot columns as `state_onehot` says
    /// ([`AcConfig::state_onehot`](crate::AcConfig::state_onehot), validated against the
    /// environment by [`AcConfig::validate_for`](crate::AcConfig::validate_for)).
    pub fn with_state_onehot<E: ParamMdp + ?Sized>(
        env: &E,
        provider: Option<Arc<dyn FeatureMap>>,
        zeta_input: ZetaInput,
        state_onehot: StateOnehot,
    ) -> Self {
        let n = env.n_states();
        let d = env.zeta_dim();
        let space = env.zeta_space();
        let elements = env.design_elements();
        let mut source = vec![elements.len() as u32; n];
        for (e, el) in elements.iter().enumerate() {
            for &s in &el.states {
                source[s] = e as u32;
            }
        }
        let (onehot_state, onehot_action, base) = match &provider {
            Some(p) => (p.onehot_state(), p.onehot_action(), p.dim()),
            None => (true, true, 0),
        };
        Self {
            zeta_input,
            zeta_center: vec![0.0; d],
            origin: space.origin().to_vec(),
            scale: space.scale().to_vec(),
            n_states: n,
            n_actions: env.n_actions(),
            d,
            state_onehot: onehot_state.then_some(state_onehot),
            onehot_action,
            provider,
            base,
            source,
            n_elements: elements.len(),
        }
    }

    /// Sizes of the one-hot groups (states and/or actions).
    pub fn onehot(&self) -> Vec<usize> {
        let mut g = Vec::with_capacity(2);
        match self.state_onehot {
            Some(StateOnehot::PerState) => g.push(self.n_states),
            Some(StateOnehot::PerElement) => g.push(self.n_elements + 1),
            None => {}
        }
        if self.onehot_action {
            g.push(self.n_actions);
        }
        g
    }

    /// Appends the one-hot indices of `(s, a)` (one per group of [`Features::onehot`]).
    #[inline]
    pub fn push_onehot(&self, s: usize, a: usize, out: &mut Vec<u32>) {
        match self.state_onehot {
            Some(StateOnehot::PerState) => out.push(s as u32),
            Some(StateOnehot::PerElement) => out.push(self.source[s]),
            None => {}
        }
        if self.onehot_action {
            out.push(a as u32);
        }
    }

    /// Number of dense features.
    pub fn dense_dim(&self) -> usize {
        self.base + self.block()
    }

    fn block(&self) -> usize {
        match self.zeta_input {
            ZetaInput::None => 0,
            ZetaInput::Centered | ZetaInput::Absolute => self.d,
            ZetaInput::Routed => self.d * (self.n_actions + self.n_elements + 1),
        }
    }

    /// The two slots of a routed block that `(s, a)` writes: its action's, and its source's.
    #[inline]
    fn slots(&self, s: usize, a: usize) -> [usize; 2] {
        [a, self.n_actions + self.source[s] as usize]
    }

    /// Sets the centre of a centred ζ-block: the current design ζ_k.
    pub fn set_center(&mut self, zeta_k: &[f64]) {
        self.zeta_center.copy_from_slice(zeta_k);
    }

    /// A copy centred on `zeta_k`.
    pub fn centered(&self, zeta_k: &[f64]) -> Self {
        let mut f = self.clone();
        f.set_center(zeta_k);
        f
    }

    /// Dimension of ζ.
    pub fn zeta_dim(&self) -> usize {
        self.d
    }

    /// Writes the dense features of `(s, a)` at `zeta` into `out` (len [`Features::dense_dim`]).
    pub fn write(&self, s: usize, a: usize, zeta: &[f64], out: &mut [f32]) {
        if let Some(p) = &self.provider {
            p.write(s, a, zeta, &mut out[..self.base]);
        }
        let b = self.base;
        match self.zeta_input {
            ZetaInput::None => {}
            ZetaInput::Centered => {
                for i in 0..self.d {
                    out[b + i] = ((zeta[i] - self.zeta_center[i]) / self.scale[i]) as f32;
                }
            }
            ZetaInput::Absolute => {
                for i in 0..self.d {
                    out[b + i] = ((zeta[i] - self.origin[i]) / self.scale[i]) as f32;
                }
            }
            ZetaInput::Routed => {
                out[b..b + self.block()].fill(0.0);
                for slot in self.slots(s, a) {
                    for i in 0..self.d {
                        out[b + slot * self.d + i] = ((zeta[i] - self.zeta_center[i]) / self.scale[i]) as f32;
                    }
                }
            }
        }
    }

    /// Whether a column lists its dense features ([`envpg_nn::Dense::Listed`]) instead of
    /// storing them whole: a routed block is zero outside the pair's two slots.
    pub fn listed(&self) -> bool {
        self.zeta_input == ZetaInput::Routed
    }

    /// Values a column stores: [`Features::dense_dim`], or when [`Features::listed`], the
    /// environment's features and the two slots the pair writes.
    pub fn width(&self) -> usize {
        if self.listed() { self.base + 2 * self.d } else { self.dense_dim() }
    }

    /// Appends the column of `(s, a)` at `zeta`: [`Features::width`] values and, when
    /// [`Features::listed`], the dense input each sits at (in increasing order).
    pub fn push_column(&self, s: usize, a: usize, zeta: &[f64], index: &mut Vec<u32>, value: &mut Vec<f32>) {
        let at = value.len();
        value.resize(at + self.width(), 0.0);
        if !self.listed() {
            self.write(s, a, zeta, &mut value[at..]);
            return;
        }
        let out = &mut value[at..];
        if let Some(p) = &self.provider {
            p.write(s, a, zeta, &mut out[..self.base]);
        }
        index.extend(0..self.base as u32);
        for (k, slot) in self.slots(s, a).into_iter().enumerate() {
            let first = self.base + slot * self.d;
            index.extend((first..first + self.d).map(|i| i as u32));
            for i in 0..self.d {
                out[self.base + k * self.d + i] = ((zeta[i] - self.zeta_center[i]) / self.scale[i]) as f32;
            }
        }
    }

    /// Adds `weight · (∂features/∂ζ)ᵀ g` for `(s, a)` at `zeta` into `out` (len d), where `g`
    /// is a gradient with respect to the column's stored values ([`Features::width`], in the
    /// order [`Features::push_column`] writes them).
    pub fn chain(&self, s: usize, a: usize, zeta: &[f64], g: &[f32], weight: f64, out: &mut [f64]) {
        if let Some(p) = &self.provider {
            p.chain(s, a, zeta, &g[..self.base], weight, out);
        }
        let g = |i: usize| g[self.base + i] as f64 * weight;
        if self.listed() {
            for k in 0..2 {
                for i in 0..self.d {
                    out[i] += g(k * self.d + i) / self.scale[i];
                }
            }
        } else {
            for i in 0..self.block() {
                out[i] += g(i) / self.scale[i];
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use envpg_core::{Env, EnvSpec, InstanceFile};
    use envpg_envs::uav::UavNetwork;

    fn net() -> UavNetwork {
        let text = r#"{"name":"t","n_uav":3,"users":[[0,0],[2,1]],"dest":[4,3]}"#;
        let mut f = InstanceFile::parse(text, "t").unwrap();
        f.resolve_params(&UavNetwork::params(), &[]).unwrap();
        UavNetwork::from_instance(&f).unwrap()
    }

    #[test]
    fn chain_rule_matches_central_differences() {
        let net = net();
        for provider in [net.feature_map(), None] {
            for input in [ZetaInput::None, ZetaInput::Centered, ZetaInput::Absolute, ZetaInput::Routed] {
                let mut f = Features::new(&net, provider.clone(), input);
                if provider.is_none() && input == ZetaInput::None {
                    continue;
                }
                f.set_center(&[0.9, 0.4, 2.4, 1.6, 3.1, 1.9]);
                let zeta = [1.0, 0.5, 2.5, 1.5, 3.0, 2.0];
                let w: Vec<f32> = (0..f.width()).map(|i| ((i as f32) * 0.7).cos()).collect();
                let dot = |z: &[f64], s: usize, a: usize| {
                    let (mut index, mut x) = (Vec::new(), Vec::new());
                    f.push_column(s, a, z, &mut index, &mut x);
                    x.iter().zip(&w).map(|(x, w)| *x as f64 * *w as f64).sum::<f64>()
                };
                for (s, a) in [(0, 1), (3, 2), (4, 3), (1, 0)] {
                    let mut g = vec![0.0; 6];
                    f.chain(s, a, &zeta, &w, 1.0, &mut g);
                    for i in 0..6 {
                        let h = 1e-3; // features are f32: a large step keeps rounding small
                        let mut zp = zeta;
                        zp[i] += h;
                        let mut zm = zeta;
                        zm[i] -= h;
                        let fd = (dot(&zp, s, a) - dot(&zm, s, a)) / (2.0 * h);
                        assert!(
                            (fd - g[i]).abs() < 2e-4 * (1.0 + fd.abs()),
                            "{input:?} s{s} a{a} i{i}: {fd} vs {}",
                            g[i]
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn a_listed_column_holds_every_non_zero_feature_at_its_place() {
        let net = net();
        for provider in [net.feature_map(), None] {
            let mut f = Features::new(&net, provider, ZetaInput::Routed);
            assert!(f.listed() && f.width() < f.dense_dim());
            f.set_center(&[0.9, 0.4, 2.4, 1.6, 3.1, 1.9]);
            let zeta = [1.0, 0.5, 2.5, 1.5, 3.0, 2.0];
            let sets = crate::nets::ActionSets::new(&net);
            for s in 0..sets.n_states() {
                for &a in sets.of(s) {
                    let mut whole = vec![f32::NAN; f.dense_dim()];
                    f.write(s, a, &zeta, &mut whole);
                    let (mut index, mut value) = (vec![7], vec![9.0]);
                    f.push_column(s, a, &zeta, &mut index, &mut value);
                    assert_eq!((index.len(), value.len()), (1 + f.width(), 1 + f.width()), "appended");
                    assert!(index[1..].windows(2).all(|w| w[0] < w[1]), "increasing");
                    let mut from_list = vec![0.0f32; f.dense_dim()];
                    for (&i, &v) in index[1..].iter().zip(&value[1..]) {
                        from_list[i as usize] = v;
                    }
                    assert_eq!(from_list, whole, "s{s} a{a}");
                }
            }
        }
        let centred = Features::new(&net, None, ZetaInput::Centered);
        assert!(!centred.listed() && centred.width() == centred.dense_dim());
    }

    #[test]
    fn the_default_map_is_one_hot_state_and_action_and_the_zeta_block() {
        let net = net();
        let f = Features::new(&net, None, ZetaInput::Centered);
        assert_eq!((f.onehot(), f.dense_dim()), (vec![net.n_states(), net.n_actions()], 6));
        let routed = Features::new(&net, None, ZetaInput::Routed);
        // One slot per action (4), per UAV (3) and one shared by users and the destination.
        assert_eq!(routed.dense_dim(), 6 * (4 + 3 + 1));
        let with_geometry = Features::new(&net, net.feature_map(), ZetaInput::Routed);
        assert_eq!(with_geometry.dense_dim(), 7 + 6 * 8);
    }

    #[test]
    fn per_element_one_hot_gives_each_uav_a_column_and_users_one_shared_column() {
        let net = net();
        let f = Features::with_state_onehot(&net, net.feature_map(), ZetaInput::Routed, StateOnehot::PerElement);
        // 3 UAVs and one column shared by the 2 users and the destination; the actions keep
        // theirs, and the dense features are unchanged.
        assert_eq!(f.onehot(), vec![3 + 1, net.n_actions()]);
        assert_eq!(f.dense_dim(), Features::new(&net, net.feature_map(), ZetaInput::Routed).dense_dim());
        let column = |s: usize| {
            let mut idx = Vec::new();
            f.push_onehot(s, 0, &mut idx);
            idx[0]
        };
        let uavs: Vec<u32> = (0..3).map(|j| column(net.uav_state(j))).collect();
        assert_eq!(uavs, vec![0, 1, 2]);
        assert_eq!((column(0), column(1)), (3, 3), "users share the last column");
        let per_state = Features::new(&net, net.feature_map(), ZetaInput::Routed);
        assert_eq!(per_state.onehot(), vec![net.n_states(), net.n_actions()]);
    }

    #[test]
    fn per_element_one_hot_needs_the_environments_own_features() {
        let net = net();
        let cfg = crate::AcConfig { state_onehot: StateOnehot::PerElement, ..Default::default() };
        assert!(cfg.validate_for(net.feature_map().as_deref()).is_ok());
        let err = cfg.validate_for(None).unwrap_err();
        assert_eq!(err.field, "state_onehot");
        assert!(crate::AcConfig::default().validate_for(None).is_ok());
    }
}
