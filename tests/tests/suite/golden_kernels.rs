//! Golden frame hashes of every core kernel on seeded weights and inputs. The inputs come from
//! `sinew_tests::Rng` (PCG32), never from a framework's random numbers, so the hashes pin the
//! core's arithmetic alone: a change of summation order, an FMA, or a platform math call shows
//! up here (and, with the firmware simulator, on every target).

use std::fmt::Write;

use sinew_core::hash::frame_hash;
use sinew_core::jaw::LearnedJaws;
use sinew_core::linalg::Vec3;
use sinew_core::nn::{Activation, Dense, Mlp};
use sinew_core::skinning::{BoneTransform, Pose, Triangles, skin, vertex_normals};
use sinew_core::sparse::Csr;
use sinew_core::spiral::{SpiralConv, Spirals};
use sinew_core::{F32s, U32s, rotation};
use sinew_tests::{Rng, check};

fn le_f32(v: &[f32]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}

fn le_u32(v: &[u32]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}

/// Evaluates an MLP with the given widths and activations on `rows` seeded inputs.
fn mlp_output(seed: u64, widths: &[usize], acts: &[Activation], rows: usize) -> Vec<f32> {
    let mut rng = Rng::new(seed);
    let storage: Vec<(Vec<u8>, Vec<u8>)> = widths
        .windows(2)
        .map(|w| {
            let bound = (6.0 / w[0] as f32).sqrt() / 30.0;
            (
                le_f32(&rng.vec(w[0] * w[1], -bound * 30.0, bound * 30.0)),
                le_f32(&rng.vec(w[1], -0.5, 0.5)),
            )
        })
        .collect();
    let layers: Vec<Dense<'_>> = storage
        .iter()
        .zip(widths.windows(2))
        .zip(acts)
        .map(|(((w, b), dims), &act)| {
            Dense::new(
                F32s::new(w).unwrap(),
                F32s::new(b).unwrap(),
                dims[0],
                dims[1],
                act,
            )
            .unwrap()
        })
        .collect();
    let mlp = Mlp::new(&layers).unwrap();
    let input = rng.vec(rows * widths[0], -1.0, 1.0);
    let mut out = vec![0.0; rows * mlp.outputs()];
    let mut scratch = vec![0.0; mlp.scratch_len()];
    mlp.eval_batch(&input, &mut out, &mut scratch).unwrap();
    out
}

fn spiral_output() -> Vec<f32> {
    let mut rng = Rng::new(3);
    let (sources, vertices, len, fin, fout) = (50usize, 30usize, 9usize, 8usize, 4usize);
    let idx: Vec<u32> = (0..vertices * len)
        .map(|_| (rng.uniform(0.0, sources as f32) as u32).min(sources as u32 - 1))
        .collect();
    let (idx, w, b) = (
        le_u32(&idx),
        le_f32(&rng.vec(fout * len * fin, -0.3, 0.3)),
        le_f32(&rng.vec(fout, -0.1, 0.1)),
    );
    let spirals = Spirals::new(U32s::new(&idx).unwrap(), vertices, len, sources).unwrap();
    let conv = SpiralConv::new(
        spirals,
        F32s::new(&w).unwrap(),
        F32s::new(&b).unwrap(),
        fin,
        fout,
        Activation::Elu { alpha: 1.0 },
    )
    .unwrap();
    let x = rng.vec(sources * fin, -1.0, 1.0);
    let mut out = vec![0.0; vertices * fout];
    conv.forward(&x, &mut out).unwrap();
    // The blocked kernel the S2D decoder uses must give the same bits, so this hash pins both.
    let mut blocked = vec![0.0; vertices * fout];
    let mut scratch = vec![0.0; conv.scratch_len()];
    conv.forward_blocked(&x, &mut blocked, &mut scratch)
        .unwrap();
    let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(&blocked), bits(&out));
    out
}

fn csr_output() -> Vec<f32> {
    // 4×5 matrix with 3 entries per row, barycentric-like weights, times 5×3 features.
    let mut rng = Rng::new(4);
    let row_ptr = le_u32(&[0, 3, 6, 9, 12]);
    let cols = le_u32(&[0, 1, 2, 1, 2, 3, 2, 3, 4, 0, 3, 4]);
    let vals = le_f32(&rng.vec(12, 0.0, 1.0));
    let csr = Csr::new(
        4,
        5,
        U32s::new(&row_ptr).unwrap(),
        U32s::new(&cols).unwrap(),
        F32s::new(&vals).unwrap(),
    )
    .unwrap();
    let x = rng.vec(15, -1.0, 1.0);
    let mut out = vec![0.0; 12];
    csr.mul_dense(&x, 3, &mut out).unwrap();
    out
}

