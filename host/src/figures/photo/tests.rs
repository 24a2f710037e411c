use super::*;

fn camera() -> Camera {
    Camera {
        width: 64,
        height: 48,
        fx: 100.0,
        fy: 100.0,
        cx: 32.0,
        cy: 24.0,
        position: [0.0, 0.0, 50.0],
    }
}

/// A square of side 10 at z = 0 facing the camera, centred on (`x`, 0).
fn square(x: f32) -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
    (
        vec![
            [x - 5.0, -5.0, 0.0],
            [x + 5.0, -5.0, 0.0],
            [x + 5.0, 5.0, 0.0],
            [x - 5.0, 5.0, 0.0],
        ],
        vec![[0, 1, 2], [0, 2, 3]],
    )
}

#[test]
fn the_square_lands_where_the_camera_projects_it() {
    let (p, t) = square(0.0);
    let img = photograph(&p, &t, &[], &camera(), 1);
    // Its corners project 10 px from the centre: (22, 14) to (42, 34).
    let lit = img.get(32, 24).unwrap();
    assert_ne!(lit, BACKDROP);
    assert!(lit[0] > lit[2], "skin is warm: {lit:?}");
    let near_edge = img.get(23, 24).unwrap();
    assert!(
        near_edge.iter().zip(lit).all(|(&a, b)| a.abs_diff(b) < 16),
        "a flat face, lit alike: {near_edge:?} and {lit:?}"
    );
    for (x, y) in [(20, 24), (44, 24), (32, 12), (32, 36)] {
        assert_eq!(
            img.get(x, y),
            Some(BACKDROP),
            "({x}, {y}) is off the square"
        );
    }
    // Either winding draws.
    let flipped: Vec<[u32; 3]> = t.iter().map(|&[a, b, c]| [a, c, b]).collect();
    assert_eq!(photograph(&p, &flipped, &[], &camera(), 1), img);
}

