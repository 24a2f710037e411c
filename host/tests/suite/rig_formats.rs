//! glTF rigs as optimisers and avatar tools write them: every component type
//! `KHR_mesh_quantization` allows (and the ones it forbids, refused by accessor),
//! `EXT_meshopt_compression` views (codecs, filters, fallback buffers; truncated or miscounted
//! streams refused by view), and required extensions Sinew need not read. VRM avatars are
//! `super::vrm`'s, on this file's grid rig and glTF document.

use std::path::Path;

use serde_json::{Value, json};
use sinew_host::io::mesh::Mesh;
use sinew_host::io::rig::{IDENTITY, RigFile, RigFormat, RigReadError, Treatment};
use sinew_host::io::units::Unit;

/// A small rig in metres: a curved 12 × 10 grid (0.16 m wide), its texture coordinates, and
/// `targets` shapes named `names`, each a smooth bump.
pub(crate) fn grid_rig(names: &[&str]) -> RigFile {
    let (nx, ny) = (12usize, 10usize);
    let mut positions = Vec::new();
    let mut uvs = Vec::new();
    for j in 0..ny {
        for i in 0..nx {
            let (u, v) = (i as f32 / (nx - 1) as f32, j as f32 / (ny - 1) as f32);
            positions.push([
                0.16 * u - 0.08,
                1.5 + 0.2 * v,
                0.1 - 0.05 * (u - 0.5).powi(2),
            ]);
            uvs.push([0.1 + 0.8 * u, 0.05 + 0.9 * v]);
        }
    }
    let mut polygons = Vec::new();
    for j in 0..ny - 1 {
        for i in 0..nx - 1 {
            let a = (j * nx + i) as u32;
            polygons.push(vec![a, a + 1, a + nx as u32]);
            polygons.push(vec![a + 1, a + nx as u32 + 1, a + nx as u32]);
        }
    }
    let deltas = (0..names.len())
        .map(|k| {
            positions
                .iter()
                .map(|p| {
                    let w =
                        (-((p[0] - 0.02 * k as f32).powi(2) + (p[1] - 1.6).powi(2)) / 0.003).exp();
                    [0.004 * w, -0.01 * w * (k as f32 - 1.0), 0.006 * w]
                })
                .collect()
        })
        .collect();
    let mut neutral = Mesh::new(positions, polygons);
    neutral.uvs = uvs;
    RigFile {
        path: "grid".into(),
        format: RigFormat::Gltf,
        mesh_name: "head".into(),
        neutral,
        shape_names: names.iter().map(|s| (*s).to_owned()).collect(),
        deltas,
        node_transform: IDENTITY,
        units: Some(Unit::Metre),
        extensions: Vec::new(),
        avatar: None,
    }
}

/// A `.glb`'s JSON and binary chunk, edited and written again.
pub(crate) struct Doc {
    pub(crate) json: Value,
    pub(crate) bin: Vec<u8>,
}

impl Doc {
    pub(crate) fn of(file: &RigFile) -> Self {
        let bytes = file.glb().unwrap();
        let (json, bin) = sinew_host::io::glb::read(&bytes).unwrap();
        Self {
            json: serde_json::from_slice(json).unwrap(),
            bin: bin.to_vec(),
        }
    }

    /// Appends `bytes` to the binary chunk as a new view of `buffer` 0; returns its index.
    fn view(&mut self, bytes: &[u8], stride: Option<usize>) -> usize {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        let mut v = json!({"buffer": 0, "byteOffset": self.bin.len(), "byteLength": bytes.len()});
        if let Some(s) = stride {
            v["byteStride"] = json!(s);
        }
        self.bin.extend_from_slice(bytes);
        self.push("bufferViews", v)
    }

    pub(crate) fn push(&mut self, list: &str, v: Value) -> usize {
        let a = self.json[list].as_array_mut().unwrap();
        a.push(v);
        a.len() - 1
    }

    fn accessor(
        &mut self,
        view: usize,
        ctype: u32,
        normalized: bool,
        count: usize,
        ty: &str,
    ) -> usize {
        self.push(
            "accessors",
            json!({"bufferView": view, "componentType": ctype, "normalized": normalized,
                   "count": count, "type": ty}),
        )
    }

    fn primitive(&mut self) -> &mut Value {
        &mut self.json["meshes"][0]["primitives"][0]
    }

