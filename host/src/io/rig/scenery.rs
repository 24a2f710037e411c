//! What a glTF rig holds besides its skin, so that an export can carry it: the other meshes
//! (eyes, teeth, hair) as triangles in their scene place, the materials, textures, samplers and
//! images as the file wrote them, and the skin's own material, and which meshes the rig hangs on
//! a jaw; with a list of what cannot be carried (other skins and their joints, animations, the VRM extension, cameras, lights).

/// The rest of a glTF rig's character.
#[derive(Clone, Debug, Default)]
pub struct Scenery {
    /// The skin mesh's vertex count (its primitives joined), to check an actor against.
    pub skin_vertices: usize,
    /// The material of the skin's first primitive, an index into [`Scenery::materials`].
    pub skin_material: Option<usize>,
    /// Every node that holds a mesh other than the skin, in depth-first scene order.
    pub parts: Vec<Part>,
    /// The file's materials as written (`textures` indices into [`Scenery::textures`]).
    pub materials: Vec<serde_json::Value>,
    /// The file's textures as written (`source` indices into [`Scenery::images`], `sampler`
    /// into [`Scenery::samplers`]).
    pub textures: Vec<serde_json::Value>,
    /// The file's samplers as written.
    pub samplers: Vec<serde_json::Value>,
    /// The file's images, their bytes read from the binary chunk, a data URI or a file beside.
    pub images: Vec<Image>,
    /// Extensions the materials and textures use (`KHR_texture_transform`,
    /// `KHR_materials_emissive_strength`, …), with whether the file required each.
    pub extensions: Vec<(String, bool)>,
    /// A VRM 1.0 avatar's `VRMC_vrm` extension as the file wrote it, for the export to keep
    /// with its expressions bound again to the learned shapes.
    pub vrm: Option<serde_json::Value>,
    /// A VRM 0.x avatar's `VRM` extension as the file wrote it, for the export to keep with its
    /// blend shape groups bound again to the learned shapes.
    pub vrm0: Option<serde_json::Value>,
    /// What the rig has that is not carried, one line each.
    pub dropped: Vec<String>,
}

/// A node's mesh other than the skin.
#[derive(Clone, Debug)]
pub struct Part {
    /// The node's name, else its mesh's, else `node N`.
    pub name: String,
    /// Its scene transform, column-major (a skinned mesh's: its bind pose's).
    pub world: [[f64; 4]; 4],
    /// Its triangle primitives.
    pub primitives: Vec<PartPrimitive>,
    /// Whether the rig puts it on a jaw: its node or a node above it is named like a jaw joint
    /// (`jaw` in the name, in any case), or every joint of its skin is.
    pub on_jaw: bool,
}

/// One primitive of a carried mesh, its accessors read as numbers.
#[derive(Clone, Debug)]
pub struct PartPrimitive {
    /// `POSITION`.
    pub positions: Vec<[f32; 3]>,
    /// `NORMAL`, where it has them.
    pub normals: Option<Vec<[f32; 3]>>,
    /// `TEXCOORD_0` as stored (its material's `KHR_texture_transform` still to apply).
    pub uvs: Option<Vec<[f32; 2]>>,
    /// The triangles, flat.
    pub triangles: Vec<u32>,
    /// Its material, an index into [`Scenery::materials`].
    pub material: Option<usize>,
}

/// An image's bytes and type.
#[derive(Clone, Debug)]
pub struct Image {
    /// Its name.
    pub name: Option<String>,
    /// Its MIME type (`image/png`, `image/jpeg`, `image/webp`, `image/ktx2`).
    pub mime_type: String,
    /// The encoded image.
    pub bytes: Vec<u8>,
}

/// The MIME type of an encoded image by its first bytes, for images given by file name.
pub(super) fn image_type(bytes: &[u8]) -> Option<&'static str> {
    if bytes.starts_with(b"\x89PNG\r\n\x1a\n") {
        Some("image/png")
    } else if bytes.starts_with(&[0xFF, 0xD8, 0xFF]) {
        Some("image/jpeg")
    } else if bytes.len() >= 12 && &bytes[..4] == b"RIFF" && &bytes[8..12] == b"WEBP" {
        Some("image/webp")
    } else if bytes.starts_with(b"\xABKTX 20\xBB\r\n\x1A\n") {
        Some("image/ktx2")
    } else {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::image_type;

    #[test]
    fn image_types_by_their_signatures() {
        assert_eq!(image_type(b"\x89PNG\r\n\x1a\nrest"), Some("image/png"));
        assert_eq!(image_type(&[0xFF, 0xD8, 0xFF, 0xE0]), Some("image/jpeg"));
        assert_eq!(image_type(b"RIFF\0\0\0\0WEBPVP8 "), Some("image/webp"));
        assert_eq!(image_type(b"GIF89a"), None);
        assert_eq!(image_type(b""), None);
    }
}
