//! Seeded PCG-64 streams and the draws made from them: uniform floats, integers below a bound,
//! standard normals, shuffles. One implementation for the data generators (`data s2d-pairs`,
//! `data motions`, `data performance`) and the trainers' and fit's draws (epoch orders, batches,
//! sampled points, the GAN's noise), so that a seed means the same numbers on every platform and
//! every run. Each caller keeps its own stream constants, so
//! the streams of different draws never overlap.

use rand_core::{RngCore, SeedableRng};

/// A PCG-64 stream (`rand_pcg::Pcg64`) with the draws the generators share.
#[derive(Clone, Debug)]
pub struct Stream(rand_pcg::Pcg64);

impl Stream {
    /// The stream of state `seed << 64 | key` and increment `stream` (PCG's stream selector).
    pub fn new(seed: u64, key: u64, stream: u128) -> Self {
        Self(rand_pcg::Pcg64::new(
            u128::from(seed) << 64 | u128::from(key),
            stream,
        ))
    }

    /// The stream `rand_pcg::Pcg64::seed_from_u64(state)` chooses (rand_core's seed expansion).
    pub fn seed_from_u64(state: u64) -> Self {
        Self(rand_pcg::Pcg64::seed_from_u64(state))
    }

    /// Uniform in [0, 1) from the top 53 bits of one output.
    pub fn unit(&mut self) -> f64 {
        (self.0.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Uniform in [`lo`, `hi`), as `lo + (hi − lo) · unit`.
    pub fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }

    /// Uniform in [`lo`, `hi`) in `f32`: `lo + (hi − lo) · unit`, the unit rounded to `f32`.
    pub fn uniform_f32(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.unit() as f32
    }

    /// Uniform integer in `0..n` (`n > 0`), by multiply-shift of one output.
    pub fn below(&mut self, n: usize) -> usize {
        ((u128::from(self.0.next_u64()) * n as u128) >> 64) as usize
    }

    /// Standard normal by Box–Muller, one value per call (the second is dropped, so that the
    /// stream's position does not depend on how many normals were drawn before).
    pub fn normal(&mut self) -> f64 {
        let u1 = 1.0 - self.unit(); // (0, 1]: ln is finite
        let u2 = self.unit();
        (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    }

    /// Fisher–Yates shuffle of `v`, from the last element down.
    pub fn shuffle<T>(&mut self, v: &mut [T]) {
        for i in (1..v.len()).rev() {
            let j = self.below(i + 1);
            v.swap(i, j);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The draws are functions of PCG-64's outputs, pinned here: the data sets and goldens made
    /// from them depend on every bit.
    #[test]
    fn draws_are_pinned_to_pcg64s_outputs() {
        let mut s = Stream::new(1, 0x5d2d_da7a, 0x00a0_2bdb_0000_0000_0000_0000_0000_0001);
        let mut raw = rand_pcg::Pcg64::new(
            1u128 << 64 | 0x5d2d_da7a,
            0x00a0_2bdb_0000_0000_0000_0000_0000_0001,
        );
        let a = raw.next_u64();
        assert_eq!(s.unit(), (a >> 11) as f64 / 9_007_199_254_740_992.0);
        let b = raw.next_u64();
        assert_eq!(s.below(7), ((u128::from(b) * 7) >> 64) as usize);
        let (c, d) = (raw.next_u64(), raw.next_u64());
        let u1 = 1.0 - (c >> 11) as f64 / 9_007_199_254_740_992.0;
        let u2 = (d >> 11) as f64 / 9_007_199_254_740_992.0;
        let n = (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos();
        assert_eq!(s.normal().to_bits(), n.to_bits());
        let e = raw.next_u64();
        let u = (e >> 11) as f64 / 9_007_199_254_740_992.0;
        assert_eq!(s.uniform_f32(0.5, 2.0), 0.5 + 1.5 * u as f32);
    }

    #[test]
    fn uniforms_stay_in_range_and_shuffles_permute() {
        let mut s = Stream::new(7, 1, 3);
        for _ in 0..1000 {
            let x = s.uniform(-2.0, 3.0);
            assert!((-2.0..3.0).contains(&x));
            assert!(s.below(5) < 5);
        }
        let mut v: Vec<usize> = (0..50).collect();
        s.shuffle(&mut v);
        assert_ne!(v, (0..50).collect::<Vec<_>>());
        v.sort_unstable();
        assert_eq!(v, (0..50).collect::<Vec<_>>());
        // Same seed, key and stream: the same draws; another key: others.
        let draw = |key| {
            let mut s = Stream::new(9, key, 1);
            [s.unit(), s.unit()]
        };
        assert_eq!(draw(1), draw(1));
        assert_ne!(draw(1), draw(2));
    }
}
