//! Property tests over seeded random landmark sequences (the seed is printed).

use rand_core::{RngCore, SeedableRng};
use rand_pcg::Pcg64;
use sinew_core::srvf::{FRAMES, decode, inner};

use super::*;

const SEED: u64 = 21;
const CASES: usize = 40;

fn uniform(rng: &mut Pcg64) -> f32 {
    (rng.next_u64() >> 40) as f32 / (1u64 << 24) as f32
}

/// A random landmark sequence: 68 random landmarks, moved by 1 to 3 random directions with
/// eased, random-onset weights and small per-frame noise, over 8 to 60 frames.
fn sequence(rng: &mut Pcg64) -> Vec<Vec<f32>> {
    let k = 68;
    let frames = 8 + (rng.next_u64() % 53) as usize;
    let base: Vec<f32> = (0..3 * k).map(|_| uniform(rng) * 10.0 - 5.0).collect();
    let directions: Vec<Vec<f32>> = (0..1 + rng.next_u64() % 3)
        .map(|_| (0..3 * k).map(|_| uniform(rng) - 0.5).collect())
        .collect();
    let onsets: Vec<f32> = directions.iter().map(|_| uniform(rng) * 0.4).collect();
    (0..frames)
        .map(|f| {
            let t = f as f32 / (frames - 1) as f32;
            let mut frame = base.clone();
            for (d, onset) in directions.iter().zip(&onsets) {
                let x = ((t - onset) / (1.0 - onset)).clamp(0.0, 1.0);
                let w = x * x * (3.0 - 2.0 * x);
                for (p, v) in frame.iter_mut().zip(d) {
                    *p += w * v + (uniform(rng) - 0.5) * 1e-3;
                }
            }
            frame
        })
        .collect()
}

fn encoded(rng: &mut Pcg64) -> (Vec<Vec<f32>>, Encoded) {
    let s = sequence(rng);
    let views: Vec<&[f32]> = s.iter().map(Vec::as_slice).collect();
    let e = encode(&views).unwrap();
    (s, e)
}

fn max_diff(a: &[f32], b: &[f32]) -> f32 {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f32::max)
}

#[test]
fn encoded_motions_are_unit() {
    eprintln!("seed {SEED}");
    let mut rng = Pcg64::seed_from_u64(SEED);
    for _ in 0..CASES {
        let (s, e) = encoded(&mut rng);
        assert_eq!(e.q.len(), FRAMES * s[0].len());
        assert!((inner(&e.q, &e.q).unwrap() - 1.0).abs() < 1e-5);
        assert!(e.length > 0.0);
    }
}

#[test]
fn decoding_an_encoding_gives_the_normalised_curve() {
    eprintln!("seed {SEED}");
    let mut rng = Pcg64::seed_from_u64(SEED + 1);
    for case in 0..CASES {
        let (s, e) = encoded(&mut rng);
        let views: Vec<&[f32]> = s.iter().map(Vec::as_slice).collect();
        let (curve, _) = normalised_curve(&views).unwrap();
        let dims = s[0].len();
        // Decoded on the normalised first frame (size 1), with the curve's length.
        let neutral: Vec<f32> = curve[0].iter().map(|&x| x as f32).collect();
        let mut out = vec![0.0f32; (FRAMES + 1) * dims];
        decode(&e.q, &neutral, e.length, &mut out).unwrap();
        let expected: Vec<f32> = curve.iter().flatten().map(|&x| x as f32).collect();
        let err = max_diff(&out, &expected);
        assert!(err < 2e-5, "case {case}: decoded curve differs by {err}");
        // The last decoded frame is the last input frame, normalised.
        let last = normalise_frame(&s[s.len() - 1], 0).unwrap();
        let last: Vec<f32> = last.iter().map(|&x| x as f32).collect();
        assert!(max_diff(&out[FRAMES * dims..], &last) < 2e-5, "case {case}");
    }
}

#[test]
fn exp_inverts_log() {
    eprintln!("seed {SEED}");
    let mut rng = Pcg64::seed_from_u64(SEED + 2);
    for case in 0..CASES {
        let (_, p) = encoded(&mut rng);
        let (_, q) = encoded(&mut rng);
        if p.q.len() != q.q.len() {
            continue;
        }
        for target in [&q.q, &p.q] {
            let s = log_map(&p.q, target).unwrap();
            // Tangent at p, as long as the distance.
            assert!(inner(&s, &p.q).unwrap().abs() < 1e-5, "case {case}");
            let d = distance(target, &p.q).unwrap();
            assert!((norm(&s).unwrap() - d).abs() < 1e-5, "case {case}");
            let back = exp(&p.q, &s).unwrap();
            let err = max_diff(&back, target);
            assert!(err < 1e-5, "case {case}: exp(log(q)) differs by {err}");
        }
    }
}

#[test]
fn near_points_keep_their_distance() {
    // acos of a rounded cosine would lose a 1e-4 rad distance entirely in f32.
    let mut rng = Pcg64::seed_from_u64(SEED + 3);
    let (_, p) = encoded(&mut rng);
    let (_, q) = encoded(&mut rng);
    let mut s = log_map(&p.q, &q.q).unwrap();
    let n = norm(&s).unwrap();
    s.iter_mut().for_each(|x| *x *= 1e-4 / n);
    let near = exp(&p.q, &s).unwrap();
    let d = distance(&near, &p.q).unwrap();
    assert!((d - 1e-4).abs() < 2e-6, "distance {d}");
    assert!(distance(&p.q, &p.q).unwrap() < 1e-5);
}

#[test]
fn interpolation_follows_the_geodesic_on_the_sphere() {
    eprintln!("seed {SEED}");
    let mut rng = Pcg64::seed_from_u64(SEED + 4);
    let mut checked = 0;
    while checked < CASES / 4 {
        let (_, a) = encoded(&mut rng);
        let (_, b) = encoded(&mut rng);
        if a.q.len() != b.q.len() {
            continue;
        }
        checked += 1;
        let theta = distance(&a.q, &b.q).unwrap();
        assert!(theta > 0.01, "distinct random motions");
        for k in 0..=8 {
            let tau = k as f32 / 8.0;
            let m = interpolate(&a.q, &b.q, tau).unwrap();
            assert!(
                (norm(&m).unwrap() - 1.0).abs() < 1e-5,
                "off the sphere at {tau}"
            );
            assert!((distance(&m, &a.q).unwrap() - tau * theta).abs() < 1e-4);
            assert!((distance(&m, &b.q).unwrap() - (1.0 - tau) * theta).abs() < 1e-4);
        }
        assert!(max_diff(&interpolate(&a.q, &b.q, 1.0).unwrap(), &b.q) < 1e-5);
        assert_eq!(interpolate(&a.q, &b.q, 0.0).unwrap(), a.q);
    }
}

#[test]
fn bad_sequences_are_refused() {
    let a = vec![0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0];
    assert_eq!(encode(&[&a]), Err(SrvfError::TooFewFrames(1)));
    assert_eq!(encode(&[&a, &a, &a]), Err(SrvfError::Still));
    assert_eq!(encode(&[&a, &a[..3]]), Err(SrvfError::FrameShape(1)));
    assert_eq!(
        encode(&[&a, &[1.0, 1.0, 1.0, 1.0, 1.0, 1.0]]),
        Err(SrvfError::DegenerateFrame(1))
    );
    let (_, q) = encoded(&mut Pcg64::seed_from_u64(SEED));
    assert_eq!(distance(&q.q, &q.q[..q.q.len() - 1]), Err(SrvfError::Shape));
}
