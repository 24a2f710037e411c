//! What a driver's training loss measures: the error of the posed actor's vertices, not of the
//! pose's numbers. A pose error `e` (`[18 + M]`) moves the vertices by about `J e`, with `J` the
//! Jacobian of every vertex position at the rest pose (Gauss–Newton), so the mean squared
//! per-vertex error is about `eᵀ G e` with `G = JᵀJ / V`. In the network's normalised outputs
//! (`e = s_out ⊙ ê`) that is `êᵀ (S G S) ê`, the metric the training loss uses: a centimetre of
//! depth then costs what it costs on the face, however widely the depth was drawn.

use sinew_core::EvalError;
use sinew_core::aim::AimActor;
use sinew_core::driver::play;
use sinew_core::replay::AIM_POSE_LEN;

/// The identity head and jaw, `[6D, t]` twice.
const REST_18: [f32; 18] = [
    1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0,
];

/// The step of the central differences, in pose units (radians-like for the 6D values, the
/// actor's unit for translations, one for coefficients; everything near the rest pose is linear
/// or smooth at this scale).
const STEP: f32 = 1e-2;

/// `G = JᵀJ / V` at the rest pose, `[P, P]` row-major (P = 18 + M), in (actor unit)² per pose
/// unit², from central differences of the core's own posing.
///
/// # Errors
/// As [`sinew_core::driver::play`] (the rest pose and its neighbours are always accepted by a
/// valid actor).
pub fn gauss_newton(actor: &AimActor<'_>) -> Result<Vec<f64>, EvalError> {
    let p = AIM_POSE_LEN + actor.shape_count();
    let v = actor.vertex_count();
    let mut rest = REST_18.to_vec();
    rest.resize(p, 0.0);
    let mut plus = vec![0.0; 3 * v];
    let mut minus = vec![0.0; 3 * v];
    let mut columns = Vec::with_capacity(p);
    for i in 0..p {
        let mut pose = rest.clone();
        pose[i] = rest[i] + STEP;
        play(actor, &pose, &mut plus)?;
        pose[i] = rest[i] - STEP;
        play(actor, &pose, &mut minus)?;
        let column: Vec<f64> = plus
            .iter()
            .zip(&minus)
            .map(|(a, b)| f64::from(a - b) / (2.0 * f64::from(STEP)))
            .collect();
        columns.push(column);
    }
    let mut g = vec![0.0; p * p];
    for a in 0..p {
        for b in a..p {
            let dot: f64 = columns[a].iter().zip(&columns[b]).map(|(x, y)| x * y).sum();
            g[a * p + b] = dot / v.max(1) as f64;
            g[b * p + a] = g[a * p + b];
        }
    }
    Ok(g)
}

/// The loss metric on normalised outputs: `S G S` scaled so that its trace is P (errors of one
/// training spread in every output then cost about P, as in the plain squared error), `[P, P]`
/// row-major as f32.
pub fn normalised(g: &[f64], output_scale: &[f32]) -> Vec<f32> {
    let p = output_scale.len();
    let s: Vec<f64> = output_scale.iter().map(|&x| f64::from(x)).collect();
    let mut m: Vec<f64> = (0..p * p)
        .map(|k| s[k / p] * g.get(k).copied().unwrap_or(0.0) * s[k % p])
        .collect();
    let trace: f64 = (0..p).map(|i| m[i * p + i]).sum();
    if trace > 0.0 {
        let k = p as f64 / trace;
        m.iter_mut().for_each(|x| *x *= k);
    }
    m.into_iter().map(|x| x as f32).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_metric_of_a_translation_is_the_identity_and_the_trace_is_the_outputs() {
        let bytes = std::fs::read(
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/data/aim-ict.sinew"),
        )
        .unwrap();
        let actor = AimActor::from_bytes(&bytes).unwrap();
        let g = gauss_newton(&actor).unwrap();
        let p = 18 + actor.shape_count();
        // A head translation moves every vertex by itself: G's block is the identity.
        for a in 6..9 {
            for b in 6..9 {
                let expected = if a == b { 1.0 } else { 0.0 };
                assert!((g[a * p + b] - expected).abs() < 1e-4, "G[{a}][{b}]");
            }
        }
        // Scaling a 6D rotation's first column does not move anything.
        assert!(g[0] < 1e-6, "G[0][0] = {}", g[0]);
        // A coefficient moves the vertices by its corrective: G's diagonal is its mean square.
        let e = actor.correctives();
        let m = actor.shape_count();
        let v = actor.vertex_count();
        let mean_sq: f64 = (0..v)
            .map(|i| {
                (0..3)
                    .map(|c| f64::from(e.at(i * 3 * m + c)).powi(2))
                    .sum::<f64>()
            })
            .sum::<f64>()
            / v as f64;
        let d = g[18 * p + 18];
        assert!(
            (d - mean_sq).abs() < 1e-3 * mean_sq.max(1e-9),
            "{d} against {mean_sq}"
        );
        let scale = vec![2.0; p];
        let n = normalised(&g, &scale);
        let trace: f32 = (0..p).map(|i| n[i * p + i]).sum();
        assert!((trace - p as f32).abs() < 1e-3 * p as f32);
    }
}
