//! What a real landmark tracker does to a 68-point track, drawn from a seeded stream, for the
//! generators and trainers that must expect it (docs/FIT.md, "Live driving"):
//!
//! - a **convention**: where its annotators put each iBUG landmark, as smooth systematic offsets
//!   from the actor's landmark vertices in the face's frame (x right, y up, z out of the face),
//!   largest on the contour (the jaw's silhouette), the lips (their visible contour) and the
//!   brows (their upper edge), small on the nose and eye corners, where trackers and meshes
//!   agree. Left and right mirror each other (annotators follow one rule for both sides), with a
//!   little of each landmark's own;
//! - **failures**: runs of frames the tracker misreads, as a widely used 68-point tracker was
//!   measured to (issue: "the head pushed 8 cm away, as if the face were smaller", for eight
//!   consecutive frames), a face found elsewhere in the image for a frame or three, a frame
//!   whose points scatter (motion blur), and frames where it finds no face at all.

use serde::{Deserialize, Serialize};
use sinew_core::driver::LANDMARKS;

use super::random::Stream;
use crate::io::performance::{Failure, FailureRun};

/// The landmark groups of a convention, each with its amplitude relative to the contour's.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Group {
    Contour,
    Brows,
    Nose,
    Eyes,
    Lips,
}

impl Group {
    const fn amplitude(self) -> f64 {
        match self {
            Self::Contour => 1.0,
            Self::Brows | Self::Lips => 0.75,
            Self::Nose | Self::Eyes => 0.1,
        }
    }

    const ALL: [Self; 5] = [
        Self::Contour,
        Self::Brows,
        Self::Nose,
        Self::Eyes,
        Self::Lips,
    ];
}

/// Where landmark `l` sits for a convention: its group, the part of the group (a smooth curve:
/// the upper and lower lip are two), its place along the part from the face's middle outwards
/// (0 to 1), and its side (−1 image left, +1 image right, 0 on the middle line).
fn place(l: usize) -> (Group, usize, f64, f64) {
    // −1, 0 or +1 as `l` lies before, on or after the middle landmark `mirror`.
    let side = |mirror: usize| match l.cmp(&mirror) {
        std::cmp::Ordering::Less => -1.0,
        std::cmp::Ordering::Equal => 0.0,
        std::cmp::Ordering::Greater => 1.0,
    };
    match l {
        0..=16 => (Group::Contour, 0, (l as f64 - 8.0).abs() / 8.0, side(8)),
        17..=21 => (Group::Brows, 0, (21 - l) as f64 / 4.0, -1.0),
        22..=26 => (Group::Brows, 0, (l - 22) as f64 / 4.0, 1.0),
        27..=30 => (Group::Nose, 0, (l - 27) as f64 / 3.0, 0.0),
        31..=35 => (Group::Nose, 1, (l as f64 - 33.0).abs() / 2.0, side(33)),
        // Eyes: from the inner corner (0) round the upper lid, then the lower; one curve.
        36..=41 => (Group::Eyes, 0, [1.0, 0.8, 0.4, 0.0, 0.2, 0.6][l - 36], -1.0),
        42..=47 => (Group::Eyes, 0, [0.0, 0.4, 0.8, 1.0, 0.6, 0.2][l - 42], 1.0),
        // Outer lips: the upper from the middle (51) to the corners (48, 54), the lower from
        // its middle (57) towards them.
        48..=54 => (Group::Lips, 0, (l as f64 - 51.0).abs() / 3.0, side(51)),
        55..=59 => (Group::Lips, 1, (l as f64 - 57.0).abs() / 3.0, -side(57)),
        // Inner lips: the upper (60–64, middle 62) and the lower (65–67, middle 66).
        60..=64 => (Group::Lips, 2, (l as f64 - 62.0).abs() / 2.0, side(62)),
        _ => (Group::Lips, 3, (l as f64 - 66.0).abs() / 2.0, -side(66)),
    }
}

/// A tracker's convention: per landmark its offset from the actor's landmark vertex, in the
/// face's frame, in the unit the amplitude was given in.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Convention {
    /// `[68]` offsets (x right, y up, z out of the face).
    pub offsets: Vec<[f64; 3]>,
}

