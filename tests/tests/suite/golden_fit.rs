//! Golden fitted performance: the golden ICT actor fitted with local coefficients to a 4-frame
//! synthetic performance, baked (`fit-ict.sinew`; the commands are in docs/FIT.md, "The golden
//! performance"). Playing it through the core evaluates F_W at all 4,705 template points per
//! frame; the frame hashes are pinned in `fit-ict.hashes`, must equal the ones baked into the
//! file, and the same performance runs on every firmware target.

use std::fmt::Write;

use sinew_core::aim::AimActor;
use sinew_core::performance::Performance;
use sinew_core::replay::ReplayError;
use sinew_host::fit::bake::{BakeError, play};
use sinew_tests::{check, golden_dir};

fn read(name: &str) -> Vec<u8> {
    let path = golden_dir().join(name);
    std::fs::read(&path).unwrap_or_else(|e| panic!("{}: golden file missing ({e})", path.display()))
}

#[test]
fn the_fitted_performance_plays_its_pinned_hashes() {
    let actor = read("aim-ict.sinew");
    let baked = read("fit-ict.sinew");
    let perf = Performance::from_bytes(&baked).unwrap();
    assert!(perf.is_local(), "the golden exercises F_W in the core");
    let (frames, hashes) = play(&actor, &baked).unwrap();
    assert_eq!(frames.len(), perf.frames());
    let mut text = String::from(
        "# fit-ict.sinew on aim-ict.sinew: per frame, the f32 hash of positions then normals\n",
    );
    for (f, h) in hashes.iter().enumerate() {
        assert_eq!(Some(*h), perf.expected(f), "frame {f}: baked hash differs");
        writeln!(text, "{f} {h:016x}").unwrap();
    }
    check("fit-ict.hashes", &text);
    // Local coefficients vary over the face: the frames are not one global blend.
    assert!(frames.windows(2).all(|w| w[0] != w[1]));
}

#[test]
fn a_performance_refuses_another_actor() {
    let other = read("aim-procedural.sinew");
    let baked = read("fit-ict.sinew");
    let perf = Performance::from_bytes(&baked).unwrap();
    let actor = AimActor::from_bytes(&other).unwrap();
    assert!(matches!(
        perf.check_actor(&other, &actor),
        Err(ReplayError::WrongModel { .. })
    ));
    // Posing with a mismatched actor is refused, not garbage.
    let mut scratch = vec![0.0; perf.scratch_len()];
    let mut out = vec![0.0; 3 * actor.vertex_count()];
    if actor.shape_count() != perf.shape_count() {
        assert!(perf.pose(&actor, 0, &mut scratch, &mut out).is_err());
    }
    let e = play(&other, &baked).unwrap_err();
    assert!(
        matches!(e, BakeError::OtherActor(ReplayError::WrongModel { .. })),
        "{e:?}"
    );
}