fn skinning_output() -> (Vec<f32>, Vec<f32>) {
    let mut rng = Rng::new(5);
    let n = 64;
    let rest = rng.vec(n * 3, -10.0, 10.0);
    let k = rng.vec(n, 0.0, 1.0);
    let shapes = 4;
    let correctives = le_f32(&rng.vec(n * shapes * 3, -0.5, 0.5));
    let weights = rng.vec(shapes, 0.0, 1.0);
    let jaw6: [f32; 9] = [1.0, 0.1, -0.05, -0.08, 0.97, 0.2, 0.3, -0.4, 0.1];
    let head6: [f32; 9] = [0.98, -0.1, 0.05, 0.12, 1.0, -0.02, 1.5, 2.0, -0.5];
    let pose = Pose {
        jaw: BoneTransform::from_9d(&jaw6, Vec3::new(0.0, -2.0, -5.0)),
        head: rotation::rigid_from_9d(&head6),
    };
    let mut out = vec![0.0; n * 3];
    skin(
        &rest,
        &k,
        F32s::new(&correctives).unwrap(),
        &weights,
        &pose,
        &mut out,
    )
    .unwrap();
    // Normals of a 4×4 grid of quads (two triangles each) lifted by the skinned heights.
    let side = 5u32;
    let tris: Vec<u32> = (0..side - 1)
        .flat_map(|r| (0..side - 1).map(move |c| (r, c)))
        .flat_map(|(r, c)| {
            let v = r * side + c;
            [v, v + 1, v + side, v + 1, v + side + 1, v + side]
        })
        .collect();
    let tris = le_u32(&tris);
    let positions: Vec<f32> = (0..side * side)
        .flat_map(|i| [(i % side) as f32, (i / side) as f32, out[i as usize] * 0.1])
        .collect();
    let triangles = Triangles::new(U32s::new(&tris).unwrap(), (side * side) as usize).unwrap();
    let mut normals = vec![0.0; positions.len()];
    vertex_normals(&triangles, &positions, &mut normals).unwrap();
    (out, normals)
}

/// The jaw of a pose given by coefficients alone (`sinew_core::jaw`) over four learned jaws (an
/// opening, a smaller one, a sideways turn, a slight closing), for coefficients within the
/// shapes' range, past it, far outside [0, 1], and one shape alone: 36 values.
fn jaw_blend_output() -> Vec<f32> {
    let jaws: [[f32; 9]; 4] = [
        [1.0, 0.0, 0.0, 0.0, 0.94, 0.34, 0.0, -0.12, 0.05],
        [1.0, 0.0, 0.0, 0.0, 0.995, 0.1, 0.0, 0.0, 0.02],
        [0.998, 0.0, -0.06, 0.0, 1.0, 0.0, 0.03, 0.0, 0.0],
        [1.0, 0.0, 0.0, 0.0, 0.9998, -0.02, 0.0, 0.01, 0.0],
    ];
    let weights: [[f32; 4]; 4] = [
        [0.5, 0.3, 0.2, 0.0],
        [1.0, 1.0, 1.0, 1.0],
        [-0.7, 2.0, -1.5, 3.0],
        [0.0, 0.0, 1.0, 0.0],
    ];
    let bytes = le_f32(jaws.as_flattened());
    let learned = LearnedJaws::new(F32s::new(&bytes).unwrap()).unwrap();
    // One shape alone at weight 1 is its learned jaw, bit for bit.
    assert_eq!(learned.blend(&weights[3]), jaws[2]);
    weights.iter().flat_map(|w| learned.blend(w)).collect()
}

#[test]
fn kernel_hashes_are_pinned() {
    let (skinned, normals) = skinning_output();
    let cases: Vec<(&str, Vec<f32>)> = vec![
        (
            "mlp-gelu-elu",
            mlp_output(
                1,
                &[3, 32, 32, 3],
                &[
                    Activation::Gelu,
                    Activation::Elu { alpha: 1.0 },
                    Activation::Identity,
                ],
                64,
            ),
        ),
        (
            "siren-w30",
            mlp_output(
                2,
                &[3, 64, 64, 3],
                &[
                    Activation::Sine { omega0: 30.0 },
                    Activation::Sine { omega0: 30.0 },
                    Activation::Identity,
                ],
                64,
            ),
        ),
        ("spiral-conv-elu", spiral_output()),
        ("csr-mul", csr_output()),
        ("skin-eq17", skinned),
        ("vertex-normals", normals),
        (
            "rotation-6d",
            rotation::from_6d(&[0.3, -1.2, 0.5, 2.0, 0.1, -0.7])
                .cols
                .iter()
                .flat_map(|c| c.to_array())
                .collect(),
        ),
        ("jaw-blend", jaw_blend_output()),
    ];
    let mut text = String::new();
    for (name, values) in &cases {
        assert!(
            values.iter().all(|v| v.is_finite()),
            "{name}: non-finite output"
        );
        writeln!(text, "{name} {:016x} {}", frame_hash(values), values.len()).unwrap();
    }
    check("kernels.hashes", &text);
}
