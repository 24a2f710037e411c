//! The core's S2D decoder on hand-written artefacts: a tiny network whose output is computed by
//! hand, and the validation of every section's shape and bounds.

use sinew_core::error::{Bound, NetworkLimit, SectionName};
use sinew_core::s2d::S2dDecoder;
use sinew_core::{ArtifactKind, BufferError, FormatError};
use sinew_host::SinewWriter;

/// Sections of the tiny decoder, each replaceable by a test.
#[derive(Clone)]
struct Tiny {
    cfg: Vec<u32>,
    levels: Vec<u32>,
    input: Vec<u32>,
    lmk: Vec<u32>,
    neutral: Vec<f32>,
    fc_w: Vec<f32>,
    fc_b: Vec<f32>,
    sp0: Vec<u32>,
    sp1: Vec<u32>,
    up_ptr: Vec<u32>,
    up_col: Vec<u32>,
    up_val: Vec<f32>,
    conv_w: Vec<f32>,
    conv_b: Vec<f32>,
    out_w: Vec<f32>,
    out_b: Vec<f32>,
    /// The optional `s2d.act` and `s2d.par` (absent: ELU).
    act: Option<(Vec<u32>, Vec<f32>)>,
}

/// Two levels: 2 vertices (+ dummy) and 1 vertex (+ dummy); one landmark; F = 1; one stage of
/// 1 filter; spirals of length 2 at level 0.
fn tiny() -> Tiny {
    Tiny {
        cfg: vec![3, 1, 3],
        levels: vec![2, 2, 1, 1],
        input: vec![1],
        lmk: vec![1],
        neutral: vec![1.0, 1.0, 1.0, 2.0, 2.0, 2.0],
        // FC 3 → 2: [x0 + 0.5, x1 − 1].
        fc_w: vec![1.0, 0.0, 0.0, 0.0, 1.0, 0.0],
        fc_b: vec![0.5, -1.0],
        // Level 0 spirals: v0 = (0, 1), v1 = (1, 2), dummy = (2, 2).
        sp0: vec![0, 1, 1, 2, 2, 2],
        // Level 1 spirals of length 1 (no convolution reads them; validated all the same).
        sp1: vec![0, 1],
        // U0 (3 × 2): row 0 = c0, row 1 = 0.5 c0 + 0.5 c1, row 2 (dummy) = c1.
        up_ptr: vec![0, 1, 3, 4],
        up_col: vec![0, 0, 1, 1],
        up_val: vec![1.0, 0.5, 0.5, 1.0],
        // Stage convolution at level 0, 1 → 1 over 2 positions: −2·h(s0) + 1·h(s1), ELU.
        conv_w: vec![-2.0, 1.0],
        conv_b: vec![0.0],
        // Output convolution 1 → 3 over 2 positions: [h(s0), h(s1), h(s0) + h(s1) + 10].
        out_w: vec![1.0, 0.0, 0.0, 1.0, 1.0, 1.0],
        out_b: vec![0.0, 0.0, 10.0],
        act: None,
    }
}

