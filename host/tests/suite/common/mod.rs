//! What the command-line tests share: running the `sinew` binary of this build, and paths in the
//! repository.

#![allow(dead_code)] // not every helper is used in every build of the suite

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Runs `sinew` with `args`, without the environment's `SINEW_SEED`.
pub fn sinew(args: &[&str]) -> Output {
    sinew_with(args, &[])
}

/// Runs `sinew` with the environment variables `vars` set.
pub fn sinew_with(args: &[&str], vars: &[(&str, &str)]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_sinew"))
        .args(args)
        .env_remove("SINEW_SEED")
        .envs(vars.iter().copied())
        .output()
        .expect("run sinew")
}

/// What a resume sets so that touching burn's default device fails: a backend that does not
/// exist (burn panics on it). A resumed run must read its state onto the device it trains on.
pub const NO_DEFAULT_DEVICE: (&str, &str) = ("BURN_DEVICE", "no-such-backend");

/// Runs `sinew`, requires success and returns its standard output.
pub fn ok(args: &[&str]) -> String {
    ok_with(args, &[])
}

/// [`ok`] with the environment variables `vars` set.
pub fn ok_with(args: &[&str], vars: &[(&str, &str)]) -> String {
    let out = sinew_with(args, vars);
    assert!(
        out.status.success(),
        "sinew {args:?} failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// Runs `sinew`, requires failure and returns its standard error.
pub fn err(args: &[&str]) -> String {
    let out = sinew(args);
    assert!(!out.status.success(), "sinew {args:?} should have failed");
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// A path as a command-line argument.
pub fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// A file of the repository by its path from the root, as an argument.
pub fn repo(path: &str) -> String {
    let p: PathBuf = Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(path);
    p.to_str().unwrap().to_owned()
}
pub mod gltf;

/// A Live Link Face capture whose channels are `names` (an actor's own shape names, which the
/// mapping plays exactly): frame 0 at rest, then frame `i + 1` with channel `i` alone at 1.
pub fn each_shape_capture(names: &[String]) -> String {
    use sinew_host::io::arkit::{Capture, CaptureFrame};
    let frames = (0..=names.len())
        .map(|f| CaptureFrame {
            timecode: format!("00:00:{:02}:{:02}.000", f / 30, f % 30),
            values: (0..names.len())
                .map(|c| if c + 1 == f { 1.0 } else { 0.0 })
                .collect(),
        })
        .collect();
    Capture {
        channels: names.to_vec(),
        frames,
    }
    .to_csv()
}

/// Mean and largest distance between two vertex lists, in the lists' unit.
pub fn distances(a: &[[f32; 3]], b: &[[f32; 3]]) -> (f64, f64) {
    assert_eq!(a.len(), b.len());
    let d: Vec<f64> = a
        .iter()
        .zip(b)
        .map(|(p, q)| {
            (0..3)
                .map(|k| f64::from(p[k] - q[k]).powi(2))
                .sum::<f64>()
                .sqrt()
        })
        .collect();
    (
        d.iter().sum::<f64>() / d.len() as f64,
        d.iter().copied().fold(0.0, f64::max),
    )
}

/// An untrained actor of the procedural face with `metadata` (its caches are whatever the
/// network gives: the export's layout, not the learning, is under test).
pub fn procedural_actor(
    set: &sinew_host::aim::TrainingSet,
    metadata: Vec<(String, String)>,
) -> Vec<u8> {
    use sinew_host::aim::bake::{BakeInput, bake};
    let config = sinew_host::aim::testing::small_aim_config(1);
    let device = sinew_host::training::backend::Backend::Flex
        .device(0)
        .unwrap();
    let net = sinew_host::aim::model::AimNet::new(&config, set.shapes.len(), &device);
    let triangles = set.template.triangles();
    let input = BakeInput {
        points: &set.template.positions,
        triangles: &triangles,
        jaw_pivot: set.jaw_pivot,
        normalisation: sinew_host::aim::model::normalisation(&set.template.positions),
        playback_only: true,
        metadata,
    };
    bake(&net, &input, &device).unwrap().0
}

/// The rig record of a rig in metres, +y up and facing +z, under no node transform, whose
/// skin mesh `mesh` of format `format` is the `vertices` training vertices themselves (nothing
/// welded) with `polygons` and no texture coordinates.
pub fn plain_record(
    format: &str,
    mesh: &str,
    vertices: usize,
    polygons: Vec<Vec<u32>>,
) -> sinew_host::rig::record::Record {
    sinew_host::rig::record::Record {
        format: format.into(),
        mesh: mesh.into(),
        units: "m".parse().unwrap(),
        up: "+y".parse().unwrap(),
        forward: "+z".parse().unwrap(),
        node_transform: sinew_host::io::rig::IDENTITY,
        placement: sinew_host::io::rig::IDENTITY,
        welded: (0..vertices as u32).collect(),
        polygons,
        uvs: Vec::new(),
        polygon_uvs: Vec::new(),
    }
}

/// The item named `name` in the list `list` (`nodes`, `meshes`, …) of a glTF document's JSON.
pub fn named<'a>(doc: &'a serde_json::Value, list: &str, name: &str) -> &'a serde_json::Value {
    &doc[list][named_index(doc, list, name)]
}

/// The index of the item named `name` in the list `list` of a glTF document's JSON.
pub fn named_index(doc: &serde_json::Value, list: &str, name: &str) -> usize {
    let items = doc[list].as_array();
    let at = items.and_then(|items| items.iter().position(|n| n["name"] == name));
    at.unwrap_or_else(|| panic!("no {list} item named {name}"))
}
