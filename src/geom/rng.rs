//! Deterministic random numbers. `pcg_hash` and `hash_to_unit` have GLSL twins
//! (`glsl/include/sampling.glsl`); `Rng` is CPU-only (construction, reference).

/// PCG hash (Jarzynski & Olano 2020, "Hash functions for GPU rendering").
#[inline]
pub fn pcg_hash(v: u32) -> u32 {
    let state = v.wrapping_mul(747_796_405).wrapping_add(2_891_336_453);
    let word = ((state >> ((state >> 28) + 4)) ^ state).wrapping_mul(277_803_737);
    (word >> 22) ^ word
}

/// A float in [0, 1) from the top 24 bits of a hash: exact in f32 on every device.
#[inline]
pub fn hash_to_unit(h: u32) -> f32 {
    (h >> 8) as f32 * (1.0 / 16_777_216.0)
}

/// Mixes two words into one hash.
#[inline]
pub fn hash2(a: u32, b: u32) -> u32 {
    pcg_hash(a ^ pcg_hash(b.wrapping_add(0x9e37_79b9)))
}

/// SplitMix64: a small, fast, seedable generator for CPU-side sampling.
#[derive(Clone, Debug)]
pub struct Rng {
    state: u64,
}

impl Rng {
    /// A generator for stream `stream` of seed `seed`.
    pub fn new(seed: u64, stream: u64) -> Self {
        let mut r = Rng {
            state: seed ^ stream.wrapping_mul(0xd1b5_4a32_d192_ed03),
        };
        r.next_u64();
        r
    }

    /// The next 64 random bits.
    #[inline]
    pub fn next_u64(&mut self) -> u64 {
        self.state = self.state.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.state;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1).
    #[inline]
    pub fn next_f32(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 * (1.0 / 16_777_216.0)
    }

    /// Uniform in [0, 1), double precision.
    #[inline]
    pub fn next_f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / 9_007_199_254_740_992.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unit_floats_stay_in_range() {
        for i in 0..100_000u32 {
            let u = hash_to_unit(pcg_hash(i));
            assert!((0.0..1.0).contains(&u));
        }
        let mut r = Rng::new(1, 2);
        for _ in 0..100_000 {
            let u = r.next_f32();
            assert!((0.0..1.0).contains(&u));
        }
    }

    #[test]
    fn hash_is_roughly_uniform() {
        let mut bins = [0u32; 16];
        for i in 0..160_000u32 {
            bins[(hash_to_unit(hash2(i, 7)) * 16.0) as usize] += 1;
        }
        for b in bins {
            assert!((9_000..11_000).contains(&b), "{bins:?}");
        }
    }
}
