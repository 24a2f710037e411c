//! The baked actor's playback cache a fit works from ([`ActorCache`], in mm), and the identity
//! pose it starts from.

use sinew_core::aim::AimActor;

/// The identity head and jaw, `[6D, t]` twice.
pub(super) const IDENTITY_18: [f32; 18] = [
    1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0,
];

/// The baked actor's playback cache, in mm (the fit's unit).
#[derive(Clone, Debug)]
pub struct ActorCache {
    /// Vertices V.
    pub vertices: usize,
    /// Corrective shapes M = N − 1.
    pub shapes: usize,
    /// Neutral skin s0, `[V·3]`, mm.
    pub rest: Vec<f32>,
    /// Jaw skinning weight k, `[V]`.
    pub k: Vec<f32>,
    /// B_e, `[V·M·3]`, mm.
    pub correctives: Vec<f32>,
    /// Jaw pivot, mm.
    pub pivot: [f32; 3],
    /// Template points normalised to [−1, 1]: `(c − centre) / half`.
    pub normalised: Vec<f32>,
    /// The template's bounding-box centre (the actor's units).
    pub centre: [f32; 3],
    /// Half the bounding box's largest extent (the actor's units).
    pub half: f32,
    /// Millimetres per unit of the actor.
    pub mm: f32,
}

impl ActorCache {
    /// The cache of a baked actor whose lengths are in `unit_mm` millimetres.
    pub fn new(actor: &AimActor<'_>, unit_mm: f32) -> Self {
        let scaled = |v: sinew_core::tensor::F32s<'_>| v.iter().map(|x| x * unit_mm).collect();
        let tpl: Vec<f32> = actor.template().iter().collect();
        let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
        for p in tpl.chunks_exact(3) {
            for c in 0..3 {
                lo[c] = lo[c].min(p[c]);
                hi[c] = hi[c].max(p[c]);
            }
        }
        let centre = [0, 1, 2].map(|c| 0.5 * (lo[c] + hi[c]));
        let half = (0..3).map(|c| 0.5 * (hi[c] - lo[c])).fold(1e-12, f32::max);
        let normalised = tpl
            .chunks_exact(3)
            .flat_map(|p| [0, 1, 2].map(|c| (p[c] - centre[c]) / half))
            .collect();
        Self {
            vertices: actor.vertex_count(),
            shapes: actor.shape_count(),
            rest: scaled(actor.rest()),
            k: actor.skinning_weights().iter().collect(),
            correctives: scaled(actor.correctives()),
            pivot: actor.jaw_pivot().to_array().map(|x| x * unit_mm),
            normalised,
            centre,
            half,
            mm: unit_mm,
        }
    }
}