    pub(crate) fn uses(&mut self, extension: &str, required: bool) {
        for key in ["extensionsUsed", "extensionsRequired"]
            .into_iter()
            .take(1 + usize::from(required))
        {
            let list = self.json[key].as_array().cloned().unwrap_or_default();
            if !list.contains(&json!(extension)) {
                let mut list = list;
                list.push(json!(extension));
                self.json[key] = json!(list);
            }
        }
    }

    pub(crate) fn write(&mut self, path: &Path) {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        self.json["buffers"][0]["byteLength"] = json!(self.bin.len());
        let text = serde_json::to_vec(&self.json).unwrap();
        std::fs::write(path, sinew_host::io::glb::write(&text, &self.bin).unwrap()).unwrap();
    }
}

/// A component type's code, byte size, whether it is signed, and its largest value.
fn ctype(name: &str) -> (u32, usize, bool, f64) {
    match name {
        "BYTE" => (5120, 1, true, 127.0),
        "UNSIGNED_BYTE" => (5121, 1, false, 255.0),
        "SHORT" => (5122, 2, true, 32767.0),
        "UNSIGNED_SHORT" => (5123, 2, false, 65535.0),
        _ => unreachable!(),
    }
}

/// `values` (groups of `width`) stored as integers of `name`, each group padded to 4 bytes.
fn store(values: &[f64], width: usize, name: &str) -> (Vec<u8>, usize) {
    let (_, size, signed, _) = ctype(name);
    let stride = (width * size).div_ceil(4) * 4;
    let mut out = Vec::new();
    for group in values.chunks(width) {
        let start = out.len();
        for &v in group {
            let r = v.round();
            match (size, signed) {
                (1, true) => out.push((r as i8) as u8),
                (1, false) => out.push(r as u8),
                (_, true) => out.extend((r as i16).to_le_bytes()),
                _ => out.extend((r as u16).to_le_bytes()),
            }
        }
        out.resize(start + stride, 0);
    }
    (out, stride)
}

fn scene(t: &[[f64; 4]; 4], p: [f32; 3]) -> [f64; 3] {
    std::array::from_fn(|r| (0..3).map(|c| t[c][r] * f64::from(p[c])).sum::<f64>() + t[3][r])
}

