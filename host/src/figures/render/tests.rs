//! Tests of [`super`] (render).

use super::*;

/// A UV sphere of radius 1 at the origin: `rings` latitude bands, `segs` longitude segments.
fn uv_sphere(rings: u32, segs: u32) -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
    let mut pos = vec![[0.0, 1.0, 0.0]];
    for r in 1..rings {
        let th = std::f32::consts::PI * r as f32 / rings as f32;
        for s in 0..segs {
            let ph = 2.0 * std::f32::consts::PI * s as f32 / segs as f32;
            pos.push([th.sin() * ph.cos(), th.cos(), th.sin() * ph.sin()]);
        }
    }
    pos.push([0.0, -1.0, 0.0]);
    let south = pos.len() as u32 - 1;
    let at = |r: u32, s: u32| 1 + (r - 1) * segs + s % segs;
    let mut tri = Vec::new();
    for s in 0..segs {
        tri.push([0, at(1, s + 1), at(1, s)]);
        tri.push([south, at(rings - 1, s), at(rings - 1, s + 1)]);
    }
    for r in 1..rings - 1 {
        for s in 0..segs {
            let (a, b, c, d) = (at(r, s), at(r, s + 1), at(r + 1, s), at(r + 1, s + 1));
            tri.push([a, b, d]);
            tri.push([a, d, c]);
        }
    }
    (pos, tri)
}

fn count_non_bg(img: &Image) -> usize {
    img.rgb.chunks(3).filter(|p| *p != BACKGROUND).count()
}

#[test]
fn single_triangle_covers_centre_not_corners() {
    let pos = [[-1.0, -1.0, 0.0], [1.0, -1.0, 0.0], [0.0, 1.0, 0.0]];
    let img = render(&pos, &[[0, 1, 2]], &[[255, 0, 0]; 3], &View::front(64, 64));
    let c = img.get(32, 36).unwrap();
    assert_ne!(c, BACKGROUND);
    // Facing the camera, so shading only scales the colour: red stays pure red.
    assert!(c[0] > 100 && c[1] == 0 && c[2] == 0, "{c:?}");
    for (x, y) in [(0, 0), (63, 0), (2, 2), (61, 2)] {
        assert_eq!(img.get(x, y).unwrap(), BACKGROUND, "corner ({x},{y})");
    }
    // Fitted with a 5% margin: the base spans the width minus the margins.
    assert_ne!(img.get(5, 58).unwrap(), BACKGROUND);
    assert_eq!(img.get(1, 62).unwrap(), BACKGROUND);
    // Opposite winding renders the same pixels (two-sided).
    let back = render(&pos, &[[0, 2, 1]], &[[255, 0, 0]; 3], &View::front(64, 64));
    assert_eq!(back, img);
}

#[test]
fn z_buffer_keeps_nearer_triangle_in_either_order() {
    // Two overlapping squares' worth of triangles; the green one is nearer (+z is toward the camera).
    let pos = [
        [-1.0, -1.0, 0.0],
        [1.0, -1.0, 0.0],
        [0.0, 1.0, 0.0],
        [-1.0, -1.0, 0.5],
        [1.0, -1.0, 0.5],
        [0.0, 1.0, 0.5],
    ];
    let mut col = vec![[255, 0, 0]; 3];
    col.extend([[0, 255, 0]; 3]);
    let v = View::front(40, 40);
    for tris in [[[0, 1, 2], [3, 4, 5]], [[3, 4, 5], [0, 1, 2]]] {
        let img = render(&pos, &tris, &col, &v);
        let c = img.get(20, 24).unwrap();
        assert!(c[1] > 100 && c[0] == 0, "{c:?}");
    }
    // Turned half way round, the red one is nearer.
    let back = View {
        yaw_deg: 180.0,
        ..v
    };
    let c = render(&pos, &[[0, 1, 2], [3, 4, 5]], &col, &back)
        .get(20, 24)
        .unwrap();
    assert!(c[0] > 100 && c[1] == 0, "{c:?}");
}

#[test]
fn bad_input_does_not_panic() {
    let pos = [[0.0, 0.0, 0.0], [f32::NAN, 1.0, 0.0], [1.0, 1.0, 0.0]];
    let v = View::front(16, 16);
    let img = render(&pos, &[[0, 1, 2], [0, 2, 7], [0, 0, 0]], &[], &v);
    assert_eq!(count_non_bg(&img), 0);
    assert_eq!(render(&[], &[], &[], &v), Image::new(16, 16, BACKGROUND));
    assert_eq!(render(&pos, &[], &[], &View::front(0, 5)).rgb.len(), 0);
    // Missing colours fall back to grey rather than failing.
    let ok = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0]];
    assert!(count_non_bg(&render(&ok, &[[0, 1, 2]], &[], &v)) > 20);
}

