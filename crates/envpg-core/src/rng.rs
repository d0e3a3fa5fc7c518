//! Reproducible random streams.
//!
//! Every random draw in envpg comes from a ChaCha12 stream whose key is derived from
//! `(seed, purpose, iteration, episode)` with SplitMix64 mixing. The output of ChaCha is
//! value-stable across `rand_chacha` versions, and because each episode has its own stream the
//! result does not depend on which thread or process ran it, or in which order.

use rand::SeedableRng;
use rand_chacha::ChaCha12Rng;

/// What a stream is used for; distinct purposes never share a stream.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u64)]
pub enum Purpose {
    /// Rollout episode `(k, e)`: initial state, actions, ζ perturbations, transitions.
    Episode = 1,
    /// Learner minibatch sampling at iteration k.
    Minibatch = 2,
    /// Network initialisation.
    Init = 3,
    /// Initial design ζ₀.
    Zeta0 = 4,
    /// Oracle restarts and annealing perturbations.
    Oracle = 5,
    /// Exploration episodes `(k, e)` used only to train the critic and actor.
    Explore = 6,
    /// Anything else a caller needs, keyed by its own sub-index.
    Other = 7,
    /// Episodes `(iteration, e)` of the ζ polish after the last iteration.
    Polish = 8,
}

/// The generator behind every stream.
pub type StreamRng = ChaCha12Rng;

/// A family of streams for one run seed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Streams {
    seed: u64,
}

/// SplitMix64 finaliser: a bijective, well-mixed map of 64-bit words.
fn splitmix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

impl Streams {
    /// Streams of run seed `seed`.
    pub fn new(seed: u64) -> Self {
        Self { seed }
    }

    /// The run seed.
    pub fn seed(&self) -> u64 {
        self.seed
    }

    /// The stream for `(purpose, k, e)`.
    pub fn stream(&self, purpose: Purpose, k: u64, e: u64) -> StreamRng {
        let mut h = splitmix(self.seed ^ 0x656E_7670_6700_0000);
        h = splitmix(h ^ purpose as u64);
        h = splitmix(h ^ k);
        h = splitmix(h ^ e);
        let mut key = [0u8; 32];
        for chunk in key.chunks_exact_mut(8) {
            h = splitmix(h);
            chunk.copy_from_slice(&h.to_le_bytes());
        }
        ChaCha12Rng::from_seed(key)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::Rng;

    #[test]
    fn streams_are_reproducible_and_distinct() {
        let s = Streams::new(42);
        let a: Vec<u64> = (0..4)
            .map({
                let mut r = s.stream(Purpose::Episode, 3, 1);
                move |_| r.next_u64()
            })
            .collect();
        let b: Vec<u64> = (0..4)
            .map({
                let mut r = s.stream(Purpose::Episode, 3, 1);
                move |_| r.next_u64()
            })
            .collect();
        assert_eq!(a, b);
        let mut c = s.stream(Purpose::Episode, 1, 3);
        assert_ne!(a[0], c.next_u64());
        let mut d = Streams::new(43).stream(Purpose::Episode, 3, 1);
        assert_ne!(a[0], d.next_u64());
    }

    #[test]
    fn stream_values_are_pinned() {
        // Guards version stability: these words must never change, or old runs stop reproducing.
        let mut r = Streams::new(1).stream(Purpose::Episode, 0, 0);
        let first = r.next_u64();
        let mut again = Streams::new(1).stream(Purpose::Episode, 0, 0);
        assert_eq!(first, again.next_u64());
        assert_eq!(first, PINNED_FIRST_WORD);
    }

    const PINNED_FIRST_WORD: u64 = 14_766_761_381_392_027_909;
}
