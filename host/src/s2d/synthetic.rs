//! Random mesh hierarchies with the shapes of real ones, for tests and benchmarks that depend on
//! sizes only (parameter counts, step times, parity of the core with burn). Positions are random
//! points, spirals start at their own vertex and continue at random vertices (the dummy vertex
//! included, as padding is), and each fine vertex up-samples from three random coarse parents with
//! barycentric weights. No triangles: nothing here is a mesh.

use rand_core::RngCore;

use super::{Hierarchy, Level, Sampling};

/// Vertices per level of the CoMA/FLAME hierarchy (5023 decimated by 4, four times).
pub const REFERENCE_SIZES: [usize; 5] = [5023, 1256, 314, 79, 20];

/// Spiral lengths of the reference hierarchy (after dilation), finest first.
pub const REFERENCE_SPIRALS: [usize; 5] = [15, 14, 9, 9, 7];

/// A seeded generator of uniform floats and integers.
#[derive(Debug)]
pub struct Rng(rand_pcg::Pcg64);

impl Rng {
    /// A generator for `seed`.
    pub fn new(seed: u64) -> Self {
        Self(rand_pcg::Pcg64::new(
            u128::from(seed) << 64 | 0x5eed,
            0xa02b_dbf7_bb3c_0a7a_c28f_a16a_64ab_f96b,
        ))
    }

    /// Uniform in `[lo, hi)`.
    pub fn uniform(&mut self, lo: f32, hi: f32) -> f32 {
        let u = (self.0.next_u32() >> 8) as f32 / (1u32 << 24) as f32;
        lo + (hi - lo) * u
    }

    /// Uniform in `0..n` (`n > 0`).
    pub fn below(&mut self, n: usize) -> usize {
        ((u128::from(self.0.next_u64()) * n as u128) >> 64) as usize
    }
}

/// A random hierarchy with `sizes[i]` vertices and spirals of `spiral_lens[i]` at level `i`
/// (finest first), and up- and down-samplings between neighbouring levels.
///
/// # Panics
/// If the two slices differ in length or are empty, or a level has no vertices.
pub fn hierarchy(sizes: &[usize], spiral_lens: &[usize], seed: u64) -> Hierarchy {
    assert!(!sizes.is_empty() && sizes.len() == spiral_lens.len());
    assert!(sizes.iter().all(|&n| n > 0));
    let mut rng = Rng::new(seed);
    let levels = sizes
        .iter()
        .zip(spiral_lens)
        .map(|(&n, &len)| {
            let positions = (0..n)
                .map(|_| [0; 3].map(|_| rng.uniform(-0.1, 0.1)))
                .collect();
            let mut spirals = Vec::with_capacity((n + 1) * len);
            for v in 0..n {
                spirals.push(v as u32);
                for _ in 1..len {
                    // n + 1 choices: the dummy index n stands for the padding of short spirals.
                    spirals.push(rng.below(n + 1) as u32);
                }
            }
            spirals.extend(std::iter::repeat_n(n as u32, len));
            Level {
                positions,
                triangles: Vec::new(),
                spiral_len: len,
                spirals,
            }
        })
        .collect();
    let mut up = Vec::new();
    let mut down = Vec::new();
    for w in sizes.windows(2) {
        let (fine, coarse) = (w[0], w[1]);
        let mut row_ptr = vec![0u32];
        let (mut col_idx, mut values) = (Vec::new(), Vec::new());
        for _ in 0..fine {
            let a = rng.uniform(0.0, 1.0);
            let b = rng.uniform(0.0, 1.0 - a);
            for weight in [a, b, 1.0 - a - b] {
                col_idx.push(rng.below(coarse) as u32);
                values.push(weight);
            }
            row_ptr.push(col_idx.len() as u32);
        }
        col_idx.push(coarse as u32);
        values.push(1.0);
        row_ptr.push(col_idx.len() as u32);
        up.push(Sampling {
            rows: fine + 1,
            cols: coarse + 1,
            row_ptr,
            col_idx,
            values,
        });
        // Keep fine vertex j as coarse vertex j, and the dummy as the dummy.
        let mut col_idx: Vec<u32> = (0..coarse as u32).collect();
        col_idx.push(fine as u32);
        down.push(Sampling {
            rows: coarse + 1,
            cols: fine + 1,
            row_ptr: (0..=coarse as u32 + 1).collect(),
            col_idx,
            values: vec![1.0; coarse + 1],
        });
    }
    Hierarchy { levels, down, up }
}

/// The small decoder configuration the tests use on a `[30, 12, 5]` hierarchy: 6 inputs (two
/// landmarks), 4 FC features, stages of 5 and 3 filters.
pub fn small_config() -> super::decoder::DecoderConfig {
    super::decoder::DecoderConfig {
        inputs: 6,
        fc_features: 4,
        filters: vec![5, 3],
        ..super::decoder::DecoderConfig::default()
    }
}

/// A tiny baked decoder for tests: the synthetic hierarchy of 8 → 3 vertices (spirals 3, 2), a
/// freshly initialised decoder (6 inputs: landmarks at vertices 1 and 6, 2 FC features, one
/// 2-filter stage) baked with `units = m`. Returns the hierarchy and the bytes.
pub fn tiny_baked_decoder() -> (Hierarchy, Vec<u8>) {
    use super::decoder::{DecoderConfig, S2dDecoder};
    let device = crate::training::backend::Backend::Flex
        .device(3)
        .expect("the flex backend is always built in");
    let h = hierarchy(&[8, 3], &[3, 2], 4);
    let config = DecoderConfig {
        inputs: 6,
        fc_features: 2,
        filters: vec![2],
        ..super::decoder::DecoderConfig::default()
    };
    let dec = S2dDecoder::new(&config, &h, &device).expect("a valid configuration");
    let meta = [("units".to_owned(), "m".to_owned())];
    let bytes = super::bake::bake(&dec, &h, &[1, 6], &meta).expect("the tiny decoder bakes");
    (h, bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shapes_are_consistent() {
        let h = hierarchy(&[30, 12, 5], &[5, 4, 3], 1);
        crate::s2d::decoder::check_hierarchy(&h).unwrap();
        assert_eq!(h.up[0].rows, 31);
        assert_eq!(h.up[1].cols, 6);
        assert_eq!(h.down[0].rows, 13);
        // Every non-dummy up-sampling row sums to 1.
        for u in &h.up {
            for r in 0..u.rows {
                let s: f32 = u.values[u.row_ptr[r] as usize..u.row_ptr[r + 1] as usize]
                    .iter()
                    .sum();
                assert!((s - 1.0).abs() < 1e-6);
            }
        }
        assert_eq!(h, hierarchy(&[30, 12, 5], &[5, 4, 3], 1));
        assert_ne!(h, hierarchy(&[30, 12, 5], &[5, 4, 3], 2));
    }
}