#[test]
fn sphere_fills_a_disc_and_is_shaded() {
    let (pos, tri) = uv_sphere(24, 48);
    let z: Vec<f32> = pos.iter().map(|p| p[2]).collect();
    let front = View::front(200, 200);
    let img = render(&pos, &tri, &heatmap(&z, -1.0, 1.0), &front);
    // Radius = 200 * (1 - 2 * 5%) / 2 = 90 px; the polygonal outline is slightly inside.
    let disc = std::f64::consts::PI * 90.0 * 90.0;
    let n = count_non_bg(&img) as f64;
    assert!((n / disc - 1.0).abs() < 0.03, "{n} vs {disc}");
    // Front (z = +1) is red-ish, and the upper left (lit) is brighter than the lower right.
    let c = img.get(100, 100).unwrap();
    assert!(c[0] > 120 && c[2] < 60, "{c:?}");
    let lum = |p: [u8; 3]| p.iter().map(|&v| u32::from(v)).sum::<u32>();
    assert!(lum(img.get(70, 70).unwrap()) > lum(img.get(130, 130).unwrap()));
    // Yawed 45°, the same sphere still fills the same disc but the red moves right.
    let yawed = View {
        yaw_deg: 45.0,
        ..front
    };
    let img45 = render(&pos, &tri, &heatmap(&z, -1.0, 1.0), &yawed);
    assert!((count_non_bg(&img45) as f64 / disc - 1.0).abs() < 0.03);
    // Shading darkens the turned front, so "red" means red dominates.
    let red = |p: [u8; 3]| p[0] > 100 && p[0] > 3 * p[1] && p[0] > 3 * p[2];
    assert!(red(img45.get(150, 100).unwrap()));
    assert!(!red(img45.get(40, 100).unwrap()));

    // Set SINEW_RENDER_OUT to a folder to keep these pictures for a look.
    if let Ok(dir) = std::env::var("SINEW_RENDER_OUT") {
        let dir = Path::new(&dir);
        let big = View::front(800, 800);
        let a = render_heatmap(&pos, &tri, &z, -1.0, 1.0, "z (cm)", "front", &big);
        let b = render_heatmap(
            &pos,
            &tri,
            &z,
            -1.0,
            1.0,
            "z (cm)",
            "yaw 45°",
            &View {
                yaw_deg: 45.0,
                ..big
            },
        );
        Image::hstack(&[a, b])
            .save_png(&dir.join("sphere.png"))
            .unwrap();
    }
}

use crate::io::data::data_dir;

#[test]
fn ict_face_front_view_is_symmetric_and_yaw_breaks_it() {
    let Some(dir) = data_dir() else { return };
    let path = dir.join("ict-facekit/generic_neutral_mesh.obj");
    let opts = tobj::LoadOptions {
        triangulate: true,
        ..Default::default()
    };
    let (models, _) = tobj::load_obj(&path, &opts).unwrap();
    let mut pos = Vec::new();
    let mut tri = Vec::new();
    for m in &models {
        let base = pos.len() as u32;
        pos.extend(m.mesh.positions.chunks(3).map(|p| [p[0], p[1], p[2]]));
        tri.extend(
            m.mesh
                .indices
                .chunks(3)
                .map(|t| [base + t[0], base + t[1], base + t[2]]),
        );
    }
    assert_eq!(pos.len(), 26_719);
    // The face and head only (vertices 0–9408, README), as the figures will show it.
    tri.retain(|t| t.iter().all(|&i| i < 9409));
    let cols = vec![[210, 190, 175]; pos.len()];
    let v = View::front(160, 160);
    let img = render(&pos, &tri, &cols, &v);
    let half = |img: &Image, right: bool| {
        (0..160)
            .flat_map(|y| (0..80).map(move |x| (x, y)))
            .filter(|&(x, y)| img.get(if right { 159 - x } else { x }, y) != Some(BACKGROUND))
            .count() as f64
    };
    let (l, r) = (half(&img, false), half(&img, true));
    // The ICT neutral head is left-right symmetric, so its front view is too.
    assert!((l - r).abs() / (l + r) < 0.02, "{l} vs {r}");
    // A tall, narrow head fitted to the frame height covers about a quarter of it.
    assert!((l + r) / (160.0 * 160.0) > 0.2, "head covers {}", l + r);
    // Mirrored pixel by pixel, nearly all coverage matches.
    let mismatched = (0..160)
        .flat_map(|y| (0..80).map(move |x| (x, y)))
        .filter(|&(x, y)| {
            (img.get(x, y) == Some(BACKGROUND)) != (img.get(159 - x, y) == Some(BACKGROUND))
        })
        .count() as f64;
    assert!(mismatched / (l + r) < 0.03, "{mismatched}");
    // Turned 45°, the silhouette is no longer symmetric.
    let yawed = render(&pos, &tri, &cols, &View { yaw_deg: 45.0, ..v });
    let (l, r) = (half(&yawed, false), half(&yawed, true));
    assert!((l - r).abs() / (l + r) > 0.05, "{l} vs {r}");
}