impl Convention {
    /// A convention drawn from `rng` whose contour offsets have a root mean square length of
    /// about `amplitude` (the brows and lips three quarters of it, the nose and eyes a tenth):
    /// per group and part a quadratic `a + b s + c s²` along the part in each axis (x mirrored
    /// between the sides, zero on the middle line; z halved: a tracker annotates the image),
    /// plus a tenth of the amplitude of each landmark's own.
    pub fn draw(rng: &mut Stream, amplitude: f64) -> Self {
        // Per group, four parts, three axes, three coefficients: drawn in one fixed order.
        let mut curves = [[[[0.0f64; 3]; 3]; 4]; 5];
        for part in curves.iter_mut().flatten() {
            for axis in part.iter_mut() {
                for (k, c) in axis.iter_mut().enumerate() {
                    *c = [0.7, 0.5, 0.35][k] * rng.normal();
                }
            }
        }
        let offsets = (0..LANDMARKS)
            .map(|l| {
                let (group, part, s, side) = place(l);
                let g = Group::ALL.iter().position(|&x| x == group).unwrap_or(0);
                let curve = &curves[g][part];
                let a = amplitude * group.amplitude();
                std::array::from_fn(|axis| {
                    let [c0, c1, c2] = curve[axis];
                    let smooth = c0 + c1 * s + c2 * s * s;
                    let own = 0.1 * rng.normal();
                    let v = match axis {
                        0 => side * smooth + own,
                        1 => smooth + own,
                        _ => 0.5 * (smooth + own),
                    };
                    a * v
                })
            })
            .collect();
        Self { offsets }
    }

    /// The convention of no tracker: every offset zero.
    pub fn none() -> Self {
        Self {
            offsets: vec![[0.0; 3]; LANDMARKS],
        }
    }

    /// The root mean square offset length of the landmarks `range`.
    pub fn rms(&self, range: std::ops::Range<usize>) -> f64 {
        let n = range.len().max(1) as f64;
        (self.offsets[range]
            .iter()
            .map(|o| o.iter().map(|v| v * v).sum::<f64>())
            .sum::<f64>()
            / n)
            .sqrt()
    }
}

/// Drawing failures (`FailureRun` is the performance folder's record of one).
#[derive(Clone, Copy, Debug)]
pub struct Failures;

impl Failures {
    /// `count` failures drawn from `rng` over the frames `from..to`, apart from each other (each
    /// starts after the last has ended and a quarter second, at `fps`), kinds in turn: a face
    /// read 8–15 % smaller for 4–10 frames, one found 80–160 px away for 1–3 frames, one frame
    /// scattered by 10–16 px, no face for 1–5 frames. Fewer when the frames run out.
    pub fn draw(
        rng: &mut Stream,
        count: usize,
        from: usize,
        to: usize,
        fps: f64,
    ) -> Vec<FailureRun> {
        let gap = (0.25 * fps).ceil() as usize;
        let span = to.saturating_sub(from);
        let spacing = span / count.max(1);
        let mut out = Vec::new();
        let mut next = from;
        for k in 0..count {
            let (frames, failure) = match k % 4 {
                0 => (
                    4 + rng.below(7),
                    Failure::Smaller {
                        factor: rng.uniform(0.85, 0.92),
                    },
                ),
                1 => {
                    let angle = rng.uniform(0.0, std::f64::consts::TAU);
                    let length = rng.uniform(80.0, 160.0);
                    (
                        1 + rng.below(3),
                        Failure::Elsewhere {
                            shift: [length * angle.cos(), length * angle.sin()],
                        },
                    )
                }
                2 => (
                    1,
                    Failure::Scattered {
                        pixels: rng.uniform(10.0, 16.0),
                    },
                ),
                _ => (1 + rng.below(5), Failure::Lost),
            };
            let room = spacing.saturating_sub(frames + gap).max(1);
            let first = next.max(from + k * spacing) + rng.below(room);
            if first + frames > to {
                break;
            }
            out.push(FailureRun {
                first,
                frames,
                failure,
            });
            next = first + frames + gap;
        }
        out
    }

