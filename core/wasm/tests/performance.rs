//! A fitted performance through the Rust layer under the WebAssembly module, on the host: the
//! golden fit `tests/data/fit-ict.sinew` played on `aim-ict.sinew` hashes as baked, as listed in
//! `fit-ict.hashes` and as the core's own `performance::play_frame_hash` computes; other actors are
//! refused. (The same through the JavaScript API: `core/wasm/test/performance.test.mjs`.)
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic
)]

use sinew_core::aim::AimActor;
use sinew_core::performance::{Performance as CorePerformance, play_frame_hash};
use sinew_wasm::{Model, Performance, frame_hash};

fn data(name: &str) -> Vec<u8> {
    let path = format!("{}/../../tests/data/{name}", env!("CARGO_MANIFEST_DIR"));
    std::fs::read(&path).unwrap_or_else(|e| panic!("{path}: {e}"))
}

/// The hashes of `fit-ict.hashes`, "frame hash" lines after a comment.
fn hash_list() -> Vec<u64> {
    let text = String::from_utf8(data("fit-ict.hashes")).unwrap();
    text.lines()
        .filter(|l| !l.starts_with('#') && !l.is_empty())
        .enumerate()
        .map(|(i, l)| {
            let (f, h) = l.split_once(' ').unwrap();
            assert_eq!(f.parse::<usize>().unwrap(), i);
            u64::from_str_radix(h, 16).unwrap()
        })
        .collect()
}

#[test]
fn the_golden_fit_hashes_as_baked_listed_and_as_the_core_computes() {
    let bytes = data("aim-ict.sinew");
    let model = Model::load(bytes.clone()).unwrap();
    let perf = Performance::load(data("fit-ict.sinew")).unwrap();
    perf.check(&model).unwrap();
    assert_eq!(perf.model_hash(), model.content_hash());
    assert_eq!(perf.shape_count(), model.shape_count());
    assert!(perf.has_hashes());
    let list = hash_list();
    assert_eq!(perf.frames(), list.len());

    let actor = AimActor::from_bytes(&bytes).unwrap();
    let perf_bytes = data("fit-ict.sinew");
    let core = CorePerformance::from_bytes(&perf_bytes).unwrap();
    assert_eq!(perf.is_local(), core.is_local());
    let mut scratch = vec![0.0; core.scratch_len()];
    let (mut p, mut n) = (
        vec![0.0; 3 * actor.vertex_count()],
        vec![0.0; 3 * actor.vertex_count()],
    );
    for (f, listed) in list.iter().enumerate() {
        let positions = perf.pose(&model, f).unwrap();
        let normals = model.normals(&positions).unwrap();
        let hash = frame_hash(&[&positions, &normals]);
        assert_eq!(hash, *listed, "frame {f} in fit-ict.hashes");
        assert_eq!(perf.expected(f).unwrap(), Some(hash), "frame {f} as baked");
        assert_eq!(perf.frame_hash(&model, f).unwrap(), hash, "frame {f}");
        let core_hash = play_frame_hash(&core, &actor, f, &mut scratch, &mut p, &mut n).unwrap();
        assert_eq!(hash, core_hash, "frame {f}: the core's play_frame_hash");
        assert_eq!(positions, p, "frame {f}: the core's positions");

        let frame = perf.frame(f).unwrap();
        let (head, jaw) = core.head_jaw(f).unwrap();
        assert_eq!((frame.head, frame.jaw), (head, jaw));
        assert_eq!(frame.coefficients.is_none(), perf.is_local());
        // A global frame is the actor posed with its row of coefficients.
        if let Some(w) = frame.coefficients {
            assert_eq!(model.pose(&head, &jaw, &w).unwrap(), positions);
        }
    }
    let past = perf.frames();
    for e in [
        perf.pose(&model, past).unwrap_err(),
        perf.frame(past).unwrap_err(),
        perf.expected(past).unwrap_err(),
    ] {
        assert_eq!(
            e.message(),
            format!("frame {past} is past the end of the performance ({past} frames)")
        );
    }
}

#[test]
fn another_actor_or_kind_is_refused() {
    let perf = Performance::load(data("fit-ict.sinew")).unwrap();
    let other = Model::load(data("aim-procedural.sinew")).unwrap();
    let expected = format!(
        "performance was fitted to the actor {:016x}, this model is {:016x}",
        perf.model_hash(),
        other.content_hash()
    );
    assert_eq!(perf.check(&other).unwrap_err().message(), expected);
    assert_eq!(perf.pose(&other, 0).unwrap_err().message(), expected);
    assert_eq!(perf.frame_hash(&other, 0).unwrap_err().message(), expected);
    let s2d = Model::load(data("s2d-ict.sinew")).unwrap();
    assert_eq!(
        perf.check(&s2d).unwrap_err().message(),
        "a performance plays on an AIM actor, this model is an S2D decoder"
    );
    let e = Performance::load(data("aim-ict.f32.replay.sinew")).unwrap_err();
    assert_eq!(
        e.message(),
        "the artefact is of another kind than expected (a replay, not a fitted performance)"
    );
    let e = Model::load(data("fit-ict.sinew")).unwrap_err();
    assert!(
        e.message().contains("(a fitted performance; a model is"),
        "{e}"
    );
    let bytes = data("fit-ict.sinew");
    let e = Performance::load(bytes[..200].to_vec()).unwrap_err();
    assert_eq!(
        e.to_string(),
        sinew_core::FormatError::LengthMismatch {
            header: bytes.len() as u32,
            actual: 200
        }
        .to_string()
    );
}
