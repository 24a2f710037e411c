//! Retargeting (AIM Sec. 5.4, Fig. 8) on the golden actors: the golden fit of
//! `tests/data/aim-ict.sinew` played on itself and on `tests/data/aim-ict-b.sinew`, an actor of
//! another ICT-FaceKit identity baked on the same vertices (NOTICE, docs/FIT.md); its jaw-only and
//! soft-tissue-only parts; the `.sinew` points section in the core; `sinew retarget` and
//! `sinew data neutral` as a user runs them.

use std::path::PathBuf;

use crate::common::{repo, s, sinew};

use sinew_core::aim::AimActor;
use sinew_core::error::{BufferError, FormatError};
use sinew_core::performance::{self as perf, Performance};
use sinew_core::replay::ReplayError;
use sinew_host::fit::bake::play;
use sinew_host::fit::retarget::{
    Input, Part, Plan, RetargetError, create_output, retarget, retarget_planned, write_parts,
};
use sinew_host::io::container::{ContainerError, SinewWriter, read_actor};

fn golden(name: &str) -> PathBuf {
    PathBuf::from(repo(&format!("tests/data/{name}")))
}

fn read(name: &str) -> Vec<u8> {
    let path = golden(name);
    std::fs::read(&path).unwrap_or_else(|e| panic!("{}: golden file missing ({e})", path.display()))
}

/// [`retarget`] of golden files by name: the source actor, the target actor and the fit.
fn retarget_files(
    source: &str,
    target: &str,
    fit: &str,
    part: Part,
) -> Result<Vec<u8>, RetargetError> {
    let (source, target, fit) = (golden(source), golden(target), golden(fit));
    let bytes = |path: &PathBuf| std::fs::read(path).unwrap();
    let (s, t, f) = (bytes(&source), bytes(&target), bytes(&fit));
    retarget(
        Input {
            path: &source,
            bytes: &s,
        },
        Input {
            path: &target,
            bytes: &t,
        },
        Input {
            path: &fit,
            bytes: &f,
        },
        part,
    )
}

/// Per-vertex displacement of each frame from the rest shape, `[V, 3]` per frame.
fn displacements(frames: &[Vec<f32>], rest: &[f32]) -> Vec<Vec<f32>> {
    frames
        .iter()
        .map(|f| f.iter().zip(rest).map(|(a, b)| a - b).collect())
        .collect()
}

