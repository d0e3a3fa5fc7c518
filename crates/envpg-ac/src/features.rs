//! [`Features`]: the network inputs of a state–action pair at a design ζ.
//!
//! One-hot state and action (gathered, not multiplied), then dense features
//! `[x̃_s, x̃_t, (x_t − x_s)/L, ‖x_t − x_s‖²/L², ζ-block]` where `x_t` is the position of the
//! action's target, `x̃ = (x − c)/L`, and `c`, `L` are the centre and half-diagonal of the
//! positions that do not depend on ζ (users and destination: observable, not the model).
//! UAV positions are read from ζ, so the features move with ζ; [`Features::chain`] maps a
//! gradient with respect to the dense features back to ζ.
//!
//! The ζ-block is ζ itself, by default *centred* on the current design: `(ζ − ζ_k)/L`. Within an
//! iteration ζ_k is constant, so an absolute ζ input is nearly constant too and the networks use
//! its weights as extra biases; as the critic's level moves those weights grow and show up as a
//! large, state-independent ∂Q/∂ζ that drags unused UAVs away. Centred, the block is the
//! zero-mean perturbation, whose weights can only learn how Q actually varies with ζ.
//!
//! Routed ([`ZetaInput::Routed`], the `uav` preset's choice), the centred block is written into
//! one slot per action and one per source state (each UAV, and one for all users) instead of
//! one block shared by every pair, so that the slope one pair needs does not leak into the
//! others; the block is then mostly zeros, which the MLP's first layer skips.

use envpg_core::Observable;

/// Dense features before the ζ block.
pub const GEOMETRY: usize = 7;

/// How ζ itself enters the dense features.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ZetaInput {
    /// Not at all (only through the positions of s and of the action's target).
    None,
    /// `(ζ − ζ_k)/L`: the perturbation around the current design.
    Centered,
    /// `(ζ − c)/L`: the absolute design.
    Absolute,
    /// The centred block routed into per-action and per-source slots: `(ζ − ζ_k)/L` written
    /// into the slot of the pair's action and into the slot of its state's UAV (one shared
    /// slot for the fixed states), zeros elsewhere. A single centred block is shared by every
    /// pair, so the slope one pair needs leaks into all others; routed, it is shared only by
    /// pairs with the same action or the same source.
    Routed,
}

/// Feature map of one environment.
#[derive(Debug, Clone)]
pub struct Features {
    zeta_input: ZetaInput,
    /// Centre of the centred ζ-block (ζ_k).
    zeta_center: Vec<f64>,
    /// Scale of the ζ-block.
    zeta_scale: f64,
    n_states: usize,
    n_actions: usize,
    d: usize,
    center: [f64; 2],
    scale: f64,
    targets: Vec<usize>,
    zidx: Vec<Option<usize>>,
    fixed: Vec<[f64; 2]>,
}