#[test]
fn heatmap_endpoints_clamping_and_nan() {
    let c = heatmap(&[0.0, 1.0, -5.0, 9.0, f32::NAN, 0.5], 0.0, 1.0);
    assert_eq!(c[0], [15, 25, 110]);
    assert_eq!(c[1], [205, 20, 20]);
    assert_eq!(c[2], c[0]);
    assert_eq!(c[3], c[1]);
    assert_eq!(c[4], NAN_COLOR);
    // Midway lies between cyan and yellow: greenish, bright.
    assert!(c[5][1] > 200, "{:?}", c[5]);
    // A degenerate range splits at lo instead of dividing by zero.
    assert_eq!(heatmap(&[1.0, 2.0], 1.0, 1.0), vec![c[0], c[1]]);
}

#[test]
fn png_round_trip() {
    let mut img = Image::new(7, 5, BACKGROUND);
    img.set(0, 0, [1, 2, 3]);
    img.set(6, 4, [250, 0, 9]);
    img.fill_rect(2, 1, 3, 2, [9, 99, 199]);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("a/b.png");
    img.save_png(&path).unwrap();
    let dec = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&path).unwrap()));
    let mut reader = dec.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    assert_eq!((info.width, info.height), (7, 5));
    assert_eq!(info.color_type, png::ColorType::Rgb);
    assert_eq!(&buf[..info.buffer_size()], &img.rgb[..]);
    // An empty picture is refused with the path in the message, not written.
    let err = Image::new(0, 3, BACKGROUND).save_png(&path).unwrap_err();
    assert!(matches!(&err, PngError::BadPicture { path: p, width: 0, .. } if *p == path));
    // A destination whose folder is a file cannot be written; the error names the PNG.
    let blocked = dir.path().join("a/b.png/c.png");
    let err = img.save_png(&blocked).unwrap_err();
    assert!(matches!(&err, PngError::Write { path: p, .. } if *p == blocked));
}

#[test]
fn text_draws_ink_within_its_box() {
    let mut img = Image::new(60, 20, BACKGROUND);
    img.text(2, 2, "Ab9%", [0, 0, 0], 2);
    let inked: Vec<(i64, i64)> = (0..20)
        .flat_map(|y| (0..60).map(move |x| (x, y)))
        .filter(|&(x, y)| img.get(x, y) == Some([0, 0, 0]))
        .collect();
    assert!(inked.len() > 40);
    let w = i64::from(text_width("Ab9%", 2));
    assert!(
        inked
            .iter()
            .all(|&(x, y)| (2..2 + w).contains(&x) && (2..2 + 16).contains(&y))
    );
    // A character the font lacks draws '?', not nothing.
    let mut a = Image::new(8, 10, BACKGROUND);
    let mut b = a.clone();
    a.text(0, 0, "€", [0, 0, 0], 1);
    b.text(0, 0, "?", [0, 0, 0], 1);
    assert_eq!(a, b);
}

#[test]
fn font_table_is_well_formed_and_complete() {
    for (ch, g) in FONT {
        let rows: Vec<&str> = if g.is_empty() {
            vec![]
        } else {
            g.split(' ').collect()
        };
        assert!(rows.len() <= 8, "{ch:?}");
        for r in rows {
            assert!(
                r.len() == 5 && r.bytes().all(|b| b == b'#' || b == b'.'),
                "{ch:?}: {r:?}"
            );
        }
        assert_eq!(FONT.iter().filter(|(k, _)| k == ch).count(), 1, "{ch:?}");
    }
    let needed = ('0'..='9')
        .chain('A'..='Z')
        .chain('a'..='z')
        .chain(".-:/%() ".chars());
    for ch in needed {
        assert!(FONT.iter().any(|(k, _)| *k == ch), "missing {ch:?}");
    }
}

