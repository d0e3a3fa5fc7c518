//! Reproducible random streams.
//!
//! Every random draw in envpg comes from a ChaCha12 stream whose key is derived from
//! `(seed, purpose, iteration, episode)` with SplitMix64 mixing. The output of ChaCha is
//! value-stable across `rand_chacha` versions, and because each episode has its own stream the
//! result does not depend on which thread or process ran it, or in which order.
//!
//! A [`StreamRng`] gives `rand_chacha::ChaCha12Rng`'s words in its order (tested against it),
//! and can be [primed](Streams::primed_stream): its first words generated up front, so that
//! clones of it replay the stream without deriving its key or running the cipher again (the
//! polish samples the same episodes at a few dozen designs an iteration).

use std::convert::Infallible;

use rand::rand_core::block::Generator;
use rand::{SeedableRng, TryRng};
use rand_chacha::ChaCha12Core;

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

/// Words the cipher generates at a time (four ChaCha blocks).
const BUFFER: usize = 64;

/// The generator behind every stream: ChaCha12 (64-bit block counter, stream id 0), its words
/// consumed in order as `rand_core`'s block buffer consumes them for `ChaCha12Rng` — a 64-bit
/// draw is the next two words, low first; a byte fill takes whole words, the last one even
/// when only part of it is used.
#[derive(Clone, Debug)]
pub struct StreamRng {
    core: ChaCha12Core,
    buf: [u32; BUFFER],
    /// The next unread word of `buf`; `BUFFER` when none is left.
    index: usize,
}

impl StreamRng {
    fn refill(&mut self) {
        self.core.generate(&mut self.buf);
        self.index = 0;
    }
}

impl SeedableRng for StreamRng {
    type Seed = [u8; 32];

    fn from_seed(seed: [u8; 32]) -> Self {
        Self { core: ChaCha12Core::from_seed(seed), buf: [0; BUFFER], index: BUFFER }
    }
}

impl TryRng for StreamRng {
    type Error = Infallible;

    #[inline]
    fn try_next_u32(&mut self) -> Result<u32, Infallible> {
        if self.index >= BUFFER {
            self.refill();
        }
        self.index += 1;
        Ok(self.buf[self.index - 1])
    }

    #[inline]
    fn try_next_u64(&mut self) -> Result<u64, Infallible> {
        let lo = u64::from(self.try_next_u32()?);
        let hi = u64::from(self.try_next_u32()?);
        Ok((hi << 32) | lo)
    }

    fn try_fill_bytes(&mut self, bytes: &mut [u8]) -> Result<(), Infallible> {
        for chunk in bytes.chunks_mut(4) {
            let w = self.try_next_u32()?.to_le_bytes();
            chunk.copy_from_slice(&w[..chunk.len()]);
        }
        Ok(())
    }
}

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

    /// [`Streams::stream`] with its first 64 words already generated: each clone of it gives
    /// the stream's words without running the cipher for them again.
    pub fn primed_stream(&self, purpose: Purpose, k: u64, e: u64) -> StreamRng {
        let mut rng = self.stream(purpose, k, e);
        rng.refill();
        rng
    }

    /// The stream for `(purpose, k, e)`.
    pub fn stream(&self, purpose: Purpose, k: u64, e: u64) -> StreamRng {
        StreamRng::from_seed(self.key(purpose, k, e))
    }

    /// The ChaCha key of stream `(purpose, k, e)`.
    fn key(&self, purpose: Purpose, k: u64, e: u64) -> [u8; 32] {
        let mut h = splitmix(self.seed ^ 0x656E_7670_6700_0000);
        h = splitmix(h ^ purpose as u64);
        h = splitmix(h ^ k);
        h = splitmix(h ^ e);
        let mut key = [0u8; 32];
        for chunk in key.chunks_exact_mut(8) {
            h = splitmix(h);
            chunk.copy_from_slice(&h.to_le_bytes());
        }
        key
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

    /// Every word, in patterns of 32- and 64-bit draws, byte fills of every length and draws
    /// through `rand`'s helpers, across many refills: what `rand_chacha::ChaCha12Rng` gives from
    /// the same key, for a fresh and for a primed stream.
    #[test]
    fn a_stream_is_rand_chachas_chacha12_word_for_word_fresh_or_primed() {
        use rand::RngExt;
        use rand_chacha::ChaCha12Rng;
        let streams = Streams::new(7);
        for e in 0..40u64 {
            let fresh = streams.stream(Purpose::Polish, 3, e);
            let primed = streams.primed_stream(Purpose::Polish, 3, e);
            for (name, mut ours) in [("fresh", fresh.clone()), ("primed", primed.clone()), ("clone of primed", primed)]
            {
                let mut theirs = ChaCha12Rng::from_seed(streams.key(Purpose::Polish, 3, e));
                // Odd offsets make 64-bit draws straddle refills; 0-length fills consume nothing.
                for step in 0..700u64 {
                    let at = format!("{name}, episode {e}, step {step}");
                    match (step * 7 + e) % 5 {
                        0 => assert_eq!(ours.next_u32(), theirs.next_u32(), "{at}"),
                        1 | 2 => assert_eq!(ours.next_u64(), theirs.next_u64(), "{at}"),
                        3 => {
                            let n = ((step + e) % 13) as usize;
                            let (mut a, mut b) = (vec![0u8; n], vec![0u8; n]);
                            ours.fill_bytes(&mut a);
                            theirs.fill_bytes(&mut b);
                            assert_eq!(a, b, "{at}");
                        }
                        _ => {
                            let (a, b): (f64, f64) = (ours.random(), theirs.random());
                            assert_eq!(a.to_bits(), b.to_bits(), "{at}");
                            assert_eq!(ours.random_range(0..1000usize), theirs.random_range(0..1000usize), "{at}");
                        }
                    }
                }
            }
        }
    }
}