fn mean_norm(v: &[f32]) -> f64 {
    let n = v.len() / 3;
    v.chunks_exact(3)
        .map(|p| f64::from((p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt()))
        .sum::<f64>()
        / n as f64
}

#[test]
fn a_fit_retargeted_onto_its_own_actor_plays_its_own_bits() {
    let actor = read("aim-ict.sinew");
    let fit = read("fit-ict.sinew");
    let original = Performance::from_bytes(&fit).unwrap();
    let full = retarget_files(
        "aim-ict.sinew",
        "aim-ict.sinew",
        "fit-ict.sinew",
        Part::Full,
    )
    .unwrap();
    let p = Performance::from_bytes(&full).unwrap();
    assert_eq!(
        p.point_count(),
        Some(4705),
        "a local fit carries its points"
    );
    let (_, hashes) = play(&actor, &full).unwrap();
    for (f, h) in hashes.iter().enumerate() {
        assert_eq!(Some(*h), original.expected(f), "frame {f}");
        assert_eq!(Some(*h), p.expected(f), "frame {f}: baked hash");
    }
}

#[test]
fn the_parts_are_the_jaw_alone_and_the_soft_tissue_alone() {
    let bytes = read("aim-ict.sinew");
    let fit = read("fit-ict.sinew");
    let actor = AimActor::from_bytes(&bytes).unwrap();
    let original = Performance::from_bytes(&fit).unwrap();
    let (full, _) = play(
        &bytes,
        &retarget_files(
            "aim-ict.sinew",
            "aim-ict.sinew",
            "fit-ict.sinew",
            Part::Full,
        )
        .unwrap(),
    )
    .unwrap();
    let jaw_bytes =
        retarget_files("aim-ict.sinew", "aim-ict.sinew", "fit-ict.sinew", Part::Jaw).unwrap();
    let soft_bytes = retarget_files(
        "aim-ict.sinew",
        "aim-ict.sinew",
        "fit-ict.sinew",
        Part::Soft,
    )
    .unwrap();
    let (jaw, _) = play(&bytes, &jaw_bytes).unwrap();
    let (soft, _) = play(&bytes, &soft_bytes).unwrap();
    let soft_perf = Performance::from_bytes(&soft_bytes).unwrap();
    let zeros = vec![0.0; actor.shape_count()];
    for f in 0..original.frames() {
        // Jaw only: the fit's head and jaw with no correctives, exactly.
        let (head, j) = original.head_jaw(f).unwrap();
        let mut expected = vec![0.0; jaw[f].len()];
        actor
            .pose(
                &actor.pose_from_9d(&j, &head).unwrap(),
                &zeros,
                &mut expected,
            )
            .unwrap();
        assert_eq!(jaw[f], expected, "frame {f}: jaw only");
        // Soft tissue only: the same head, the jaw at rest, the fit's coefficients.
        let (soft_head, soft_jaw) = soft_perf.head_jaw(f).unwrap();
        assert_eq!(soft_head, head);
        assert_eq!(soft_jaw, [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0]);
        assert_ne!(soft[f], full[f], "frame {f}: the jaw moves in the fit");
        assert_ne!(jaw[f], full[f], "frame {f}: the correctives act in the fit");
    }
}

#[test]
fn a_fit_retargeted_to_another_identity_moves_as_the_source_did() {
    let source = read("aim-ict.sinew");
    let target = read("aim-ict-b.sinew");
    let fit = read("fit-ict.sinew");
    let src = AimActor::from_bytes(&source).unwrap();
    let dst = AimActor::from_bytes(&target).unwrap();
    let src_rest: Vec<f32> = src.rest().iter().collect();
    let dst_rest: Vec<f32> = dst.rest().iter().collect();
    // Another face: the rest shapes differ by millimetres, not by rounding.
    let identity = src_rest.iter().zip(&dst_rest).map(|(a, b)| a - b);
    assert!(mean_norm(&identity.collect::<Vec<_>>()) > 0.1, "cm");

    let baked = retarget_files(
        "aim-ict.sinew",
        "aim-ict-b.sinew",
        "fit-ict.sinew",
        Part::Full,
    )
    .unwrap();
    let (frames, hashes) = play(&target, &baked).unwrap();
    let p = Performance::from_bytes(&baked).unwrap();
    for (f, h) in hashes.iter().enumerate() {
        assert_eq!(Some(*h), p.expected(f));
    }
    let (source_frames, _) = play(&source, &fit).unwrap();
    let moved = displacements(&source_frames, &src_rest);
    let retargeted = displacements(&frames, &dst_rest);
    for (f, (a, b)) in moved.iter().zip(&retargeted).enumerate() {
        let gap: Vec<f32> = a.iter().zip(b).map(|(a, b)| a - b).collect();
        let (motion, gap) = (mean_norm(a), mean_norm(&gap));
        println!("frame {f}: source motion {motion:.4} cm, target differs by {gap:.4} cm");
        // The target performs the source's motion in its own anatomy: far closer to the
        // source's displacement than the displacement itself, yet not a copy of it.
        assert!(gap < 0.35 * motion, "frame {f}: {gap} vs {motion}");
        assert!(gap > 0.0);
    }
}

#[test]
fn retargeting_refuses_fits_of_another_actor_and_files_of_another_kind() {
    let e = retarget_files(
        "aim-procedural.sinew",
        "aim-ict.sinew",
        "fit-ict.sinew",
        Part::Full,
    )
    .unwrap_err();
    assert!(
        matches!(&e, RetargetError::OtherActor { fit, actor, source: ReplayError::WrongModel { .. } }
            if fit.ends_with("fit-ict.sinew") && actor.ends_with("aim-procedural.sinew")),
        "{e:?}"
    );
    // Files that are not what they should be are named.
    let e = retarget_files(
        "fit-ict.sinew",
        "aim-ict.sinew",
        "fit-ict.sinew",
        Part::Full,
    )
    .unwrap_err();
    assert!(
        matches!(&e, RetargetError::Read(ContainerError::NotAnActor { path, .. }) if path.ends_with("fit-ict.sinew")),
        "{e:?}"
    );
    let e = retarget_files(
        "aim-ict.sinew",
        "aim-ict.sinew",
        "aim-ict.sinew",
        Part::Full,
    )
    .unwrap_err();
    assert!(
        matches!(&e, RetargetError::NotAPerformance { path, .. } if path.ends_with("aim-ict.sinew")),
        "{e:?}"
    );
}

/// The golden actor `aim-ict.sinew` rewritten by `change` into `dir/name`; returns the path.
fn altered_actor(
    dir: &std::path::Path,
    name: &str,
    change: impl FnOnce(&AimActor<'_>, &mut SinewWriter),
) -> PathBuf {
    let bytes = read("aim-ict.sinew");
    let actor = AimActor::from_bytes(&bytes).unwrap();
    let mut w =
        SinewWriter::from_file(&sinew_core::SinewFile::from_bytes(&bytes).unwrap()).unwrap();
    change(&actor, &mut w);
    let path = dir.join(name);
    w.write(&path).unwrap();
    path
}

/// [`retarget`] of `aim-ict.sinew`'s golden fit onto the actor file at `target`.
fn retarget_onto(target: &std::path::Path) -> Result<Vec<u8>, RetargetError> {
    retarget_onto_part(target, Part::Full)
}

/// [`retarget`] of `part` of `aim-ict.sinew`'s golden fit onto the actor file at `target`.
fn retarget_onto_part(target: &std::path::Path, part: Part) -> Result<Vec<u8>, RetargetError> {
    let (source, fit) = (golden("aim-ict.sinew"), golden("fit-ict.sinew"));
    let (s, f) = (read("aim-ict.sinew"), read("fit-ict.sinew"));
    let t = read_actor(target)?;
    retarget(
        Input {
            path: &source,
            bytes: &s,
        },
        Input {
            path: target,
            bytes: &t,
        },
        Input {
            path: &fit,
            bytes: &f,
        },
        part,
    )
}

/// The golden actor with its vertices numbered backwards from `start` (a rotation of the
/// order), its triangles renumbered to match and its correctives in reverse order (names too);
/// playback-only, without the Q16 cache. Returns the path and, per new vertex, the old one.
fn reordered_actor(dir: &std::path::Path) -> (PathBuf, Vec<usize>) {
    let bytes = read("aim-ict.sinew");
    let file = sinew_core::SinewFile::from_bytes(&bytes).unwrap();
    let actor = AimActor::from_bytes(&bytes).unwrap();
    let (v, m) = (actor.vertex_count(), actor.shape_count());
    let old: Vec<usize> = (0..v).map(|i| (v + 1234 - i) % v).collect();
    let mut new = vec![0u32; v];
    for (n, &o) in old.iter().enumerate() {
        new[o] = n as u32;
    }
    let mut w = SinewWriter::from_file(&file).unwrap();
    w.remove_prefixed("q16.");
    w.flags(sinew_core::format::FLAG_PLAYBACK_ONLY);
    for section in file.sections() {
        let dims: Vec<usize> = section.dims().iter().map(|&d| d as usize).collect();
        let name = section.name();
        if name == "tpl.tri" {
            let tri: Vec<u32> = section
                .u32s()
                .unwrap()
                .iter()
                .map(|i| new[i as usize])
                .collect();
            w.remove_prefixed(name);
            w.u32s(name, &dims, &tri).unwrap();
        } else if dims.first() == Some(&v) && !name.starts_with("q16.") {
            let values: Vec<f32> = section.f32s().unwrap().iter().collect();
            let row = values.len() / v;
            let mut rows: Vec<f32> = old
                .iter()
                .flat_map(|&o| values[o * row..(o + 1) * row].iter().copied())
                .collect();
            if name == "cache.e" {
                // [V, M, 3]: the shapes reversed.
                for r in rows.chunks_exact_mut(row) {
                    let reversed: Vec<f32> = r.chunks_exact(3).rev().flatten().copied().collect();
                    r.copy_from_slice(&reversed);
                }
            }
            w.remove_prefixed(name);
            w.f32s(name, &dims, &rows).unwrap();
        }
    }
    let names = file.metadata().get("shapes").unwrap();
    let mut list: Vec<&str> = names.split(',').skip(1).collect();
    assert_eq!(list.len(), m);
    list.reverse();
    w.meta("shapes", format!("neutral,{}", list.join(",")));
    let path = dir.join("reordered.sinew");
    w.write(&path).unwrap();
    (path, old)
}

#[test]
fn a_fit_retargeted_onto_its_actor_in_another_vertex_and_shape_order_plays_the_same_face() {
    let dir = tempfile::tempdir().unwrap();
    let (target, old) = reordered_actor(dir.path());
    let source = read("aim-ict.sinew");
    let fit = read("fit-ict.sinew");
    let (frames, _) = play(&source, &fit).unwrap();
    let t = read_actor(&target).unwrap();
    let (source_path, fit_path) = (golden("aim-ict.sinew"), golden("fit-ict.sinew"));
    let (src, dst) = (
        Input {
            path: &source_path,
            bytes: &source,
        },
        Input {
            path: &target,
            bytes: &t,
        },
    );
    let plan = Plan::new(
        (src, &AimActor::from_bytes(&source).unwrap()),
        (dst, &AimActor::from_bytes(&t).unwrap()),
    )
    .unwrap();
    assert_eq!(plan.correspondence(), "template");
    assert!(plan.unmatched.is_empty(), "{:?}", plan.unmatched);
    for part in [Part::Full, Part::Jaw, Part::Soft] {
        let input = Input {
            path: &fit_path,
            bytes: &fit,
        };
        let baked = retarget_planned(src, dst, input, part, &plan).unwrap();
        let (played, _) = play(&t, &baked).unwrap();
        let (expected, _) = play(
            &source,
            &retarget_files("aim-ict.sinew", "aim-ict.sinew", "fit-ict.sinew", part).unwrap(),
        )
        .unwrap();
        assert_eq!(played.len(), frames.len());
        for (f, (got, want)) in played.iter().zip(&expected).enumerate() {
            // Vertex n of the target is vertex old[n] of the source, found through the face
            // template (registered onto each), not by its index.
            let worst = old
                .iter()
                .enumerate()
                .map(|(n, &o)| {
                    (0..3)
                        .map(|k| (got[3 * n + k] - want[3 * o + k]).powi(2))
                        .sum::<f32>()
                        .sqrt()
                })
                .fold(0.0f32, f32::max);
            assert!(
                worst < 1e-3,
                "{part:?} frame {f}: {worst} cm from the source's"
            );
        }
    }
}

#[test]
fn retargeting_refuses_an_actor_that_shares_no_shape_or_is_no_face() {
    let dir = tempfile::tempdir().unwrap();
    // The same vertices and triangles, one corrective fewer and no names in common: a
    // playback-only actor (no networks to agree with the count) without the Q16 cache.
    let fewer = altered_actor(dir.path(), "fewer.sinew", |actor, w| {
        let (v, m) = (actor.vertex_count(), actor.shape_count());
        let e: Vec<f32> = actor.correctives().iter().collect();
        let kept: Vec<f32> = e
            .chunks_exact(3 * m)
            .flat_map(|vertex| vertex[..3 * (m - 1)].iter().copied())
            .collect();
        let jaw: Vec<f32> = actor
            .learned_jaws()
            .map_or_else(Vec::new, |j| (0..m - 1).flat_map(|s| j.shape(s)).collect());
        w.remove_prefixed("cache.e");
        w.remove_prefixed("q16.");
        w.remove_prefixed("train.jaw");
        w.f32s("cache.e", &[v, m - 1, 3], &kept).unwrap();
        w.f32s("train.jaw", &[m - 1, 9], &jaw).unwrap();
        w.flags(sinew_core::format::FLAG_PLAYBACK_ONLY);
        let names: Vec<String> = (0..m - 1).map(|i| format!("custom{i}")).collect();
        w.meta("shapes", format!("neutral,{}", names.join(",")));
    });
    let m = AimActor::from_bytes(&read("aim-ict.sinew"))
        .unwrap()
        .shape_count();
    let e = retarget_onto(&fewer).unwrap_err();
    assert!(
        matches!(&e, RetargetError::NoSharedShapes { target_actor, source_shapes, target_shapes, .. }
            if target_actor.ends_with("fewer.sinew")
                && *source_shapes == m
                && *target_shapes == m - 1),
        "{e:?}"
    );
    assert!(e.to_string().contains("no name in common"), "{e}");
    // Another topology that is no face (every vertex on one point): nothing to register onto.
    let flat = altered_actor(dir.path(), "flat.sinew", |actor, w| {
        let v = actor.vertex_count();
        let tri: Vec<u32> = actor.triangles().indices().iter().collect();
        let turned: Vec<u32> = tri
            .chunks_exact(3)
            .flat_map(|t| [t[0], t[2], t[1]])
            .collect();
        let flat = vec![1.0f32; 3 * v];
        w.remove_prefixed("tpl.");
        w.remove_prefixed("q16.");
        w.f32s("tpl.pos", &[v, 3], &flat).unwrap();
        w.u32s("tpl.tri", &[tri.len() / 3, 3], &turned).unwrap();
        w.flags(sinew_core::format::FLAG_PLAYBACK_ONLY);
    });
    let e = retarget_onto(&flat).unwrap_err();
    assert!(
        matches!(&e, RetargetError::Correspondence { path, .. } if path.ends_with("flat.sinew")),
        "{e:?}"
    );
    assert!(e.to_string().contains("flat.sinew"), "{e}");
}

#[test]
fn writing_the_parts_names_a_missing_fit_and_an_output_that_cannot_be_a_folder() {
    let dir = tempfile::tempdir().unwrap();
    let actor_path = golden("aim-ict.sinew");
    let actor = read_actor(&actor_path).unwrap();
    let input = Input {
        path: &actor_path,
        bytes: &actor,
    };
    let missing = dir.path().join("missing.sinew");
    let e = write_parts(input, input, &missing, dir.path(), None).unwrap_err();
    assert!(
        matches!(&e, RetargetError::Read(ContainerError::Read { path, .. }) if *path == missing),
        "{e:?}"
    );
    let file = dir.path().join("a-file");
    std::fs::write(&file, b"not a folder").unwrap();
    let e = create_output(&file.join("out")).unwrap_err();
    assert!(
        matches!(&e, RetargetError::CreateFolder(c) if c.path.ends_with("a-file/out")),
        "{e:?}"
    );
    let e = read_actor(&golden("fit-ict.sinew")).unwrap_err();
    assert!(matches!(e, ContainerError::NotAnActor { .. }), "{e:?}");
}

#[test]
fn the_points_section_is_checked_against_the_actor_and_the_coefficients() {
    let bytes = read("aim-ict.sinew");
    let actor = AimActor::from_bytes(&bytes).unwrap();
    let full = retarget_files(
        "aim-ict.sinew",
        "aim-ict.sinew",
        "fit-ict.sinew",
        Part::Full,
    )
    .unwrap();
    // Too few points for the actor.
    let file = sinew_core::SinewFile::from_bytes(&full).unwrap();
    let mut w = SinewWriter::from_file(&file).unwrap();
    w.remove_prefixed(perf::POINTS);
    w.f32s(perf::POINTS, &[2, 3], &[0.0; 6]).unwrap();
    let short = w.to_bytes().unwrap();
    let p = Performance::from_bytes(&short).unwrap();
    assert!(matches!(
        p.check_actor(&bytes, &actor),
        Err(ReplayError::PointCount {
            performance: 2,
            actor: 4705
        })
    ));
    let mut scratch = vec![0.0; p.scratch_len()];
    let mut out = vec![0.0; 3 * actor.vertex_count()];
    assert_eq!(
        p.pose(&actor, 0, &mut scratch, &mut out),
        Err(BufferError::Input.into())
    );
    // Points beside global coefficients mean nothing and are refused.
    let jaw = retarget_files("aim-ict.sinew", "aim-ict.sinew", "fit-ict.sinew", Part::Jaw).unwrap();
    let mut w = SinewWriter::from_file(&sinew_core::SinewFile::from_bytes(&jaw).unwrap()).unwrap();
    w.f32s(perf::POINTS, &[4705, 3], &vec![0.0; 3 * 4705])
        .unwrap();
    assert_eq!(
        Performance::from_bytes(&w.to_bytes().unwrap()),
        Err(FormatError::incompatible_shapes(perf::POINTS))
    );
}

#[test]
fn sinew_retarget_writes_the_three_parts_that_play_reproduces() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("retarget");
    let target = golden("aim-ict-b.sinew");
    let run = sinew(&[
        "retarget",
        "--source",
        s(&golden("aim-ict.sinew")),
        "--target",
        s(&target),
        "--fit",
        s(&golden("fit-ict.sinew")),
        "--out",
        s(&out),
        "--frames",
        "0,3",
    ]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("report.json")).unwrap()).unwrap();
    assert_eq!(report["frames"], 4);
    assert_eq!(report["strip_frames"], serde_json::json!([0, 3]));
    assert!(report["seconds_per_frame"].as_f64().unwrap() > 0.0);
    let strip = std::fs::read(out.join("strip.png")).unwrap();
    assert_eq!(&strip[1..4], b"PNG");
    for part in ["target", "jaw", "soft"] {
        let played = dir.path().join(format!("played-{part}"));
        let p = sinew(&[
            "play",
            "--model",
            s(&target),
            "--performance",
            s(&out.join(format!("{part}.sinew"))),
            "--out",
            s(&played),
        ]);
        assert!(p.status.success(), "{}", String::from_utf8_lossy(&p.stderr));
        for f in 0..4 {
            let name = format!("frame_{f:05}.obj");
            assert_eq!(
                std::fs::read(played.join(&name)).unwrap(),
                std::fs::read(out.join(part).join(&name)).unwrap(),
                "{part}/{name}"
            );
        }
    }
    // No shape in common: refused, naming both files.
    let run = sinew(&[
        "retarget",
        "--source",
        s(&golden("aim-ict.sinew")),
        "--target",
        s(&golden("aim-procedural.sinew")),
        "--fit",
        s(&golden("fit-ict.sinew")),
        "--out",
        s(&dir.path().join("bad")),
    ]);
    let e = String::from_utf8_lossy(&run.stderr);
    assert!(!run.status.success());
    assert!(
        e.contains("aim-procedural.sinew") && e.contains("no name in common"),
        "{e}"
    );
    // A strip frame past the end.
    let run = sinew(&[
        "retarget",
        "--source",
        s(&golden("aim-ict.sinew")),
        "--target",
        s(&target),
        "--fit",
        s(&golden("fit-ict.sinew")),
        "--out",
        s(&dir.path().join("late")),
        "--frames",
        "9",
    ]);
    assert!(!run.status.success());
    assert!(String::from_utf8_lossy(&run.stderr).contains("strip frame 9"));
}