/// Every position type `KHR_mesh_quantization` allows, normalised or not, with signed morph
/// target deltas and quantised texture coordinates dequantised by the material's
/// `KHR_texture_transform`: each reads as the float rig in the scene within half a step.
#[test]
fn every_quantised_component_type_reads_as_the_float_rig() {
    let dir = tempfile::tempdir().unwrap();
    let rig = grid_rig(&["a", "b"]);
    let (lo, hi) = rig.neutral.bounds();
    let extent = (0..3).map(|k| f64::from(hi[k] - lo[k])).fold(0.0, f64::max);
    let n = rig.vertex_count();
    for (position, normalized) in ["BYTE", "UNSIGNED_BYTE", "SHORT", "UNSIGNED_SHORT"]
        .into_iter()
        .flat_map(|p| [(p, false), (p, true)])
    {
        let (code, _, _, most) = ctype(position);
        // Stored integer q means lo + q · step (normalised: q / most of the extent).
        let step = extent / most;
        let scale = if normalized { extent } else { step };
        let q: Vec<f64> = rig
            .neutral
            .positions
            .iter()
            .flat_map(|p| (0..3).map(move |k| f64::from(p[k] - lo[k]) / step))
            .collect();
        let mut doc = Doc::of(&rig);
        let (bytes, stride) = store(&q, 3, position);
        let view = doc.view(&bytes, Some(stride));
        let a = doc.accessor(view, code, normalized, n, "VEC3");
        doc.json["accessors"][a]["min"] = json!([0, 0, 0]);
        doc.json["accessors"][a]["max"] = json!([most, most, most]);
        doc.primitive()["attributes"]["POSITION"] = json!(a);
        // Deltas on the same grid, in the signed type of the same size.
        let target = if ctype(position).1 == 1 {
            "BYTE"
        } else {
            "SHORT"
        };
        let (tcode, _, _, tmost) = ctype(target);
        let tstep = if normalized { extent / tmost } else { step };
        for (k, d) in rig.deltas.iter().enumerate() {
            let v: Vec<f64> = d
                .iter()
                .flat_map(|d| d.map(|c| f64::from(c) / tstep))
                .collect();
            let (bytes, stride) = store(&v, 3, target);
            let view = doc.view(&bytes, Some(stride));
            let a = doc.accessor(view, tcode, normalized, n, "VEC3");
            doc.primitive()["targets"][k]["POSITION"] = json!(a);
        }
        // Texture coordinates as integers of the same type, dequantised by the material.
        let (uv_lo, uv_step) = (
            0.04,
            0.8 / if ctype(position).1 == 1 {
                100.0
            } else {
                3000.0
            },
        );
        let uq: Vec<f64> = rig
            .neutral
            .uvs
            .iter()
            .flat_map(|t| t.map(|c| (f64::from(c) - uv_lo) / uv_step))
            .collect();
        let (bytes, stride) = store(&uq, 2, position);
        let view = doc.view(&bytes, Some(stride));
        let a = doc.accessor(view, code, normalized, n, "VEC2");
        doc.primitive()["attributes"]["TEXCOORD_0"] = json!(a);
        let uv_scale = if normalized { uv_step * most } else { uv_step };
        doc.json["images"] = json!([{"uri": "face.png"}]);
        doc.json["textures"] = json!([{"source": 0}]);
        doc.json["materials"] = json!([{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0,
            "extensions": {"KHR_texture_transform": {"offset": [uv_lo, uv_lo], "scale": [uv_scale, uv_scale]}}}}}]);
        doc.primitive()["material"] = json!(0);
        doc.json["nodes"][0]["matrix"] = json!([
            scale, 0, 0, 0, 0, scale, 0, 0, 0, 0, scale, 0, lo[0], lo[1], lo[2], 1
        ]);
        doc.uses("KHR_mesh_quantization", true);
        doc.uses("KHR_texture_transform", false);
        let path = dir.path().join(format!("{position}-{normalized}.glb"));
        doc.write(&path);

        let read =
            RigFile::read(&path, None).unwrap_or_else(|e| panic!("{position} {normalized}: {e}"));
        let t = read.node_transform;
        let half = |s: f64| 0.5 * s + 1e-6 * extent;
        for (p, want) in read.neutral.positions.iter().zip(&rig.neutral.positions) {
            let got = scene(&t, *p);
            for k in 0..3 {
                assert!(
                    (got[k] - f64::from(want[k])).abs() <= half(step),
                    "{position} {normalized}: {got:?} {want:?}"
                );
            }
        }
        for (d, want) in read.deltas.iter().zip(&rig.deltas) {
            for (d, w) in d.iter().zip(want) {
                for k in 0..3 {
                    let got = f64::from(d[k]) * scale;
                    assert!(
                        (got - f64::from(w[k])).abs() <= half(tstep),
                        "{position} {normalized} delta {got} {}",
                        w[k]
                    );
                }
            }
        }
        for (uv, want) in read.neutral.uvs.iter().zip(&rig.neutral.uvs) {
            for k in 0..2 {
                assert!(
                    (uv[k] - want[k]).abs() <= (0.5 * uv_step + 1e-5) as f32,
                    "{position} {normalized} uv {uv:?} {want:?}"
                );
            }
        }
        assert!(
            read.extensions
                .iter()
                .any(|e| e.name == "KHR_mesh_quantization"
                    && e.required
                    && e.treatment == Treatment::Decoded)
        );
    }
}

/// What `KHR_mesh_quantization` forbids is refused, naming the file and the accessor.
#[test]
fn component_types_the_extension_forbids_are_refused_by_accessor() {
    let dir = tempfile::tempdir().unwrap();
    let rig = grid_rig(&["a"]);
    let n = rig.vertex_count();
    let cases: [(&str, u32, bool, &str); 5] = [
        ("POSITION", 5125, false, "VEC3"),   // UNSIGNED_INT
        ("POSITION", 5126, true, "VEC3"),    // normalised FLOAT
        ("TARGET", 5121, false, "VEC3"),     // unsigned deltas
        ("TARGET", 5123, true, "VEC3"),      // unsigned normalised deltas
        ("TEXCOORD_0", 5126, false, "VEC3"), // the wrong type
    ];
    for (k, (what, code, normalized, ty)) in cases.into_iter().enumerate() {
        let mut doc = Doc::of(&rig);
        let width = if ty == "VEC3" { 3 } else { 2 };
        let view = doc.view(&vec![0u8; n * width * 4], None);
        let a = doc.accessor(view, code, normalized, n, ty);
        doc.json["accessors"][a]["min"] = json!([0, 0, 0]);
        doc.json["accessors"][a]["max"] = json!([1, 1, 1]);
        match what {
            "TARGET" => doc.primitive()["targets"][0]["POSITION"] = json!(a),
            attribute => doc.primitive()["attributes"][attribute] = json!(a),
        }
        doc.uses("KHR_mesh_quantization", true);
        let path = dir.path().join(format!("forbidden-{k}.glb"));
        doc.write(&path);
        let e = RigFile::read(&path, None).unwrap_err();
        assert!(
            matches!(&e, RigReadError::Accessor { accessor, .. } if *accessor == a),
            "{what} {code} {normalized}: {e}"
        );
        let text = e.to_string();
        assert!(
            text.contains(&format!("forbidden-{k}.glb")) && text.contains(&format!("accessor {a}")),
            "{text}"
        );
    }
}