impl Tiny {
    fn bytes(&self) -> Vec<u8> {
        // The writer refuses non-finite weights, so those are written as 0 and patched in after.
        let mut patches = Vec::new();
        let mut w = SinewWriter::new(ArtifactKind::S2dDecoder);
        let mut f32s = |w: &mut SinewWriter, name: &str, dims: &[usize], v: &[f32]| {
            for (i, x) in v.iter().enumerate().filter(|(_, x)| !x.is_finite()) {
                patches.push((name.to_owned(), i, *x));
            }
            let finite: Vec<f32> = v
                .iter()
                .map(|x| if x.is_finite() { *x } else { 0.0 })
                .collect();
            w.f32s(name, dims, &finite).unwrap();
        };
        let n = |v: &[u32]| v.len();
        w.u32s("s2d.cfg", &[n(&self.cfg)], &self.cfg).unwrap();
        w.u32s("s2d.levels", &[n(&self.levels) / 2, 2], &self.levels)
            .unwrap();
        w.u32s("s2d.input", &[n(&self.input)], &self.input).unwrap();
        w.u32s("s2d.lmk", &[n(&self.lmk)], &self.lmk).unwrap();
        f32s(
            &mut w,
            "s2d.h0.pos",
            &[self.neutral.len() / 3, 3],
            &self.neutral,
        );
        f32s(
            &mut w,
            "s2d.fc.w",
            &[self.fc_b.len(), self.fc_w.len() / self.fc_b.len()],
            &self.fc_w,
        );
        f32s(&mut w, "s2d.fc.b", &[self.fc_b.len()], &self.fc_b);
        w.u32s("s2d.h0.spiral", &[n(&self.sp0) / 2, 2], &self.sp0)
            .unwrap();
        w.u32s("s2d.h1.spiral", &[n(&self.sp1), 1], &self.sp1)
            .unwrap();
        w.u32s("s2d.u0.ptr", &[n(&self.up_ptr)], &self.up_ptr)
            .unwrap();
        w.u32s("s2d.u0.col", &[n(&self.up_col)], &self.up_col)
            .unwrap();
        f32s(&mut w, "s2d.u0.val", &[self.up_val.len()], &self.up_val);
        f32s(
            &mut w,
            "s2d.conv.0.w",
            &[self.conv_b.len(), self.conv_w.len() / self.conv_b.len()],
            &self.conv_w,
        );
        f32s(&mut w, "s2d.conv.0.b", &[self.conv_b.len()], &self.conv_b);
        f32s(
            &mut w,
            "s2d.out.w",
            &[self.out_b.len(), self.out_w.len() / self.out_b.len()],
            &self.out_w,
        );
        f32s(&mut w, "s2d.out.b", &[self.out_b.len()], &self.out_b);
        if let Some((code, param)) = &self.act {
            w.u32s("s2d.act", &[code.len()], code).unwrap();
            f32s(&mut w, "s2d.par", &[param.len()], param);
        }
        let mut bytes = w.to_bytes().unwrap();
        for (name, i, x) in patches {
            patch_f32(&mut bytes, &name, i, x);
        }
        bytes
    }

    fn load(&self) -> Result<(), FormatError> {
        S2dDecoder::from_bytes(&self.bytes()).map(|_| ())
    }
}

#[test]
fn tiny_decoder_hand_computed() {
    let bytes = tiny().bytes();
    let dec = S2dDecoder::from_bytes(&bytes).unwrap();
    assert_eq!(
        (dec.input_len(), dec.vertex_count(), dec.fc_features()),
        (3, 2, 1)
    );
    // FC on x = [1, 2, 3]: [1.5, 1.0] (the coarse dummy row keeps its value).
    // U0: [1.5, 0.5·1.5 + 0.5·1.0 = 1.25, 1.0].
    // Stage: v0 = −3 + 1.25 = −1.75, v1 = −2.5 + 1 = −1.5, dummy = −2 + 1 = −1 → ELU → zeroed.
    // ELU(z) = 1 · expm1(z) for z ≤ 0, with libm's expm1f as the core evaluates it.
    let elu = sinew_core::nn::Activation::Elu { alpha: 1.0 };
    let (e1, e2) = (elu.apply(-1.75), elu.apply(-1.5));
    assert!((e1 - (-1.75f32).exp_m1()).abs() < 1e-6);
    // Output: v0 over (0, 1) = [e1, e2, (e1 + e2) + 10]; v1 over (1, dummy) = [e2, 0, e2 + 10].
    let expected = [e1, e2, (e1 + e2) + 10.0, e2, 0.0, e2 + 10.0];
    // Scratch: two buffers of the largest map, 3 rows × 3 outputs, then one packed weight block
    // of the widest convolution (2 positions × 1 feature × a block of 4 channels).
    assert_eq!(dec.scratch_len(), 18 + 8);
    let mut scratch = vec![f32::NAN; dec.scratch_len()];
    let mut out = [f32::NAN; 6];
    dec.displacements(&[1.0, 2.0, 3.0], &mut scratch, &mut out)
        .unwrap();
    assert_eq!(out, expected);
    dec.decode(&[1.0, 2.0, 3.0], &mut scratch, &mut out)
        .unwrap();
    let neutral = [1.0, 1.0, 1.0, 2.0, 2.0, 2.0];
    for i in 0..6 {
        assert_eq!(out[i], expected[i] + neutral[i]);
    }
    dec.decode_onto(&[0.0; 6], &[1.0, 2.0, 3.0], &mut scratch, &mut out)
        .unwrap();
    assert_eq!(out, expected);

    assert_eq!(
        dec.decode(&[1.0, 2.0], &mut scratch, &mut out),
        Err(BufferError::Input.into())
    );
    assert_eq!(
        dec.decode(&[1.0, 2.0, 3.0], &mut scratch, &mut out[..5]),
        Err(BufferError::Output.into())
    );
    assert_eq!(
        dec.decode(&[1.0, 2.0, 3.0], &mut scratch[..25], &mut out),
        Err(BufferError::Scratch.into())
    );
    assert_eq!(
        dec.decode_onto(&[0.0; 3], &[1.0, 2.0, 3.0], &mut scratch, &mut out),
        Err(BufferError::Input.into())
    );
}

