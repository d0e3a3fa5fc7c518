//! Idle design elements: the visit averages the learner keeps, and the move of the least-visited
//! element to where the environment says it would serve the costliest hop.

use envpg_core::DesignElement;

use super::Learner;
use crate::rollout::Episode;

impl Learner {
    /// Updates the visit averages with this iteration's on-policy states and, on schedule,
    /// moves the least-visited idle design element to where the environment says it would
    /// serve the costliest on-policy hop of this iteration ([`ParamMdp::relocate`]). The move is
    /// J-neutral (an unvisited element contributes nothing to J) and gives the gradient an
    /// element to work with: an idle element's ζ-gradient is exactly zero.
    pub(super) fn track_and_relocate(&mut self, on: &[&Episode]) -> Option<u32> {
        const DECAY: f64 = 0.95;
        self.visits.iter_mut().for_each(|v| *v *= DECAY);
        let w = (1.0 - DECAY) / on.len().max(1) as f64;
        for ep in on {
            for &s in &ep.s {
                self.visits[s as usize] += w;
            }
        }
        let every = self.cfg.relocate_every as u64;
        if every == 0 || self.k < self.cfg.warmup as u64 || (self.k - self.cfg.warmup as u64) % every != every - 1 {
            return None;
        }
        let visits = |e: &DesignElement| e.states.iter().map(|&s| self.visits[s]).sum::<f64>();
        let busy_v = self.elements.iter().map(visits).fold(0.0, f64::max);
        let (idle, idle_v) =
            self.elements.iter().enumerate().map(|(i, e)| (i, visits(e))).min_by(|a, b| a.1.total_cmp(&b.1))?;
        if busy_v <= 0.0 || idle_v >= self.cfg.relocate_below * busy_v {
            return None;
        }
        // The costliest on-policy hop (observed cost between observed states).
        let mut best: Option<(f64, usize, usize)> = None;
        for ep in on {
            for t in 0..ep.len() {
                let c = ep.cost[t] as f64;
                if best.is_none_or(|b| c > b.0) {
                    best = Some((c, ep.s[t] as usize, ep.s2[t] as usize));
                }
            }
        }
        let (_, from, to) = best?;
        let element = &self.elements[idle];
        let coords = self.env.relocate(element, &self.zeta, from, to)?;
        for (c, z) in element.coords.clone().zip(coords) {
            self.zeta[c] = z;
            self.zeta_opt.m[c] = 0.0;
            self.zeta_opt.v[c] = 0.0;
        }
        self.space.project(&mut self.zeta);
        let share = self.cfg.relocate_below * busy_v / element.states.len() as f64;
        for &s in &element.states {
            self.visits[s] = share;
        }
        self.features.set_center(&self.zeta);
        Some(element.states[0] as u32)
    }
}
