//! Baking a trained AIM into the core's format: the networks, and their outputs at the template
//! vertices as a per-vertex cache for real-time playback (see `sinew_core::aim` for the sections).

use super::{AimConfig, TrainingSet};
use burn::tensor::Device;
use sinew_core::FormatError;
use sinew_core::format::{ArtifactKind, FLAG_PLAYBACK_ONLY};

use super::model::{AimNet, normalise};
use crate::io::container::{SinewWriter, WriterError};
use crate::training::nn::{tensor, to_vec};

/// Why the Q16.16 playback cache could not be added to an actor.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Q16CacheError {
    /// The bytes are not an AIM actor.
    #[error("not an AIM actor")]
    NotAnActor(#[source] FormatError),
    /// The actor lacks an `f32` cache section the Q16.16 cache is rounded from.
    #[error("section {name} missing")]
    MissingSection {
        /// The section.
        name: String,
    },
    /// The actor with its cache could not be laid out.
    #[error(transparent)]
    Writer(#[from] WriterError),
}

/// The networks' outputs at a set of points.
#[derive(Clone, Debug, Default)]
pub struct Cache {
    /// s0 `[V]`.
    pub skin: Vec<[f32; 3]>,
    /// k `[V]`.
    pub k: Vec<f32>,
    /// B_e `[V, M, 3]` flattened.
    pub correctives: Vec<f32>,
    /// b0 `[V]`.
    pub bone: Vec<[f32; 3]>,
    /// d0 `[V]`.
    pub thickness: Vec<f32>,
    /// n0 `[V]`.
    pub normal: Vec<[f32; 3]>,
}

/// Evaluates the networks at `points` in chunks of 4096 (faster per point than one large batch).
pub fn evaluate(net: &AimNet, points: &[[f32; 3]], norm: [f32; 4], device: &Device) -> Cache {
    let mut cache = Cache::default();
    for chunk in points.chunks(4096) {
        let n = chunk.len();
        let x = tensor(
            chunk.iter().flat_map(|&p| normalise(p, norm)).collect(),
            [n, 3],
            device,
        );
        let c = tensor(chunk.iter().flatten().copied().collect(), [n, 3], device);
        let p = net.predict(x, c);
        cache.skin.extend(crate::io::mesh::points(to_vec(p.skin)));
        cache.k.extend(to_vec(p.k));
        cache.correctives.extend(to_vec(p.correctives));
        cache.bone.extend(crate::io::mesh::points(to_vec(p.bone)));
        cache.thickness.extend(to_vec(p.thickness));
        cache
            .normal
            .extend(crate::io::mesh::points(to_vec(p.normal)));
    }
    cache
}

/// What goes into a baked actor besides the networks.
#[derive(Clone, Debug)]
pub struct BakeInput<'a> {
    /// Template points the cache is evaluated at.
    pub points: &'a [[f32; 3]],
    /// Template triangles.
    pub triangles: &'a [[u32; 3]],
    /// Jaw pivot.
    pub jaw_pivot: [f32; 3],
    /// Input normalisation.
    pub normalisation: [f32; 4],
    /// Leave the networks out.
    pub playback_only: bool,
    /// Metadata entries (units, provenance, config…).
    pub metadata: Vec<(String, String)>,
}

/// Builds the baked actor.
pub fn bake(
    net: &AimNet,
    input: &BakeInput<'_>,
    device: &Device,
) -> Result<(Vec<u8>, Cache), WriterError> {
    let cache = evaluate(net, input.points, input.normalisation, device);
    let v = input.points.len();
    let m = net.corrective_shapes();
    let mut w = SinewWriter::new(ArtifactKind::AimActor);
    if input.playback_only {
        w.flags(FLAG_PLAYBACK_ONLY);
    }
    for (k, val) in &input.metadata {
        w.meta(k, val);
    }
    let flat = |p: &[[f32; 3]]| p.iter().flatten().copied().collect::<Vec<f32>>();
    w.f32s("tpl.pos", &[v, 3], &flat(input.points))?;
    let tri: Vec<u32> = input.triangles.iter().flatten().copied().collect();
    w.u32s("tpl.tri", &[input.triangles.len(), 3], &tri)?;
    w.f32s("cache.s0", &[v, 3], &flat(&cache.skin))?;
    w.f32s("cache.k", &[v], &cache.k)?;
    w.f32s("cache.e", &[v, m, 3], &cache.correctives)?;
    w.f32s("cache.b0", &[v, 3], &flat(&cache.bone))?;
    w.f32s("cache.d0", &[v], &cache.thickness)?;
    w.f32s("cache.n0", &[v, 3], &flat(&cache.normal))?;
    w.f32s("jaw.pivot", &[3], &input.jaw_pivot)?;
    // The learned jaw transform of each training expression, for evaluation and replays.
    w.f32s("train.jaw", &[m, 9], &to_vec(net.jaw.val()))?;
    if !input.playback_only {
        w.f32s("aim.norm", &[4], &input.normalisation)?;
        // Written only when not the identity, so that files of the paper's model stay as before.
        if net.thickness_activation != super::config::ThicknessActivation::Identity {
            w.u32s("aim.dact", &[1], &[net.thickness_activation.code()])?;
        }
        for (name, mlp) in [
            ("net.b", &net.b),
            ("net.d", &net.d),
            ("net.n", &net.n),
            ("net.k", &net.k),
            ("net.e", &net.e),
        ] {
            mlp.export(&mut w, name)?;
        }
    }
    Ok((w.to_bytes()?, cache))
}