/// The same decoder with the stages' activation named in the artefact: Leaky ReLU with slope
/// 0.25 (code 5) turns the stage's −1.75 and −1.5 into −0.4375 and −0.375, exactly; code 0
/// leaves them as they are.
#[test]
fn tiny_decoder_with_a_named_stage_activation() {
    for (code, param, e1, e2) in [(5, 0.25, -0.4375, -0.375), (0, 0.0, -1.75, -1.5)] {
        let mut t = tiny();
        t.act = Some((vec![code], vec![param]));
        let bytes = t.bytes();
        let dec = S2dDecoder::from_bytes(&bytes).unwrap();
        let mut scratch = vec![f32::NAN; dec.scratch_len()];
        let mut out = [f32::NAN; 6];
        dec.displacements(&[1.0, 2.0, 3.0], &mut scratch, &mut out)
            .unwrap();
        assert_eq!(out, [e1, e2, (e1 + e2) + 10.0, e2, 0.0, e2 + 10.0]);
    }
}

/// `S2dDecoder::input` normalises as the artefact's `s2d.input` says.
#[test]
fn input_follows_the_artefacts_normalisation() {
    use sinew_core::s2d::{
        INPUT_FROBENIUS, INPUT_NEUTRAL_SCALE, landmark_input, landmark_input_neutral_scale,
    };
    let (neutral, expressive) = ([0.0, 0.0, 0.0], [0.5, 1.0, 2.0]);
    let mut t = tiny();
    // One landmark is a degenerate set; two points make the normalisations differ.
    t.cfg[0] = 6;
    t.lmk = vec![0, 1];
    t.fc_w = vec![0.0; 12];
    let (n, e) = (
        [neutral, [2.0, 0.0, 0.0]].concat(),
        [expressive, [2.0, 4.0, 0.0]].concat(),
    );
    for (code, f) in [
        (
            INPUT_FROBENIUS,
            landmark_input as fn(&[f32], &[f32], &mut [f32]) -> _,
        ),
        (INPUT_NEUTRAL_SCALE, landmark_input_neutral_scale),
    ] {
        t.input = vec![code];
        let bytes = t.bytes();
        let dec = S2dDecoder::from_bytes(&bytes).unwrap();
        assert_eq!(dec.input_normalisation(), code);
        let (mut got, mut want) = ([f32::NAN; 6], [f32::NAN; 6]);
        dec.input(&n, &e, &mut got).unwrap();
        f(&n, &e, &mut want).unwrap();
        assert_eq!(got, want);
    }
    let (mut a, mut b) = ([0.0; 6], [0.0; 6]);
    landmark_input(&n, &e, &mut a).unwrap();
    landmark_input_neutral_scale(&n, &e, &mut b).unwrap();
    assert_ne!(a, b);
}

/// A change to the tiny decoder's sections.
type Edit = Box<dyn Fn(&mut Tiny)>;