/// Required extensions that concern only textures, materials or lights are read past and
/// listed; one that may change the geometry is refused by name, and Draco with advice.
#[test]
fn required_extensions_are_accepted_or_refused_by_what_they_change() {
    let dir = tempfile::tempdir().unwrap();
    let rig = grid_rig(&["a"]);
    let path = dir.path().join("textured.glb");
    let mut doc = Doc::of(&rig);
    for e in [
        "KHR_texture_basisu",
        "KHR_materials_clearcoat",
        "KHR_lights_punctual",
        "EXT_texture_webp",
    ] {
        doc.uses(e, true);
    }
    doc.uses("ACME_unknown_but_optional", false);
    doc.write(&path);
    let read = RigFile::read(&path, None).unwrap();
    assert_eq!(read.deltas, rig.deltas);
    let names: Vec<(&str, bool, Treatment)> = read
        .extensions
        .iter()
        .map(|e| (e.name.as_str(), e.required, e.treatment))
        .collect();
    assert!(
        names.contains(&("KHR_texture_basisu", true, Treatment::NotRead)),
        "{names:?}"
    );
    assert!(names.contains(&("ACME_unknown_but_optional", false, Treatment::NotRead)));
    assert_eq!(names.len(), 5);

    for (k, e) in ["EXT_mesh_gpu_instancing", "ACME_wobble"]
        .into_iter()
        .enumerate()
    {
        let path = dir.path().join(format!("geometry-{k}.glb"));
        let mut doc = Doc::of(&rig);
        doc.uses("KHR_texture_basisu", true);
        doc.uses(e, true);
        doc.write(&path);
        let err = RigFile::read(&path, None).unwrap_err();
        assert!(
            matches!(&err, RigReadError::Extension { extension, .. } if extension == e),
            "{err}"
        );
        assert!(err.to_string().contains(&format!("geometry-{k}.glb")));
    }
    let path = dir.path().join("draco.glb");
    let mut doc = Doc::of(&rig);
    doc.uses("KHR_draco_mesh_compression", true);
    doc.write(&path);
    assert!(matches!(
        RigFile::read(&path, None),
        Err(RigReadError::Compressed { .. })
    ));
}