    /// The frame's `[68]` pixels as the tracker failing by `run` gives them (`rng`: the
    /// scattering's noise).
    pub fn apply(run: &FailureRun, pixels: &mut [[f32; 2]], rng: &mut Stream) {
        let n = pixels.len().max(1) as f64;
        let centre: [f64; 2] =
            std::array::from_fn(|c| pixels.iter().map(|p| f64::from(p[c])).sum::<f64>() / n);
        for p in pixels.iter_mut() {
            for (c, v) in p.iter_mut().enumerate() {
                let x = f64::from(*v);
                *v = match run.failure {
                    Failure::Smaller { factor } => centre[c] + factor * (x - centre[c]),
                    Failure::Elsewhere { shift } => x + shift[c],
                    Failure::Scattered { pixels } => x + pixels * rng.normal(),
                    Failure::Lost => x,
                } as f32;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn stream(seed: u64) -> Stream {
        Stream::new(seed, 0x7e57, 1)
    }

    #[test]
    fn a_convention_is_largest_on_the_contour_lips_and_brows_and_mirrors_its_sides() {
        let mut rms = [0.0f64; 3];
        let mut steady = 0.0;
        for seed in 0..50 {
            let c = Convention::draw(&mut stream(seed), 0.4);
            assert_eq!(c.offsets.len(), LANDMARKS);
            rms[0] += c.rms(0..17) / 50.0;
            rms[1] += c.rms(17..27) / 50.0;
            rms[2] += c.rms(48..68) / 50.0;
            steady += c.rms(27..48) / 50.0;
            // Mirrored: the contour's ends move alike in y and oppositely in x, but for the
            // landmarks' own tenth.
            let (a, b) = (c.offsets[0], c.offsets[16]);
            assert!((a[1] - b[1]).abs() < 0.2 * 0.4 * 3.0, "{a:?} {b:?}");
        }
        // Several millimetres (the amplitude is 4 mm) on the contour, lips and brows; little on
        // the nose and eyes.
        assert!((0.25..0.6).contains(&rms[0]), "{rms:?}");
        assert!(rms[1] > 0.15 && rms[2] > 0.15, "{rms:?}");
        assert!(steady < 0.5 * rms[1].min(rms[2]), "{steady} {rms:?}");
        // Smooth: neighbours along the contour differ less than its ends.
        let c = Convention::draw(&mut stream(3), 0.4);
        let d = |a: usize, b: usize| {
            (0..2)
                .map(|k| (c.offsets[a][k] - c.offsets[b][k]).powi(2))
                .sum::<f64>()
                .sqrt()
        };
        let near: f64 = (9..16).map(|l| d(l, l + 1)).sum::<f64>() / 7.0;
        assert!(near < 0.5 * c.rms(0..17), "{near}");
        assert_eq!(
            Convention::draw(&mut stream(3), 0.4),
            Convention::draw(&mut stream(3), 0.4)
        );
    }

    #[test]
    fn failures_are_apart_within_their_frames_and_move_the_points_as_they_say() {
        let f = Failures::draw(&mut stream(1), 6, 30, 300, 30.0);
        assert_eq!(f.len(), 6);
        for w in f.windows(2) {
            assert!(w[1].first >= w[0].first + w[0].frames + 8, "{w:?}");
        }
        assert!(f.iter().all(|x| x.first >= 30 && x.first + x.frames <= 300));
        let mut pixels = vec![[100.0f32, 50.0], [120.0, 50.0], [110.0, 80.0]];
        let smaller = FailureRun {
            first: 0,
            frames: 1,
            failure: Failure::Smaller { factor: 0.5 },
        };
        Failures::apply(&smaller, &mut pixels, &mut stream(0));
        assert_eq!(pixels, vec![[105.0, 55.0], [115.0, 55.0], [110.0, 70.0]]);
        assert!(smaller.covers(0) && !smaller.covers(1));
        // Too few frames: fewer failures.
        assert!(Failures::draw(&mut stream(1), 6, 0, 20, 30.0).len() < 6);
    }
}
