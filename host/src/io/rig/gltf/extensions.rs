//! Which glTF extensions a rig may use: those whose data Sinew decodes (quantised and
//! meshopt-compressed geometry, a VRM avatar's expressions), those that concern only what Sinew
//! does not read (textures, materials, lights, animation, physics), accepted even when required,
//! and the rest, refused when required because they may change the geometry Sinew reads.

use std::path::Path;

use crate::io::rig::file::{ExtensionUse, RigReadError, Treatment};

/// Extensions whose data Sinew decodes.
const DECODED: [&str; 5] = [
    "KHR_mesh_quantization",
    "EXT_meshopt_compression",
    "KHR_meshopt_compression",
    "VRMC_vrm",
    "VRM",
];

/// Mesh compression Sinew does not decode: refused with advice on how to export instead.
const UNDECODED_COMPRESSION: [&str; 1] = ["KHR_draco_mesh_compression"];

/// Extensions named in full that concern only what Sinew does not read.
const NOT_READ: [&str; 14] = [
    // The dequantisation of texture coordinates (KHR_mesh_quantization) Sinew applies itself.
    "KHR_texture_transform",
    "KHR_lights_punctual",
    "EXT_lights_image_based",
    "KHR_animation_pointer",
    "KHR_xmp_json_ld",
    "KHR_xmp",
    "KHR_node_visibility",
    "KHR_interactivity",
    "KHR_audio_emitter",
    "VRMC_springBone",
    "VRMC_springBone_extended_collider",
    "VRMC_node_constraint",
    "VRMC_vrm_animation",
    "MSFT_packing_occlusionRoughnessMetallic",
];

/// Name prefixes of families that concern only textures, materials and lights.
const NOT_READ_FAMILIES: [&str; 7] = [
    "KHR_texture_",
    "EXT_texture_",
    "MSFT_texture_",
    "KHR_materials_",
    "EXT_materials_",
    "VRMC_materials_",
    "KHR_lights_",
];

/// What Sinew does with `name`, or `None` where it may change the geometry and is not decoded.
pub(crate) fn treatment(name: &str) -> Option<Treatment> {
    if DECODED.contains(&name) {
        Some(Treatment::Decoded)
    } else if NOT_READ.contains(&name) || NOT_READ_FAMILIES.iter().any(|f| name.starts_with(f)) {
        Some(Treatment::NotRead)
    } else {
        None
    }
}

/// Each extension the file uses or requires, with what Sinew makes of it; an error for the
/// first required one that may change the geometry and is not decoded.
pub(crate) fn check(
    path: &Path,
    used: &[String],
    required: &[String],
) -> Result<Vec<ExtensionUse>, RigReadError> {
    for name in required {
        if UNDECODED_COMPRESSION.contains(&name.as_str()) {
            return Err(RigReadError::Compressed {
                path: path.to_owned(),
                extension: name.clone(),
            });
        }
        if treatment(name).is_none() {
            return Err(RigReadError::Extension {
                path: path.to_owned(),
                extension: name.clone(),
            });
        }
    }
    let mut out: Vec<ExtensionUse> = Vec::new();
    for name in used.iter().chain(required) {
        if out.iter().any(|e| &e.name == name) {
            continue;
        }
        out.push(ExtensionUse {
            name: name.clone(),
            required: required.contains(name),
            // An optional extension Sinew does not know is ignored, as the spec allows.
            treatment: treatment(name).unwrap_or(Treatment::NotRead),
        });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn geometry_is_decoded_or_refused_and_the_rest_is_not_read() {
        assert_eq!(treatment("KHR_mesh_quantization"), Some(Treatment::Decoded));
        assert_eq!(
            treatment("EXT_meshopt_compression"),
            Some(Treatment::Decoded)
        );
        assert_eq!(treatment("KHR_texture_basisu"), Some(Treatment::NotRead));
        assert_eq!(treatment("EXT_texture_webp"), Some(Treatment::NotRead));
        assert_eq!(
            treatment("KHR_materials_clearcoat"),
            Some(Treatment::NotRead)
        );
        assert_eq!(treatment("VRMC_materials_mtoon"), Some(Treatment::NotRead));
        assert_eq!(treatment("KHR_lights_punctual"), Some(Treatment::NotRead));
        assert_eq!(treatment("EXT_mesh_gpu_instancing"), None);
        assert_eq!(treatment("KHR_draco_mesh_compression"), None);
        assert_eq!(treatment("ACME_wobble"), None);
        let p = Path::new("x.glb");
        let used = ["KHR_texture_basisu".to_owned(), "ACME_wobble".to_owned()];
        let list = check(p, &used, &used[..1]).unwrap();
        assert_eq!(list.len(), 2);
        assert!(list[0].required && list[0].treatment == Treatment::NotRead);
        assert!(!list[1].required);
        assert!(matches!(
            check(p, &used, &used[1..]),
            Err(RigReadError::Extension { extension, .. }) if extension == "ACME_wobble"
        ));
        assert!(matches!(
            check(p, &[], &["KHR_draco_mesh_compression".to_owned()]),
            Err(RigReadError::Compressed { .. })
        ));
    }
}