#[test]
fn every_shape_and_bound_is_validated() {
    assert_eq!(tiny().load(), Ok(()));
    let cases: Vec<(&str, Edit, FormatError)> = vec![
        (
            "four outputs",
            Box::new(|t| t.cfg[2] = 4),
            FormatError::incompatible_shapes("s2d.cfg"),
        ),
        (
            "inputs not whole landmarks",
            Box::new(|t| t.cfg[0] = 4),
            FormatError::incompatible_shapes("s2d.cfg"),
        ),
        (
            "too many levels",
            Box::new(|t| t.levels = [2, 2].repeat(9)),
            FormatError::limit_exceeded("s2d.levels", 9, 8),
        ),
        (
            "a third level without its sections",
            Box::new(|t| t.levels = vec![2, 2, 1, 1, 1, 1]),
            FormatError::MissingSection {
                section: SectionName::new("s2d.h2.spiral"),
            },
        ),
        (
            "empty level",
            Box::new(|t| t.levels[2] = 0),
            FormatError::incompatible_shapes("s2d.levels"),
        ),
        (
            "spiral length differs from the table",
            Box::new(|t| t.levels[1] = 3),
            FormatError::incompatible_shapes("s2d.h0.spiral"),
        ),
        (
            "coarse spiral past the dummy",
            Box::new(|t| t.sp1[0] = 2),
            FormatError::index_out_of_range("s2d.h1.spiral", 0),
        ),
        (
            "unknown input normalisation",
            Box::new(|t| t.input[0] = 3),
            FormatError::unknown_code("s2d.input", 0, 3),
        ),
        (
            "unknown stage activation",
            Box::new(|t| t.act = Some((vec![9], vec![0.0]))),
            FormatError::unknown_code("s2d.act", 0, 9),
        ),
        (
            "non-finite stage activation parameter",
            Box::new(|t| t.act = Some((vec![5], vec![f32::NAN]))),
            FormatError::NonFiniteValue {
                section: SectionName::new("s2d.par"),
                index: 0,
            },
        ),
        (
            "stage activation without its parameter",
            Box::new(|t| t.act = Some((vec![5], vec![]))),
            FormatError::incompatible_shapes("s2d.par"),
        ),
        (
            "landmark outside the mesh",
            Box::new(|t| t.lmk[0] = 2),
            FormatError::index_out_of_range("s2d.lmk", 0),
        ),
        (
            "non-finite neutral",
            Box::new(|t| t.neutral[4] = f32::NAN),
            FormatError::NonFiniteValue {
                section: SectionName::new("s2d.h0.pos"),
                index: 4,
            },
        ),
        (
            "non-finite FC weight",
            Box::new(|t| t.fc_w[1] = f32::INFINITY),
            FormatError::NonFiniteValue {
                section: SectionName::new("s2d.fc.w"),
                index: 1,
            },
        ),
        (
            "FC of the wrong width",
            Box::new(|t| {
                t.fc_w.extend([0.0; 3]);
                t.fc_b.push(0.0);
            }),
            FormatError::incompatible_shapes("s2d.fc.w"),
        ),
        (
            "spiral past the dummy",
            Box::new(|t| t.sp0[1] = 3),
            FormatError::index_out_of_range("s2d.h0.spiral", 1),
        ),
        (
            "spirals of the wrong count",
            Box::new(|t| t.sp0.truncate(4)),
            FormatError::incompatible_shapes("s2d.h0.spiral"),
        ),
        (
            "CSR column past the coarse dummy",
            Box::new(|t| t.up_col[3] = 2),
            FormatError::index_out_of_range("s2d.u0.col", 3),
        ),
        (
            "CSR row pointers decrease",
            Box::new(|t| t.up_ptr[1] = 4),
            FormatError::index_out_of_range("s2d.u0.ptr", 2),
        ),
        (
            "CSR row pointers end early",
            Box::new(|t| t.up_ptr[3] = 3),
            FormatError::index_out_of_range("s2d.u0.ptr", 3),
        ),
        (
            "CSR with a row too few",
            Box::new(|t| t.up_ptr.truncate(3)),
            FormatError::incompatible_shapes("s2d.u0.ptr"),
        ),
        (
            "CSR values and columns differ",
            Box::new(|t| t.up_val.push(1.0)),
            FormatError::incompatible_shapes("s2d.u0.val"),
        ),
        (
            "non-finite CSR value",
            Box::new(|t| t.up_val[0] = f32::NAN),
            FormatError::NonFiniteValue {
                section: SectionName::new("s2d.u0.val"),
                index: 0,
            },
        ),
        (
            "stage convolution reads the wrong width",
            Box::new(|t| {
                t.conv_w = vec![1.0; 4];
            }),
            FormatError::incompatible_shapes("s2d.conv.0.w"),
        ),
        (
            "output convolution does not chain",
            Box::new(|t| {
                t.conv_w = vec![1.0; 4];
                t.conv_b = vec![0.0; 2];
            }),
            FormatError::incompatible_shapes("s2d.out.w"),
        ),
        (
            "non-finite output bias",
            Box::new(|t| t.out_b[2] = f32::NEG_INFINITY),
            FormatError::NonFiniteValue {
                section: SectionName::new("s2d.out.b"),
                index: 2,
            },
        ),
        (
            "neutral beyond the coordinate limit",
            Box::new(|t| t.neutral[4] = 2e5),
            FormatError::ValueOutOfRange {
                section: SectionName::new("s2d.h0.pos"),
                index: 4,
                bound: Bound::Coordinate,
            },
        ),
        (
            "up-sampling weight beyond the factor limit",
            Box::new(|t| t.up_val[0] = -2e3),
            FormatError::ValueOutOfRange {
                section: SectionName::new("s2d.u0.val"),
                index: 0,
                bound: Bound::Factor,
            },
        ),
        (
            "stage activation parameter beyond the factor limit",
            Box::new(|t| t.act = Some((vec![5], vec![1e4]))),
            FormatError::ValueOutOfRange {
                section: SectionName::new("s2d.par"),
                index: 0,
                bound: Bound::Factor,
            },
        ),
        (
            // Finite, but inputs within ±1e3 times 1e30 would overflow f32.
            "FC weight that can overflow",
            Box::new(|t| t.fc_w[4] = 1e30),
            FormatError::Unbounded {
                section: SectionName::new("s2d.fc.w"),
                row: 1,
                limit: NetworkLimit::Values,
            },
        ),
        (
            // FC outputs up to 1,001 times 1e19: beyond 1e20.
            "stage convolution weight that can overflow",
            Box::new(|t| t.conv_w[0] = 1e19),
            FormatError::Unbounded {
                section: SectionName::new("s2d.conv.0.w"),
                row: 0,
                limit: NetworkLimit::Values,
            },
        ),
    ];
    for (what, edit, expected) in cases {
        let mut t = tiny();
        edit(&mut t);
        assert_eq!(t.load(), Err(expected), "{what}");
    }
}

