//! The one table of allowed differences between the core's deterministic kernels and burn running
//! the same maths on the same weights. Bits are compared only where determinism is promised (the
//! core against itself across targets); here two implementations of the same formula meet, and
//! each entry says why they may differ and by how much.

/// One comparison's allowance: `|core − burn| ≤ abs + rel·|burn|` for every output value.
#[derive(Clone, Copy, Debug)]
pub struct Tolerance {
    /// What is compared.
    pub what: &'static str,
    /// Absolute allowance.
    pub abs: f32,
    /// Relative allowance.
    pub rel: f32,
    /// Why the two may differ at all.
    pub reason: &'static str,
}

impl Tolerance {
    /// Whether `core` is within this allowance of `reference`.
    pub fn accepts(&self, core: f32, reference: f32) -> bool {
        (core - reference).abs() <= self.abs + self.rel * reference.abs()
    }

    /// The first index where `core` and `reference` differ beyond the allowance, with both values.
    pub fn first_violation(&self, core: &[f32], reference: &[f32]) -> Option<(usize, f32, f32)> {
        if core.len() != reference.len() {
            return Some((core.len().min(reference.len()), f32::NAN, f32::NAN));
        }
        core.iter()
            .zip(reference)
            .position(|(&c, &r)| !self.accepts(c, r))
            .map(|i| (i, core[i], reference[i]))
    }
}

/// Dense/GELU/ELU MLP against burn.
pub const MLP: Tolerance = Tolerance {
    what: "MLP (dense + GELU/ELU/ReLU)",
    abs: 1e-5,
    rel: 1e-5,
    reason: "burn's matmul blocks and vectorises the dot products (a different summation order, \
             possibly fused multiply-adds); the core sums in index order without FMA. Each output \
             is a sum of ≤ 256 products of O(1) terms: a few ulps of 1.",
};

/// SIREN against burn.
pub const SIREN: Tolerance = Tolerance {
    what: "SIREN (sin(ω0·(Wx+b)), ω0 = 30)",
    abs: 2e-4,
    rel: 1e-4,
    reason: "as for the MLP, and the sine multiplies each pre-activation's rounding error by ω0 = 30 \
             before the next layer sums 256 of them; burn's sin and libm's sinf may also differ by \
             an ulp.",
};

/// Spiral convolution against burn.
pub const SPIRAL_CONV: Tolerance = Tolerance {
    what: "spiral convolution (gather + linear + ELU)",
    abs: 1e-5,
    rel: 1e-5,
    reason: "one dot product of len·in terms per output, summed in a different order by burn's matmul.",
};

/// The whole S2D decoder (FC, four up-sampling + spiral + ELU stages, output convolution).
pub const S2D_DECODER: Tolerance = Tolerance {
    what: "S2D decoder (FC 204 → 2688, 4 stages, output conv; 5023 vertices)",
    abs: 1e-6,
    rel: 1e-5,
    reason: "burn's matmul sums each product in a different order (blocked, FMA) and burn's \
             training layout multiplies before it gathers, so a convolution output is summed per \
             spiral position and then across positions instead of in one pass; the core sums in \
             index order without FMA. Five layers of dot products of up to 1152 terms and four \
             sparse up-samplings pass each rounding on: a few ulps of the largest intermediate \
             values, which are O(1). Measured 3e-8 to 4e-8 at initialisation (docs/S2D.md).",
};

/// The exported glTF rig, posed by glTF's rules, against the core's playback (model units).
pub const GLTF_RIG: Tolerance = Tolerance {
    what: "glTF rig (sinew export gltf) vs sinew-core playback, positions in model units",
    abs: GLTF_RIG_ABS,
    rel: 1e-6,
    reason: "glTF morphs before it skins and clamps the jaw weights into [0, 1]; the export \
             compensates both (every shape's target for its own jaw, the animation's frames by \
             jawCompensation targets, export::jaw) to within 5e-6 m a vertex, and stores f32 \
             metres and f32 unit quaternions (an ulp or two of coordinates of order 10 cm). \
             Measured 7.7e-5 cm on the golden ICT actor over 30 frames with every shape playing, \
             the jaw along its learned jawOpen (21°) and the head turning (host/tests/suite/gltf.rs, \
             2026-12-01).",
};

/// The bound of [`GLTF_RIG`] in cm on the ICT actor: 0.01 mm, the compensation's 0.005 mm and
/// rounding.
const GLTF_RIG_ABS: f32 = 1e-3;

/// A fit evaluated by burn (in mm) against its baked performance played by sinew-core.
pub const FIT_PLAYBACK: Tolerance = Tolerance {
    what: "fitted performance: burn's fit (mm, scaled back) vs sinew-core's playback, model units",
    abs: 1e-4,
    rel: 1e-5,
    reason: "the fit runs in mm and divides by the unit afterwards where the core poses in the \
             actor's units; F_W's GELU layers are summed in burn's matmul order (as for MLP); the \
             rotations are made from the 6D parameters by burn's and the core's Gram-Schmidt. \
             Coordinates of order 10 cm.",
};

/// Every entry, for documentation and the report.
pub const TABLE: [Tolerance; 6] = [MLP, SIREN, SPIRAL_CONV, S2D_DECODER, GLTF_RIG, FIT_PLAYBACK];
