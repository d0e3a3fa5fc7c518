//! [`Model`]: a training run's throughput predicted from the per-iteration costs `--bench`
//! measures, for any number of workers, either policy lag and any number of cores.
//!
//! One iteration moves T transitions. A worker spends `s` seconds sampling each (emulator step
//! and policy, the benchmark's raw loop) and `x` moving it (publish, receive, the iteration's
//! broadcast and wake-ups, spread over its transitions: the one-worker collect-only run minus
//! the raw loop); the learner spends `u` in `Learner::update` and `r` on the rest of its
//! iteration (ordering, recording, the policy table: the one-worker training run minus the
//! others). With W workers the gathering takes T(s + x)/W; lag 0 waits for it and then
//! updates, lag 1 updates meanwhile:
//!
//! ```text
//! lag 0: t = u + T(s + x)/W + r        lag 1: t = max(u, T(s + x)/W) + r
//! ```
//!
//! and no iteration is shorter than its CPU work spread over the cores, (c·u + r + T(s + x))/P,
//! where the update keeps c cores busy (it computes the ζ-gradient on a second thread; c is its
//! CPU seconds over its wall seconds when it runs alone). Predicted transitions/s are T/t.
//! Left out: how unevenly W workers share an iteration's episodes (where a collect-only run
//! measured the gathering, [`Model::iteration_seconds_with`] takes that time instead), and
//! what sharing a core costs beyond its time (caches), or the processes besides these take.

use serde::Serialize;

/// Per-iteration costs of a run, in seconds.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Model {
    /// Transitions per iteration, T.
    pub transitions: f64,
    /// Sampling per transition in one worker, s.
    pub sample: f64,
    /// Transport per transition, x.
    pub transport: f64,
    /// The learner's update, u.
    pub update: f64,
    /// Cores the update keeps busy, c (≥ 1).
    pub update_cores: f64,
    /// The rest of the learner's iteration, r.
    pub rest: f64,
}

impl Model {
    /// Fits the model to one-worker measurements: the raw loop's and the collect-only run's
    /// transitions/s; a lag-0 training run's transitions/s, transitions per iteration, update
    /// seconds per iteration and the update's CPU seconds per wall second.
    pub fn fit(raw: f64, collect_one: f64, train_one: f64, transitions: f64, update: f64, update_cores: f64) -> Self {
        let sample = 1.0 / raw;
        let transport = (1.0 / collect_one - sample).max(0.0);
        let rest = (transitions / train_one - update - transitions * (sample + transport)).max(0.0);
        Self { transitions, sample, transport, update, update_cores: update_cores.max(1.0), rest }
    }

    /// Seconds the workers take to gather an iteration's transitions when W share them evenly.
    pub fn gather_seconds(&self, workers: usize) -> f64 {
        self.transitions * (self.sample + self.transport) / workers.max(1) as f64
    }

    /// Seconds of one iteration with `workers` workers, policy lag `lag` (0 or 1) and `cores`
    /// cores.
    pub fn iteration_seconds(&self, workers: usize, lag: usize, cores: usize) -> f64 {
        self.iteration_seconds_with(self.gather_seconds(workers), lag, cores)
    }

    /// Seconds of one iteration whose gathering takes `gather` seconds (measured, say, with
    /// the workers' uneven shares), with policy lag `lag` and `cores` cores.
    pub fn iteration_seconds_with(&self, gather: f64, lag: usize, cores: usize) -> f64 {
        let wall = if lag == 0 { self.update + gather } else { self.update.max(gather) } + self.rest;
        let work = self.update_cores * self.update + self.rest + self.transitions * (self.sample + self.transport);
        wall.max(work / cores.max(1) as f64)
    }

    /// Predicted transitions/s.
    pub fn transitions_per_s(&self, workers: usize, lag: usize, cores: usize) -> f64 {
        self.transitions / self.iteration_seconds(workers, lag, cores)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_fit_reproduces_the_run_it_was_fitted_to() {
        // 200 transitions of 50 µs, 5 µs transport each; a 4 ms update, 1 ms of the rest.
        let m =
            Model { transitions: 200.0, sample: 50e-6, transport: 5e-6, update: 4e-3, update_cores: 1.5, rest: 1e-3 };
        let t = m.iteration_seconds(1, 0, 2);
        assert!((t - 16e-3).abs() < 1e-12, "{t}");
        let fitted = Model::fit(1.0 / 50e-6, 1.0 / 55e-6, 200.0 / t, 200.0, 4e-3, 1.5);
        for (a, b) in [(fitted.sample, m.sample), (fitted.transport, m.transport), (fitted.rest, m.rest)] {
            assert!((a - b).abs() < 1e-12, "{fitted:?}");
        }
    }

    #[test]
    fn lag_one_hides_the_update_until_the_cores_run_out() {
        let m =
            Model { transitions: 200.0, sample: 50e-6, transport: 5e-6, update: 4e-3, update_cores: 1.5, rest: 1e-3 };
        // One worker: sampling (11 ms) hides the update (4 ms) entirely.
        assert!((m.iteration_seconds(1, 1, 8) - 12e-3).abs() < 1e-12);
        // Many workers and cores: the update bounds both lags, lag 1 by itself.
        assert!((m.transitions_per_s(64, 1, 65) - 200.0 / 5e-3).abs() < 1e-6);
        assert!(m.transitions_per_s(64, 0, 65) < m.transitions_per_s(64, 1, 65));
        // Two cores: the CPU work (1.5 · 4 + 1 + 11 = 18 ms) over two cores bounds any number of
        // workers.
        assert!((m.iteration_seconds(8, 1, 2) - 9e-3).abs() < 1e-12);
        // More workers never predict fewer transitions/s.
        for lag in [0, 1] {
            let xs: Vec<f64> = (1..=64).map(|w| m.transitions_per_s(w, lag, w + 1)).collect();
            assert!(xs.windows(2).all(|p| p[1] >= p[0]), "lag {lag}: {xs:?}");
        }
    }
}