#[test]
fn missing_sections_and_wrong_kind() {
    let bytes = tiny().bytes();
    let file = sinew_core::SinewFile::from_bytes(&bytes).unwrap();
    for skip in 0..file.section_count() {
        let mut w = SinewWriter::new(ArtifactKind::S2dDecoder);
        for (i, s) in file.sections().enumerate() {
            if i == skip {
                continue;
            }
            let dims: Vec<usize> = s.dims().iter().map(|&d| d as usize).collect();
            if let Some(v) = s.f32s() {
                w.f32s(s.name(), &dims, &v.iter().collect::<Vec<_>>())
                    .unwrap();
            } else {
                let v = s.u32s().expect("every tiny section is f32 or u32");
                w.u32s(s.name(), &dims, &v.iter().collect::<Vec<_>>())
                    .unwrap();
            }
        }
        let name = file.section_at(skip).unwrap().name().to_owned();
        assert_eq!(
            S2dDecoder::from_bytes(&w.to_bytes().unwrap()).map(|_| ()),
            Err(FormatError::MissingSection {
                section: SectionName::new(&name)
            }),
            "without {name}"
        );
    }
    // The typed loader refuses another artefact kind; `from_file` reads any container.
    let mut other = bytes.clone();
    other[16] = ArtifactKind::Network.code() as u8;
    let count = sinew_core::SinewFile::from_bytes(&bytes)
        .unwrap()
        .section_count();
    fix_header_crc(&mut other, count);
    let crc_fixed = other;
    assert_eq!(
        S2dDecoder::from_bytes(&crc_fixed).map(|_| ()),
        Err(FormatError::WrongKind)
    );
    let file = sinew_core::SinewFile::from_bytes(&crc_fixed).unwrap();
    assert!(S2dDecoder::from_file(file).is_ok());
}

