//! What the learner and the drawings see of a [`HopNetwork`]: the geometric features of a hop
//! ([`HopFeatures`]), the design elements and the relocation of an idle one, and the arrows of
//! a greedy policy.

use std::sync::Arc;

use envpg_core::{DesignElement, FeatureMap, SketchArrow};

use super::{HopNetwork, Place};

impl HopNetwork {
    /// One design element per point read from ζ, with the states placed there (in state
    /// order), ordered by their first state.
    pub fn design_elements(&self) -> Vec<DesignElement> {
        let mut out: Vec<DesignElement> = Vec::new();
        for (s, p) in self.places.iter().enumerate() {
            if let Place::Zeta(i) = *p {
                match out.iter_mut().find(|e| e.coords.start == i) {
                    Some(e) => e.states.push(s),
                    None => out.push(DesignElement { coords: i..i + 2, states: vec![s] }),
                }
            }
        }
        out
    }

    /// The midpoint of the hop `from → to` at `zeta`: where an idle point serves that hop best
    /// while staying clear of both ends (a point next to one end would form a cheap loop with
    /// it that the entropy term rewards).
    pub fn relocation(&self, zeta: &[f64], from: usize, to: usize) -> Vec<f64> {
        let (a, b) = (self.position(from, zeta), self.position(to, zeta));
        vec![0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1])]
    }

    /// The geometric features of a hop ([`HopFeatures`]).
    pub fn features(&self) -> Arc<dyn FeatureMap> {
        let (center, scale) = self.fixed_frame();
        Arc::new(HopFeatures {
            n_actions: self.n_actions,
            center,
            scale,
            target_of: self.target_of.clone(),
            places: self.places.clone(),
        })
    }

    /// The hops `(s, t)` of the greedy route from `origin` under `actions` up to a terminal
    /// state; a route that loops ends after one pass through every state.
    fn greedy_route(&self, origin: usize, actions: &[usize]) -> Vec<(usize, usize)> {
        let mut hops = Vec::new();
        let mut s = origin;
        for _ in 0..self.n_states() {
            if self.is_terminal(s) {
                break;
            }
            let t = self.target(s, actions[s]);
            hops.push((s, t));
            s = t;
        }
        hops
    }

    /// The arrows of the greedy policy `actions` from every state placed by ζ: bold where some
    /// route from an `origins` state passes.
    pub fn policy_arrows(&self, zeta: &[f64], actions: &[usize], origins: &[usize]) -> Vec<SketchArrow> {
        let mut used = vec![false; self.n_states()];
        for &o in origins {
            for (s, _) in self.greedy_route(o, actions) {
                used[s] = true;
            }
        }
        (0..self.n_states())
            .filter(|&s| self.zeta_index(s).is_some() && !self.is_terminal(s))
            .map(|s| {
                let t = self.target(s, actions[s]);
                SketchArrow { from: self.position(s, zeta), to: self.position(t, zeta), strong: used[s] }
            })
            .collect()
    }

    /// The arrows of every origin's whole greedy route (each hop once), for drawing routes.
    pub fn route_arrows(&self, zeta: &[f64], actions: &[usize], origins: &[usize]) -> Vec<SketchArrow> {
        let mut out: Vec<SketchArrow> = Vec::new();
        for &o in origins {
            for (s, t) in self.greedy_route(o, actions) {
                let arrow = SketchArrow { from: self.position(s, zeta), to: self.position(t, zeta), strong: true };
                if !out.contains(&arrow) {
                    out.push(arrow);
                }
            }
        }
        out
    }
}

/// The geometric features of a hop from `s` to the target `t` of action `a`:
/// `[x̃_s, x̃_t, (x_t − x_s)/L, ‖x_t − x_s‖²/L²]` with `x̃ = (x − c)/L`, where `c` and `L` are
/// the centre and half-diagonal of the fixed positions (observable, not the model). Points read
/// from ζ move with ζ, and [`FeatureMap::chain`] maps a gradient with respect to the features
/// back to ζ.
#[derive(Debug, Clone)]
pub struct HopFeatures {
    n_actions: usize,
    center: [f64; 2],
    scale: f64,
    /// Target of `(s, a)` at `s · n_actions + a` (`u32::MAX`: invalid).
    target_of: Vec<u32>,
    places: Vec<Place>,
}

impl HopFeatures {
    /// Number of features.
    pub const DIM: usize = 7;

    #[inline]
    fn pos(&self, s: usize, zeta: &[f64]) -> [f64; 2] {
        match self.places[s] {
            Place::Fixed(p) => p,
            Place::Zeta(i) => [zeta[i], zeta[i + 1]],
        }
    }

    #[inline]
    fn target(&self, s: usize, a: usize) -> usize {
        self.target_of[s * self.n_actions + a] as usize
    }
}

impl FeatureMap for HopFeatures {
    fn dim(&self) -> usize {
        Self::DIM
    }

    fn write(&self, s: usize, a: usize, zeta: &[f64], out: &mut [f32]) {
        let (c, l) = (self.center, self.scale);
        let xs = self.pos(s, zeta);
        let xt = self.pos(self.target(s, a), zeta);
        let dx = [xt[0] - xs[0], xt[1] - xs[1]];
        out[0] = ((xs[0] - c[0]) / l) as f32;
        out[1] = ((xs[1] - c[1]) / l) as f32;
        out[2] = ((xt[0] - c[0]) / l) as f32;
        out[3] = ((xt[1] - c[1]) / l) as f32;
        out[4] = (dx[0] / l) as f32;
        out[5] = (dx[1] / l) as f32;
        out[6] = ((dx[0] * dx[0] + dx[1] * dx[1]) / (l * l)) as f32;
    }

    fn chain(&self, s: usize, a: usize, zeta: &[f64], g: &[f32], scale: f64, out: &mut [f64]) {
        let l = self.scale;
        let t = self.target(s, a);
        let xs = self.pos(s, zeta);
        let xt = self.pos(t, zeta);
        let g = |i: usize| g[i] as f64 * scale;
        let dq = [2.0 * (xt[0] - xs[0]) / (l * l) * g(6), 2.0 * (xt[1] - xs[1]) / (l * l) * g(6)];
        if let Place::Zeta(i) = self.places[s] {
            out[i] += (g(0) - g(4)) / l - dq[0];
            out[i + 1] += (g(1) - g(5)) / l - dq[1];
        }
        if let Place::Zeta(i) = self.places[t] {
            out[i] += (g(2) + g(4)) / l + dq[0];
            out[i + 1] += (g(3) + g(5)) / l + dq[1];
        }
    }
}
