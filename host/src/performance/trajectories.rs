//! The seeded trajectories of a synthetic performance: every expression weight, the jaw and the
//! head as smooth waves of time, and each frame's ground truth drawn from them; optionally
//! opening on frames at rest, looking at the camera, from which the performance eases in (what
//! a person does while a live tool calibrates).

use sinew_core::linalg::{Mat3, Vec3};
use sinew_core::rotation::to_6d;

use crate::io::performance::FrameParameters;
use crate::training::random::Stream;

/// A smooth signal in [−1, 1]: the mean of three sinusoids of 0.1–0.8 Hz with random phases.
pub struct Wave([(f64, f64); 3]);

impl Wave {
    /// A wave of three seeded sinusoids.
    pub fn new(rng: &mut Stream) -> Self {
        Self([(); 3].map(|()| {
            (
                rng.uniform(0.1, 0.8),
                rng.uniform(0.0, std::f64::consts::TAU),
            )
        }))
    }

    /// The wave at `seconds`.
    pub fn at(&self, seconds: f64) -> f64 {
        self.0
            .iter()
            .map(|(f, phase)| (std::f64::consts::TAU * f * seconds + phase).sin())
            .sum::<f64>()
            / 3.0
    }
}

/// An expression weight's trajectory: `clamp(offset + amplitude · wave, 0, 1)`; the offset is
/// mostly negative, so each shape is active part of the time, as in a real performance.
pub struct Weight {
    wave: Wave,
    offset: f64,
    amplitude: f64,
}

/// Rotation `Rz(γ) Ry(β) Rx(α)`.
pub fn euler(a: f64, b: f64, g: f64) -> Mat3 {
    let (sa, ca) = a.sin_cos();
    let (sb, cb) = b.sin_cos();
    let (sg, cg) = g.sin_cos();
    let m = [
        [cg * cb, cg * sb * sa - sg * ca, cg * sb * ca + sg * sa],
        [sg * cb, sg * sb * sa + cg * ca, sg * sb * ca - cg * sa],
        [-sb, cb * sa, cb * ca],
    ];
    let col = |j: usize| Vec3::new(m[0][j] as f32, m[1][j] as f32, m[2][j] as f32);
    Mat3 {
        cols: [col(0), col(1), col(2)],
    }
}

/// A rotation and a translation as 9 values (6D rotation, translation).
pub fn nine(rot: &Mat3, t: [f64; 3]) -> [f32; 9] {
    let r = to_6d(rot);
    [
        r[0],
        r[1],
        r[2],
        r[3],
        r[4],
        r[5],
        t[0] as f32,
        t[1] as f32,
        t[2] as f32,
    ]
}

/// The trajectories of every parameter, seeded.
pub struct Trajectories {
    weights: Vec<Weight>,
    /// Jaw opening, yaw, and translation x, y, z.
    jaw: [Wave; 5],
    /// Head rotations about x, y, z and translation x, y, z.
    head: [Wave; 6],
}

impl Trajectories {
    /// The trajectories of `shapes` weights, the jaw and the head, drawn from `rng`.
    pub fn new(rng: &mut Stream, shapes: usize) -> Self {
        let weights = (0..shapes)
            .map(|_| Weight {
                wave: Wave::new(rng),
                offset: rng.uniform(-0.6, 0.2),
                amplitude: rng.uniform(0.4, 1.0),
            })
            .collect();
        Self {
            weights,
            jaw: [(); 5].map(|()| Wave::new(rng)),
            head: [(); 6].map(|()| Wave::new(rng)),
        }
    }

    /// The parameters at time `t` seconds; `jaw` false keeps the jaw transform the identity;
    /// `ease` scales the expression, the jaw and the head towards rest (none: in full).
    pub fn at(&self, t: f64, jaw: bool, ease: Option<Ease>) -> FrameParameters {
        let Ease {
            expression: e,
            head: g,
        } = ease.unwrap_or(Ease::FULL);
        let full = ease.is_none();
        let weights = self
            .weights
            .iter()
            .map(|w| {
                let v = (w.offset + w.amplitude * w.wave.at(t)).clamp(0.0, 1.0);
                (if full { v } else { e * v }) as f32
            })
            .collect();
        let j = |i: usize| {
            if full {
                self.jaw[i].at(t)
            } else {
                e * self.jaw[i].at(t)
            }
        };
        // Opening 0–0.12 rad about x (positive opens: the chin, in front of the pivot, goes
        // down), ±0.03 rad of yaw, ±0.5 mm of translation.
        let opening = if full {
            0.06 * (1.0 + j(0))
        } else {
            e * 0.06 * (1.0 + self.jaw[0].at(t))
        };
        let jaw = if jaw {
            nine(
                &euler(opening, 0.03 * j(1), 0.0),
                [0.05 * j(2), 0.05 * j(3), 0.05 * j(4)],
            )
        } else {
            nine(&Mat3::IDENTITY, [0.0; 3])
        };
        let h = |i: usize| {
            if full {
                self.head[i].at(t)
            } else {
                g * self.head[i].at(t)
            }
        };
        // ±0.08 rad about each axis, ±8 mm of translation.
        let head = nine(
            &euler(0.08 * h(0), 0.08 * h(1), 0.08 * h(2)),
            [0.8 * h(3), 0.8 * h(4), 0.8 * h(5)],
        );
        FrameParameters { weights, jaw, head }
    }
}

/// How much of a performance a frame plays after frames at rest: the expression's and the
/// jaw's share (0 at rest), and the head's (a little while at rest: a head held still sways).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ease {
    /// The expression's and the jaw's share, 0 to 1.
    pub expression: f64,
    /// The head's share, 0 to 1.
    pub head: f64,
}

impl Ease {
    /// The whole performance.
    pub const FULL: Self = Self {
        expression: 1.0,
        head: 1.0,
    };
    /// The head's share while at rest.
    pub const HEAD_AT_REST: f64 = 0.2;

    /// Frame `f` of a performance that rests for `rest` frames, then eases in over `ramp`
    /// frames (linearly); `None` (the whole performance, as before frames at rest existed)
    /// when it does not rest.
    pub fn at(f: usize, rest: usize, ramp: usize) -> Option<Self> {
        if rest == 0 {
            return None;
        }
        let e = if f < rest {
            0.0
        } else {
            ((f - rest + 1) as f64 / ramp.max(1) as f64).min(1.0)
        };
        Some(Self {
            expression: e,
            head: Self::HEAD_AT_REST + (1.0 - Self::HEAD_AT_REST) * e,
        })
    }
}