/// Overwrites value `i` of the f32 section `name` and recomputes the section and header CRCs,
/// as a writer that did not check finiteness would have.
fn patch_f32(bytes: &mut [u8], name: &str, i: usize, x: f32) {
    use sinew_core::format::{CRC32, ENTRY_CRC, HEADER_LEN, SECTION_ENTRY_LEN};
    let (index, offset, len, count) = {
        let file = sinew_core::SinewFile::from_bytes(bytes).unwrap();
        let index = file.sections().position(|s| s.name() == name).unwrap();
        let s = file.section_at(index).unwrap();
        let offset = s.data().as_ptr() as usize - bytes.as_ptr() as usize;
        (index, offset, s.data().len(), file.section_count())
    };
    bytes[offset + 4 * i..offset + 4 * i + 4].copy_from_slice(&x.to_le_bytes());
    let crc = CRC32.checksum(&bytes[offset..offset + len]);
    let entry = HEADER_LEN + index * SECTION_ENTRY_LEN;
    bytes[ENTRY_CRC.at(entry)].copy_from_slice(&crc.to_le_bytes());
    fix_header_crc(bytes, count);
}

/// Recomputes the header CRC (over header bytes 0..28 and the section table).
fn fix_header_crc(bytes: &mut [u8], sections: usize) {
    use sinew_core::format::{CRC32, HEADER_CRC, HEADER_LEN, SECTION_ENTRY_LEN};
    let table_end = HEADER_LEN + sections * SECTION_ENTRY_LEN;
    let mut digest = CRC32.digest();
    digest.update(&bytes[..HEADER_CRC.offset]);
    digest.update(&bytes[HEADER_LEN..table_end]);
    let crc = digest.finalize();
    bytes[HEADER_CRC.range()].copy_from_slice(&crc.to_le_bytes());
}

/// A plain S2D decode read straight from the artefact's sections, in the documented order (the
/// definition the core's blocked kernels must match bit for bit): every dot product from `0.0`
/// in index order with separate multiply and add, the bias after; CSR rows in stored order; the
/// dummy row zeroed after each stage.
fn reference_displacements(bytes: &[u8], input: &[f32]) -> Vec<f32> {
    let file = sinew_core::SinewFile::from_bytes(bytes).unwrap();
    let f32s =
        |name: &str| -> Vec<f32> { file.section(name).unwrap().f32s().unwrap().iter().collect() };
    let u32s = |name: &str| -> Vec<usize> {
        let s = file.section(name).unwrap();
        s.u32s().unwrap().iter().map(|v| v as usize).collect()
    };
    let cfg = u32s("s2d.cfg");
    let (fc_features, outputs) = (cfg[1], cfg[2]);
    let levels = u32s("s2d.levels");
    let n_levels = levels.len() / 2;
    let rows_at = |k: usize| levels[2 * k] + 1;
    let len_at = |k: usize| levels[2 * k + 1];
    let dense = |w: &[f32], b: &[f32], x: &[f32]| -> Vec<f32> {
        let n = x.len();
        b.iter()
            .enumerate()
            .map(|(o, b)| {
                let mut acc = 0.0f32;
                for (i, xi) in x.iter().enumerate() {
                    acc += w[o * n + i] * xi;
                }
                acc + b
            })
            .collect()
    };
    // The stages' activation: ELU (α = 1) unless the artefact names another.
    let (act, param) = match file.section("s2d.act") {
        Some(_) => (u32s("s2d.act")[0], f32s("s2d.par")[0]),
        None => (3, 1.0),
    };
    let activate = |z: f32| match act {
        0 => z,
        3 if z <= 0.0 => libm_expm1(z),
        3 => z,
        5 if z < 0.0 => param * z,
        5 => z,
        _ => panic!("activation code {act} in a test decoder"),
    };
    let conv = |k: usize, w: &[f32], b: &[f32], x: &[f32], in_f: usize, stage: bool| -> Vec<f32> {
        let (rows, len) = (rows_at(k), len_at(k));
        let spirals = u32s(&format!("s2d.h{k}.spiral"));
        let mut out = Vec::new();
        for v in 0..rows {
            let g: Vec<f32> = spirals[v * len..(v + 1) * len]
                .iter()
                .flat_map(|&s| x[s * in_f..(s + 1) * in_f].iter().copied())
                .collect();
            for z in dense(w, b, &g) {
                out.push(if stage { activate(z) } else { z });
            }
        }
        out
    };
    let mut h = dense(&f32s("s2d.fc.w"), &f32s("s2d.fc.b"), input);
    let mut width = fc_features;
    for k in (0..n_levels - 1).rev() {
        let (ptr, col, val) = (
            u32s(&format!("s2d.u{k}.ptr")),
            u32s(&format!("s2d.u{k}.col")),
            f32s(&format!("s2d.u{k}.val")),
        );
        let mut fine = vec![0.0f32; rows_at(k) * width];
        for r in 0..rows_at(k) {
            for e in ptr[r]..ptr[r + 1] {
                for f in 0..width {
                    fine[r * width + f] += val[e] * h[col[e] * width + f];
                }
            }
        }
        let (w, b) = (
            f32s(&format!("s2d.conv.{k}.w")),
            f32s(&format!("s2d.conv.{k}.b")),
        );
        h = conv(k, &w, &b, &fine, width, true);
        width = b.len();
        let dummy = rows_at(k) - 1;
        h[dummy * width..].fill(0.0);
    }
    let y = conv(0, &f32s("s2d.out.w"), &f32s("s2d.out.b"), &h, width, false);
    y[..(rows_at(0) - 1) * outputs].to_vec()
}