impl Features {
    /// Builds the feature map of `env`; `sigma` scales the centred ζ-block.
    pub fn new<E: Observable>(env: &E, zeta_input: ZetaInput, sigma: f64) -> Self {
        let n = env.n_states();
        let d = env.zeta_dim();
        let zeros = vec![0.0; d];
        let zidx: Vec<Option<usize>> = (0..n).map(|s| env.zeta_index(s)).collect();
        let fixed: Vec<[f64; 2]> = (0..n).map(|s| env.position(s, &zeros)).collect();
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for s in (0..n).filter(|&s| zidx[s].is_none()) {
            for k in 0..2 {
                lo[k] = lo[k].min(fixed[s][k]);
                hi[k] = hi[k].max(fixed[s][k]);
            }
        }
        let center = [(lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0];
        let scale = (((hi[0] - lo[0]).powi(2) + (hi[1] - lo[1]).powi(2)).sqrt() / 2.0).max(1e-9);
        // The ζ-block shares the geometry's length scale L: dividing by σ instead would amplify
        // the random walk that noisy targets impose on its weights into large spurious ∂Q/∂ζ.
        let _ = sigma;
        let zeta_scale = scale;
        Self {
            zeta_input,
            zeta_center: vec![0.0; d],
            zeta_scale,
            n_states: n,
            n_actions: env.n_actions(),
            d,
            center,
            scale,
            targets: (0..env.n_actions()).map(|a| env.action_target(a)).collect(),
            zidx,
            fixed,
        }
    }

    /// Sizes of the one-hot groups: states, actions.
    pub fn onehot(&self) -> Vec<usize> {
        vec![self.n_states, self.n_actions]
    }

    /// Number of dense features.
    pub fn dense_dim(&self) -> usize {
        GEOMETRY + self.block()
    }

    fn block(&self) -> usize {
        match self.zeta_input {
            ZetaInput::None => 0,
            ZetaInput::Centered | ZetaInput::Absolute => self.d,
            ZetaInput::Routed => self.d * (self.n_actions + self.d / 2 + 1),
        }
    }

    /// The two slots of a routed block that `(s, a)` writes: its action's, and its source's.
    fn slots(&self, s: usize, a: usize) -> [usize; 2] {
        let src = self.zidx[s].map_or(self.d / 2, |i| i / 2);
        [a, self.n_actions + src]
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

    /// The length scale L of the observable geometry (half-diagonal of the fixed positions).
    pub fn length_scale(&self) -> f64 {
        self.scale
    }

    /// Dimension of ζ.
    pub fn zeta_dim(&self) -> usize {
        self.d
    }

    /// The position of state `s` at design `zeta`.
    #[inline]
    pub fn position(&self, s: usize, zeta: &[f64]) -> [f64; 2] {
        self.pos(s, zeta)
    }

    #[inline]
    fn pos(&self, s: usize, zeta: &[f64]) -> [f64; 2] {
        match self.zidx[s] {
            Some(i) => [zeta[i], zeta[i + 1]],
            None => self.fixed[s],
        }
    }

    /// Writes the dense features of `(s, a)` at `zeta` into `out` (len [`Features::dense_dim`]).
    pub fn write(&self, s: usize, a: usize, zeta: &[f64], out: &mut [f32]) {
        let (c, l) = (self.center, self.scale);
        let xs = self.pos(s, zeta);
        let xt = self.pos(self.targets[a], zeta);
        let dx = [xt[0] - xs[0], xt[1] - xs[1]];
        out[0] = ((xs[0] - c[0]) / l) as f32;
        out[1] = ((xs[1] - c[1]) / l) as f32;
        out[2] = ((xt[0] - c[0]) / l) as f32;
        out[3] = ((xt[1] - c[1]) / l) as f32;
        out[4] = (dx[0] / l) as f32;
        out[5] = (dx[1] / l) as f32;
        out[6] = ((dx[0] * dx[0] + dx[1] * dx[1]) / (l * l)) as f32;
        match self.zeta_input {
            ZetaInput::None => {}
            ZetaInput::Centered => {
                for i in 0..self.d {
                    out[GEOMETRY + i] = ((zeta[i] - self.zeta_center[i]) / self.zeta_scale) as f32;
                }
            }
            ZetaInput::Absolute => {
                for i in 0..self.d {
                    out[GEOMETRY + i] = ((zeta[i] - c[i % 2]) / self.zeta_scale) as f32;
                }
            }
            ZetaInput::Routed => {
                out[GEOMETRY..GEOMETRY + self.block()].fill(0.0);
                for slot in self.slots(s, a) {
                    for i in 0..self.d {
                        out[GEOMETRY + slot * self.d + i] = ((zeta[i] - self.zeta_center[i]) / self.zeta_scale) as f32;
                    }
                }
            }
        }
    }

    /// Adds `(∂features/∂ζ)ᵀ g` for `(s, a)` at `zeta` into `out` (len d), `scale` times.
    pub fn chain(&self, s: usize, a: usize, zeta: &[f64], g: &[f32], scale: f64, out: &mut [f64]) {
        let l = self.scale;
        let t = self.targets[a];
        let xs = self.pos(s, zeta);
        let xt = self.pos(t, zeta);
        let g = |i: usize| g[i] as f64 * scale;
        let dq = [2.0 * (xt[0] - xs[0]) / (l * l) * g(6), 2.0 * (xt[1] - xs[1]) / (l * l) * g(6)];
        if let Some(i) = self.zidx[s] {
            out[i] += (g(0) - g(4)) / l - dq[0];
            out[i + 1] += (g(1) - g(5)) / l - dq[1];
        }
        if let Some(i) = self.zidx[t] {
            out[i] += (g(2) + g(4)) / l + dq[0];
            out[i + 1] += (g(3) + g(5)) / l + dq[1];
        }
        if self.zeta_input == ZetaInput::Routed {
            for slot in self.slots(s, a) {
                for i in 0..self.d {
                    out[i] += g(GEOMETRY + slot * self.d + i) / self.zeta_scale;
                }
            }
        } else {
            for i in 0..self.block() {
                out[i] += g(GEOMETRY + i) / self.zeta_scale;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use envpg_core::{Instance, UavNetwork};

    #[test]
    fn chain_rule_matches_central_differences() {
        let inst = Instance { name: "t".into(), n_uav: 3, users: vec![[0.0, 0.0], [2.0, 1.0]], dest: [4.0, 3.0] };
        let net = UavNetwork::new(inst, 1.0, 100.0).unwrap();
        for input in [ZetaInput::None, ZetaInput::Centered, ZetaInput::Absolute, ZetaInput::Routed] {
            let mut f = Features::new(&net, input, 0.3);
            f.set_center(&[0.9, 0.4, 2.4, 1.6, 3.1, 1.9]);
            let zeta = [1.0, 0.5, 2.5, 1.5, 3.0, 2.0];
            let w: Vec<f32> = (0..f.dense_dim()).map(|i| ((i as f32) * 0.7).cos()).collect();
            let dot = |z: &[f64], s: usize, a: usize| {
                let mut x = vec![0.0f32; f.dense_dim()];
                f.write(s, a, z, &mut x);
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
                    assert!((fd - g[i]).abs() < 2e-4 * (1.0 + fd.abs()), "{input:?} s{s} a{a} i{i}: {fd} vs {}", g[i]);
                }
            }
        }
    }
}