/// The rig's positions, morph targets (exponential filter), texture coordinates and indices
/// compressed by meshopt into buffer 0, with a fallback buffer 1 that has no data: read as the
/// plain rig; a truncated stream, or a count that is not the data's, is refused by view.
#[test]
fn meshopt_compressed_views_read_as_the_plain_rig_and_bad_streams_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let rig = grid_rig(&["a", "b"]);
    let plain = dir.path().join("plain.glb");
    rig.write_glb(&plain).unwrap();
    let want = RigFile::read(&plain, None).unwrap();

    let compress = |extension: &str, truncate: bool, miscount: bool| -> Doc {
        let mut doc = Doc::of(&rig);
        let fallback_len = doc.bin.len();
        // Every existing view moves to the fallback buffer, its data compressed into buffer 0.
        let views = doc.json["bufferViews"].as_array().unwrap().clone();
        let old = doc.bin.clone();
        doc.bin.clear();
        for (i, v) in views.iter().enumerate() {
            let (off, len) = (
                v["byteOffset"].as_u64().unwrap_or(0) as usize,
                v["byteLength"].as_u64().unwrap() as usize,
            );
            let bytes = &old[off..off + len];
            let is_index = v["target"] == json!(34963);
            let (encoded, stride, count, mode, filter) = if is_index {
                let idx: Vec<u32> = bytes
                    .chunks_exact(4)
                    .map(|c| u32::from_le_bytes(c.try_into().unwrap()))
                    .collect();
                (
                    meshopt::encode_index_buffer(&idx, rig.vertex_count()).unwrap(),
                    4,
                    idx.len(),
                    "TRIANGLES",
                    "NONE",
                )
            } else if i >= 2 {
                // Morph targets: floats through the exponential filter at full precision.
                let f: Vec<[f32; 3]> = bytes
                    .chunks_exact(12)
                    .map(|c| {
                        std::array::from_fn(|k| {
                            f32::from_le_bytes(c[4 * k..4 * k + 4].try_into().unwrap())
                        })
                    })
                    .collect();
                let packed = meshopt::encode_filter_exp(&f, 24, meshopt::EncodeExpMode::Separate);
                (
                    meshopt::encode_vertex_buffer(&packed).unwrap(),
                    12,
                    f.len(),
                    "ATTRIBUTES",
                    "EXPONENTIAL",
                )
            } else {
                let stride = if len == rig.vertex_count() * 8 { 8 } else { 12 };
                let words: Vec<[u8; 4]> = bytes
                    .chunks_exact(4)
                    .map(|c| c.try_into().unwrap())
                    .collect();
                let elements: Vec<Vec<[u8; 4]>> =
                    words.chunks(stride / 4).map(<[_]>::to_vec).collect();
                let encoded = match stride {
                    8 => meshopt::encode_vertex_buffer(
                        &elements.iter().map(|e| [e[0], e[1]]).collect::<Vec<_>>(),
                    )
                    .unwrap(),
                    _ => meshopt::encode_vertex_buffer(
                        &elements
                            .iter()
                            .map(|e| [e[0], e[1], e[2]])
                            .collect::<Vec<_>>(),
                    )
                    .unwrap(),
                };
                (encoded, stride, len / stride, "ATTRIBUTES", "NONE")
            };
            while !doc.bin.len().is_multiple_of(4) {
                doc.bin.push(0);
            }
            let mut ext = json!({"buffer": 0, "byteOffset": doc.bin.len(),
                "byteLength": encoded.len() - usize::from(truncate && i == 0),
                "byteStride": stride, "count": count + 16 * usize::from(miscount && i == 0), "mode": mode, "filter": filter});
            if miscount && i == 0 {
                ext["byteStride"] = json!(stride);
            }
            doc.bin.extend(&encoded);
            let view = &mut doc.json["bufferViews"][i];
            view["buffer"] = json!(1);
            view["extensions"] = json!({extension: ext});
            if miscount && i == 0 {
                // A count 16 past the data's: a group of 16 elements more than the stream holds
                // (within a group the codec cannot tell, since groups are padded).
                view["byteLength"] = json!(stride * (count + 16));
            }
        }
        let buffers = doc.json["buffers"].as_array_mut().unwrap();
        buffers.push(json!({"byteLength": fallback_len + 64,
            "extensions": {extension: {"fallback": true}}}));
        doc.uses(extension, true);
        doc
    };
    for extension in ["EXT_meshopt_compression", "KHR_meshopt_compression"] {
        let path = dir.path().join(format!("{extension}.glb"));
        compress(extension, false, false).write(&path);
        let read = RigFile::read(&path, None).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(read.neutral.positions, want.neutral.positions);
        // The triangle codec may start a triangle at another corner, keeping its winding.
        let turned = |p: &[Vec<u32>]| -> Vec<Vec<u32>> {
            p.iter()
                .map(|t| {
                    let m = (0..3).min_by_key(|&k| t[k]).unwrap();
                    (0..3).map(|k| t[(m + k) % 3]).collect()
                })
                .collect()
        };
        assert_eq!(
            turned(&read.neutral.polygons),
            turned(&want.neutral.polygons)
        );
        assert_eq!(read.neutral.uvs, want.neutral.uvs);
        for (d, w) in read.deltas.iter().zip(&want.deltas) {
            for (d, w) in d.iter().zip(w) {
                for k in 0..3 {
                    assert!(
                        (d[k] - w[k]).abs() <= w[k].abs() * 1e-6 + 1e-12,
                        "{d:?} {w:?}"
                    );
                }
            }
        }
    }
    for (name, truncate, miscount) in [("truncated", true, false), ("miscounted", false, true)] {
        let path = dir.path().join(format!("{name}.glb"));
        compress("EXT_meshopt_compression", truncate, miscount).write(&path);
        let e = RigFile::read(&path, None).unwrap_err();
        assert!(
            matches!(&e, RigReadError::BufferView { view: 0, .. }),
            "{name}: {e}"
        );
        assert!(e.to_string().contains(&format!("{name}.glb")), "{e}");
    }
    // A view left on the fallback buffer without the extension has no data to read.
    let path = dir.path().join("fallback-only.glb");
    let mut doc = compress("EXT_meshopt_compression", false, false);
    doc.json["bufferViews"][0]
        .as_object_mut()
        .unwrap()
        .remove("extensions");
    doc.write(&path);
    assert!(matches!(
        RigFile::read(&path, None),
        Err(RigReadError::BufferView { view: 0, .. })
    ));
}