#[test]
fn hstack_and_colorbar() {
    let a = Image::new(3, 2, [1, 1, 1]);
    let b = Image::new(2, 4, [2, 2, 2]);
    let s = Image::hstack(&[a, b]);
    assert_eq!((s.width, s.height), (5, 4));
    assert_eq!(s.get(0, 0), Some([1, 1, 1]));
    assert_eq!(s.get(0, 3), Some(BACKGROUND));
    assert_eq!(s.get(4, 3), Some([2, 2, 2]));
    assert_eq!(Image::hstack(&[]).rgb.len(), 0);

    let mut img = Image::new(300, 200, BACKGROUND);
    colorbar(&mut img, 0.0, 2.5, "mm");
    let strip = colorbar_width(300, 200, 0.0, 2.5, "mm") as i64;
    // The bar runs red at the top to dark blue at the bottom, inside the strip.
    let x = 300 - strip + 4 + 2;
    assert_eq!(img.get(x, 200 / 5), Some([205, 20, 20]));
    assert_eq!(img.get(x, 200 - 200 / 6), Some([15, 25, 110]));
    assert!(
        (0..300 - strip)
            .flat_map(|x| (0..200).map(move |y| (x, y)))
            .all(|(x, y)| img.get(x, y) == Some(BACKGROUND))
    );
    assert_eq!(format_value(1.5e-4), "1.5e-4");
    assert_eq!(format_value(2.5), "2.5");
    assert_eq!(format_value(1234.0), "1234");
    assert_eq!(format_value(0.0123), "0.0123");
    assert_eq!(format_value(1e5), "1e5");
}

#[test]
fn a_coarse_sphere_shades_smoothly() {
    // 12 × 24 facets: flat shading would step by tens of levels from facet to facet.
    let (pos, tri) = uv_sphere(12, 24);
    let img = render(&pos, &tri, &[[200, 200, 200]; 300], &View::front(200, 200));
    let lum = |x: i64, y: i64| {
        let p = img.get(x, y).unwrap();
        p.iter().map(|&v| i32::from(v)).sum::<i32>()
    };
    // Inside the disc (radius 90 px about the centre), away from the silhouette: neighbouring
    // pixels differ by a few levels at most.
    let mut worst = 0;
    for y in 30..170 {
        for x in 30..169 {
            let r = |x: i64| ((x as f64 - 100.0).powi(2) + (y as f64 - 100.0).powi(2)).sqrt();
            if r(x) < 75.0 && r(x + 1) < 75.0 {
                worst = worst.max((lum(x, y) - lum(x + 1, y)).abs());
            }
        }
    }
    assert!(
        worst <= 9,
        "neighbouring pixels differ by {worst} (sum of RGB)"
    );
}

#[test]
fn edges_are_anti_aliased() {
    let pos = [[-1.0, -1.0, 0.0], [1.0, -0.9, 0.0], [0.2, 1.0, 0.0]];
    let red = [255, 0, 0];
    let img = render(&pos, &[[0, 1, 2]], &[red; 3], &View::front(64, 64));
    // Facing the light's direction only partly, the inside is one shade of red; pixels the edges
    // cross mix it with the background, and only those.
    let inside = img.get(32, 40).unwrap();
    let mixed: Vec<[u8; 3]> = img
        .rgb
        .chunks(3)
        .map(|p| [p[0], p[1], p[2]])
        .filter(|&p| p != inside && p != BACKGROUND)
        .collect();
    assert!(mixed.len() > 40, "{} edge pixels", mixed.len());
    // Mixtures of red and the grey background: green and blue equal, red between the two.
    assert!(mixed.iter().all(|p| p[1] == p[2] && p[1] < BACKGROUND[1]));
    let total = count_non_bg(&img);
    assert!(mixed.len() * 4 < total, "{} of {total}", mixed.len());
}

#[test]
fn downsample_averages_blocks_and_vstack_stacks() {
    let mut img = Image::new(4, 2, [0, 0, 0]);
    img.set(0, 0, [255, 255, 255]);
    img.set(1, 1, [100, 0, 4]);
    img.set(3, 0, [7, 8, 9]);
    let d = img.downsample(2);
    assert_eq!((d.width, d.height), (2, 1));
    // (255 + 100) / 4 = 88.75, (255 + 0) / 4 = 63.75, (255 + 4) / 4 = 64.75: rounded.
    assert_eq!(d.get(0, 0), Some([89, 64, 65]));
    assert_eq!(d.get(1, 0), Some([2, 2, 2]));
    assert_eq!(img.downsample(1), img);

    let v = Image::vstack(&[Image::new(3, 1, [1, 1, 1]), Image::new(2, 2, [2, 2, 2])]);
    assert_eq!((v.width, v.height), (3, 3));
    assert_eq!(v.get(2, 0), Some([1, 1, 1]));
    assert_eq!(v.get(1, 2), Some([2, 2, 2]));
    assert_eq!(v.get(2, 2), Some(BACKGROUND));
}