/// ELU's negative branch as the core evaluates it (α = 1): `libm::expm1f`, reached through the
/// core's own activation so that this test needs no `libm` of its own.
fn libm_expm1(z: f32) -> f32 {
    sinew_core::nn::Activation::Elu { alpha: 1.0 }.apply(z)
}

/// The core's decode against [`reference_displacements`], bit for bit, on the tiny baked decoder
/// and on freshly initialised decoders whose widths straddle the kernels' blocks (4 vertices;
/// 4, 8 and 16 channels): odd FC widths, filters of 5, 9, 17 and 3, vertex counts that are not
/// multiples of 4, and each stage activation.
#[test]
fn decode_bits_match_a_plain_reference() {
    use sinew_host::s2d::decoder::StageActivation::{Elu, Identity, LeakyRelu};
    use sinew_host::s2d::decoder::{DecoderConfig, S2dDecoder as Burn};
    use sinew_host::s2d::synthetic;
    let device = sinew_host::training::backend::Backend::Flex
        .device(1)
        .unwrap();
    let mut cases = vec![synthetic::tiny_baked_decoder().1];
    for (sizes, spirals, fc, filters, activation, seed) in [
        (&[30, 12, 5][..], &[5, 4, 3][..], 4, vec![5, 3], Elu, 1),
        (&[37, 13, 6][..], &[7, 5, 3][..], 7, vec![17, 9], Elu, 2),
        (
            &[61, 23, 9, 2][..],
            &[9, 6, 4, 2][..],
            5,
            vec![16, 8, 5],
            Elu,
            3,
        ),
        (
            &[37, 13, 6][..],
            &[7, 5, 3][..],
            7,
            vec![17, 9],
            LeakyRelu,
            4,
        ),
        (
            &[37, 13, 6][..],
            &[7, 5, 3][..],
            7,
            vec![17, 9],
            Identity,
            5,
        ),
    ] {
        let h = synthetic::hierarchy(sizes, spirals, seed);
        let config = DecoderConfig {
            inputs: 6,
            fc_features: fc,
            filters,
            activation,
            ..DecoderConfig::default()
        };
        let dec = Burn::new(&config, &h, &device).unwrap();
        cases.push(sinew_host::s2d::bake::bake(&dec, &h, &[1, 2], &[]).unwrap());
    }
    let mut rng = sinew_tests::Rng::new(31);
    for (i, bytes) in cases.iter().enumerate() {
        let core = S2dDecoder::from_bytes(bytes).unwrap();
        let mut scratch = vec![f32::NAN; core.scratch_len()];
        let mut out = vec![f32::NAN; 3 * core.vertex_count()];
        for _ in 0..3 {
            let input = rng.vec(core.input_len(), -0.5, 0.5);
            core.displacements(&input, &mut scratch, &mut out).unwrap();
            let expected = reference_displacements(bytes, &input);
            let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&out), bits(&expected), "decoder {i}");
        }
    }
}