/// Adds the Q16.16 playback cache (`q16.s0`, `q16.k`, `q16.e`: the `f32` cache rounded to
/// nearest with `sinew_core::q16::q16`, exactly as the core would) to a baked actor, for the
/// core's fixed-point mode (`sinew_core::q16`). An actor that has one already is returned as is.
pub fn with_q16_cache(actor_bytes: &[u8]) -> Result<Vec<u8>, Q16CacheError> {
    let actor =
        sinew_core::aim::AimActor::from_bytes(actor_bytes).map_err(Q16CacheError::NotAnActor)?;
    if actor.q16().is_some() {
        return Ok(actor_bytes.to_vec());
    }
    let (v, m) = (actor.vertex_count(), actor.shape_count());
    let file = actor.file();
    let q = |name: &str| -> Result<Vec<i32>, Q16CacheError> {
        let s = file.section(name).and_then(|s| s.f32s()).ok_or_else(|| {
            Q16CacheError::MissingSection {
                name: name.to_string(),
            }
        })?;
        Ok(s.iter()
            .map(|x| sinew_core::q16::q16(x).to_bits())
            .collect())
    };
    let mut w = SinewWriter::from_file(file)?;
    w.q16s("q16.s0", &[v, 3], &q("cache.s0")?)?;
    w.q16s("q16.k", &[v], &q("cache.k")?)?;
    w.q16s("q16.e", &[v, m, 3], &q("cache.e")?)?;
    Ok(w.to_bytes()?)
}

/// The metadata entry `uv` (`geometry::uv`) of an actor baked on `template` (whose triangles are
/// `triangles`, its fan triangulation): the template's own texture coordinates, or else those of
/// `training` (the checkpoint's template, another resolution of the same face) carried onto it.
/// None for an actor learned from a rig, whose record (`metadata`'s `rig`) holds the rig's, or
/// where neither mesh has coordinates.
pub fn uv_metadata(
    metadata: &[(String, String)],
    template: &crate::io::mesh::Mesh,
    triangles: &[[u32; 3]],
    training: Option<&crate::io::mesh::Mesh>,
) -> Result<Option<(String, String)>, crate::geometry::uv::UvError> {
    use crate::geometry::uv::{CornerUvs, KEY};
    if metadata.iter().any(|(k, _)| k == crate::rig::record::KEY) {
        return Ok(None);
    }
    let uvs = match CornerUvs::of_mesh(template) {
        Some(uvs) => uvs,
        None => match training.and_then(|t| Some((t, CornerUvs::of_mesh(t)?))) {
            Some((t, uvs)) => uvs.transfer(t, &template.positions, triangles),
            None => return Ok(None),
        },
    };
    let flat: Vec<u32> = triangles.iter().flatten().copied().collect();
    Ok(Some((
        KEY.into(),
        uvs.metadata(&flat, template.positions.len())?,
    )))
}

/// Metadata recorded in every baked actor.
pub fn metadata(
    set: &TrainingSet,
    config: &AimConfig,
) -> Result<Vec<(String, String)>, serde_json::Error> {
    let mut recorded = vec![
        ("units".into(), set.units.name().into()),
        ("axes".into(), "x-left-of-actor,y-up,z-forward".into()),
        (
            "tool".into(),
            format!("sinew {}", env!("CARGO_PKG_VERSION")),
        ),
        ("source".into(), set.source.replace('\n', " ")),
        ("seed".into(), config.seed.to_string()),
        ("shapes".into(), set.names.join(",")),
        ("config".into(), serde_json::to_string(config)?),
    ];
    recorded.extend(set.provenance.iter().cloned());
    Ok(recorded)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn q16_cache_is_the_rounded_f32_cache_and_loads_in_the_core() {
        let golden = std::fs::read(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../tests/data/aim-procedural.sinew"
        ))
        .unwrap();
        // The golden actor carries the cache already: take it off, then add it again.
        let file = sinew_core::SinewFile::from_bytes(&golden).unwrap();
        let mut w = SinewWriter::from_file(&file).unwrap();
        assert_eq!(w.remove_prefixed("q16."), 3);
        let bytes = w.to_bytes().unwrap();
        let out = with_q16_cache(&bytes).unwrap();
        assert_eq!(out, golden, "the same bytes as the committed golden");
        let before = sinew_core::aim::AimActor::from_bytes(&bytes).unwrap();
        let after = sinew_core::aim::AimActor::from_bytes(&out).unwrap();
        assert!(before.q16().is_none());
        let q = after.q16().unwrap();
        assert_eq!(q.vertex_count(), before.vertex_count());
        // Everything else is carried over unchanged.
        assert_eq!(
            after.file().metadata().text(),
            before.file().metadata().text()
        );
        for s in before.file().sections() {
            assert_eq!(after.file().section(s.name()).unwrap().data(), s.data());
        }
        let s0 = after.file().section("q16.s0").unwrap().q16s().unwrap();
        for (i, x) in before.rest().iter().enumerate() {
            assert!((f64::from(s0.at(i)) / 65536.0 - f64::from(x)).abs() <= 0.5 / 65536.0);
        }
        // Idempotent.
        assert_eq!(with_q16_cache(&out).unwrap(), out);
    }

    #[test]
    fn a_damaged_actor_is_refused() {
        let golden = std::fs::read(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../tests/data/aim-procedural.sinew"
        ))
        .unwrap();
        let err = with_q16_cache(&golden[..golden.len() / 2]).unwrap_err();
        assert!(matches!(err, Q16CacheError::NotAnActor(_)), "{err}");
    }
}