#[test]
fn data_neutral_gives_the_golden_template_and_another_identity_on_its_vertices() {
    let Some(root) = sinew_host::io::data::data_dir() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let kit = root.join("ict-facekit");
    let like = golden("aim-ict.sinew");
    let generic = dir.path().join("generic.obj");
    let other = dir.path().join("other.obj");
    for (out, identity) in [(&generic, None), (&other, Some("1.5,-1.2,1,0.8"))] {
        let mut args = vec!["data", "neutral", "--data", s(&kit), "--like", s(&like)];
        if let Some(w) = identity {
            args.extend(["--identity", w]);
        }
        args.extend(["--out", s(out)]);
        let run = sinew(&args);
        assert!(
            run.status.success(),
            "{}",
            String::from_utf8_lossy(&run.stderr)
        );
    }
    let bytes = read("aim-ict.sinew");
    let actor = AimActor::from_bytes(&bytes).unwrap();
    let template: Vec<f32> = actor.template().iter().collect();
    let generic = sinew_host::io::mesh::Mesh::read(&generic).unwrap();
    let flat: Vec<f32> = generic.positions.iter().flatten().copied().collect();
    assert_eq!(
        flat, template,
        "the golden actor's own template, bit for bit"
    );
    let other = sinew_host::io::mesh::Mesh::read(&other).unwrap();
    assert_eq!(other.polygons, generic.polygons);
    assert_ne!(other.positions, generic.positions);
}