#[test]
fn the_nearer_surface_wins_and_behind_the_camera_is_skipped() {
    let (mut p, mut t) = square(0.0);
    let (q, u) = square(0.0);
    p.extend(q.iter().map(|v| [v[0], v[1], 10.0]));
    t.extend(u.iter().map(|tri| tri.map(|i| i + 4)));
    let colours = [[0u8, 0, 255]; 4]
        .into_iter()
        .chain([[255u8, 0, 0]; 4])
        .collect::<Vec<_>>();
    let img = photograph(&p, &t, &colours, &camera(), 1);
    let c = img.get(32, 24).unwrap();
    assert!(
        c[0] > c[2],
        "the red square in front hides the blue one: {c:?}"
    );
    // A triangle reaching behind the camera draws nothing.
    let behind = vec![[0.0, 0.0, 0.0], [1.0, 0.0, 60.0], [0.0, 1.0, 0.0]];
    let img = photograph(&behind, &[[0, 1, 2]], &[], &camera(), 1);
    assert!(img.rgb.chunks(3).all(|c| c == BACKDROP));
    // Bad indices and non-finite corners are skipped, not a panic.
    let bad = vec![[f32::NAN, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
    let img = photograph(&bad, &[[0, 1, 2], [0, 1, 9]], &[], &camera(), 2);
    assert!(img.rgb.chunks(3).all(|c| c == BACKDROP));
}

#[test]
fn the_light_comes_from_the_upper_left() {
    // A square turned to face up-left (z rising to the lower right, so its normal leans up and
    // left) is brighter than one turned to face down-right.
    let turned = |sign: f32| -> Vec<[f32; 3]> {
        square(0.0)
            .0
            .iter()
            .map(|v| [v[0], v[1], sign * 0.5 * (v[1] - v[0])])
            .collect()
    };
    let t = square(0.0).1;
    let up_left = photograph(&turned(-1.0), &t, &[], &camera(), 1);
    let down_right = photograph(&turned(1.0), &t, &[], &camera(), 1);
    let y = |img: &Image| {
        img.get(32, 24)
            .unwrap()
            .iter()
            .map(|&v| u32::from(v))
            .sum::<u32>()
    };
    assert!(
        y(&up_left) > y(&down_right) + 30,
        "{} vs {}",
        y(&up_left),
        y(&down_right)
    );
}

#[test]
fn the_albedo_follows_the_landmarks() {
    // A grid of points with a synthetic landmark layout: the lips a square about (0, -3),
    // the eyes squares about (±2, 2), the brows lines at y = 3.5.
    let mut face = Vec::new();
    for y in -50..=50 {
        for x in -50..=50 {
            face.push([x as f32 * 0.1, y as f32 * 0.1, 0.0]);
        }
    }
    let at = |x: f32, y: f32| -> u32 {
        let (i, j) = (
            ((x * 10.0).round() + 50.0) as u32,
            ((y * 10.0).round() + 50.0) as u32,
        );
        j * 101 + i
    };
    let mut lm = vec![at(0.0, 0.0); 68];
    let ring = |cx: f32, cy: f32, r: f32, n: usize| -> Vec<u32> {
        (0..n)
            .map(|k| {
                let a = k as f32 / n as f32 * std::f32::consts::TAU;
                at(cx + r * a.cos(), cy + r * a.sin())
            })
            .collect()
    };
    lm[48..60].copy_from_slice(&ring(0.0, -3.0, 1.0, 12));
    lm[36..42].copy_from_slice(&ring(-2.0, 2.0, 0.6, 6));
    lm[42..48].copy_from_slice(&ring(2.0, 2.0, 0.6, 6));
    for k in 0..5 {
        lm[17 + k] = at(-3.0 + 0.5 * k as f32, 3.5);
        lm[22 + k] = at(1.0 + 0.5 * k as f32, 3.5);
    }
    let albedo = face_albedo(&face, &lm);
    assert_eq!(albedo[at(0.0, -3.0) as usize], LIPS);
    assert_eq!(albedo[at(-2.0, 2.0) as usize], EYES);
    assert_eq!(albedo[at(2.0, 2.0) as usize], EYES);
    assert_eq!(albedo[at(-2.0, 3.5) as usize], BROWS);
    assert_eq!(albedo[at(0.0, 0.0) as usize], SKIN);
    assert_eq!(albedo[at(4.0, -4.0) as usize], SKIN);
    // Too few landmarks, or one out of range: skin everywhere.
    assert!(face_albedo(&face, &lm[..60]).iter().all(|&c| c == SKIN));
    let mut bad = lm.clone();
    bad[3] = u32::MAX;
    assert!(face_albedo(&face, &bad).iter().all(|&c| c == SKIN));
}

#[test]
fn eyeballs_fill_the_eye_openings_behind_the_eyelids() {
    // The 68 landmarks of a flat face at z = 0: eyes rings of radius 1 about (±2, 2), the
    // chin at (0, -5), the nose's bridge at (0, 2).
    let mut lm = vec![[0.0f32, 0.0, 0.0]; 68];
    for (first, cx) in [(36, -2.0f32), (42, 2.0)] {
        for k in 0..6 {
            let a = std::f32::consts::PI - k as f32 / 6.0 * std::f32::consts::TAU;
            lm[first + k] = [cx + a.cos(), 2.0 + a.sin(), 0.0];
        }
    }
    lm[8] = [0.0, -5.0, 0.0];
    lm[27] = [0.0, 2.0, 0.0];
    let (mut positions, mut triangles, mut albedo) = (Vec::new(), Vec::new(), Vec::new());
    eyes::add_eyes(&mut positions, &mut triangles, &mut albedo, &lm);
    assert_eq!(albedo.len(), positions.len());
    assert!(!triangles.is_empty());
    // Every point of the eyeballs lies behind the eyelids.
    assert!(positions.iter().all(|p| p[2] < 0.0), "an eyeball pokes out");
    // Seen from the front: the pupil at each eye's centre, the iris about it, the sclera
    // further out; nothing between the eyes.
    let mut cam = camera();
    cam.position = [0.0, 2.0, 30.0];
    let img = photograph(&positions, &triangles, &albedo, &cam, 1);
    let px = |x: f32, y: f32| {
        let uv = cam.project([x, y, 0.0]).unwrap();
        img.get(uv[0] as i64, uv[1] as i64).unwrap()
    };
    let bright = |c: [u8; 3]| c.iter().map(|&v| u32::from(v)).sum::<u32>();
    for cx in [-2.0, 2.0] {
        let (pupil, iris, sclera) = (px(cx, 2.0), px(cx + 0.3, 2.0), px(cx + 0.8, 2.0));
        assert!(bright(pupil) < bright(iris), "{pupil:?} {iris:?}");
        assert!(bright(iris) < bright(sclera), "{iris:?} {sclera:?}");
        assert!(iris[0] > iris[2], "the iris is brown: {iris:?}");
    }
    assert_eq!(px(0.0, 2.0), BACKDROP);
    // Without 68 landmarks, nothing is added.
    let mut none = (Vec::new(), Vec::new(), Vec::new());
    eyes::add_eyes(&mut none.0, &mut none.1, &mut none.2, &lm[..60]);
    assert!(none.0.is_empty() && none.1.is_empty());
}

#[test]
fn the_frame_number_code_reads_back_and_leaves_the_face_alone() {
    let (positions, triangles) = square(0.0);
    let camera = Camera {
        width: 160,
        height: 120,
        cx: 80.0,
        cy: 60.0,
        ..camera()
    };
    let face = photograph(&positions, &triangles, &[], &camera, 1);
    for frame in [0, 1, 2, 37, 255, 1000, 65_535, 65_536 + 5] {
        let mut image = face.clone();
        stamp(&mut image, frame);
        assert_eq!(
            read_stamp(&image),
            Some(frame as u32 % 65_536),
            "frame {frame}"
        );
        // Only the top row of cells changes.
        let row = 3 * (STAMP_CELL * image.width) as usize;
        assert_eq!(image.rgb[row..], face.rgb[row..], "frame {frame}");
    }
    let mut small = Image::new(STAMP_BITS * STAMP_CELL - 1, 64, BACKDROP);
    let before = small.clone();
    stamp(&mut small, 7);
    assert_eq!(small, before);
    assert_eq!(read_stamp(&small), None);
}