#[test]
fn sinew_retarget_fits_the_source_to_a_performance_first() {
    let Some(root) = sinew_host::io::data::data_dir() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let perf = dir.path().join("perf");
    let source = golden("aim-ict.sinew");
    let run = sinew(&[
        "data",
        "performance",
        "--data",
        s(&root.join("ict-facekit")),
        "--actor",
        s(&source),
        "--frames",
        "2",
        "--out",
        s(&perf),
    ]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let out = dir.path().join("retarget");
    let run = sinew(&[
        "retarget",
        "--source",
        s(&source),
        "--target",
        s(&golden("aim-ict-b.sinew")),
        "--performance",
        s(&perf),
        "--out",
        s(&out),
        "--global",
        "--iterations",
        "20",
        "--hidden",
        "16",
        "--code",
        "4",
    ]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("report.json")).unwrap()).unwrap();
    assert_eq!(report["frames"], 2);
    assert!(report["fit_seconds_per_frame"].as_f64().unwrap() > 0.0);
    assert!(report["fit_mean_error_mm"].as_f64().unwrap() > 0.0);
    // The source's fit is kept, and what the target plays is that fit.
    let fit = std::fs::read(out.join("source.sinew")).unwrap();
    let played = std::fs::read(out.join("target.sinew")).unwrap();
    let (f, p) = (
        Performance::from_bytes(&fit).unwrap(),
        Performance::from_bytes(&played).unwrap(),
    );
    assert!(!p.is_local());
    for i in 0..2 {
        assert_eq!(f.head_jaw(i), p.head_jaw(i));
    }
    assert!(out.join("target/frame_00001.obj").exists());
}
