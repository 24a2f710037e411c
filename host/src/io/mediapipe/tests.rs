use super::*;

/// A line of `n` points, point `k` at (0.3 + k/2000, 0.4, -0.01 k/468), or as `swap` writes it.
fn line_with(n: usize, extra: &str, swap: (usize, &str)) -> String {
    let points: Vec<String> = (0..n)
        .map(|k| {
            if k == swap.0 {
                swap.1.to_owned()
            } else {
                format!(
                    "[{}, 0.4, {}]",
                    0.3 + k as f64 / 2000.0,
                    -0.01 * k as f64 / 468.0
                )
            }
        })
        .collect();
    format!(
        "{{\"width\": 640, \"height\": 480{extra}, \"landmarks\": [{}]}}",
        points.join(", ")
    )
}

fn line(n: usize, extra: &str) -> String {
    line_with(n, extra, (usize::MAX, ""))
}

/// The 468-point line with point `k` written as `p`.
fn with_point(k: usize, p: &str) -> String {
    line_with(468, "", (k, p))
}

fn err(text: &str) -> String {
    parse(Path::new("track.jsonl"), text)
        .unwrap_err()
        .to_string()
}

#[test]
fn reads_face_and_iris_tracks_and_lost_frames() {
    let text = format!(
        "{}\n\n{}\n{}\n",
        line(468, ", \"timestamp\": 0.5"),
        line(0, ""),
        line(478, ", \"frame\": 2")
    );
    let t = parse(Path::new("t.jsonl"), &text).unwrap();
    assert_eq!(t.size, [640, 480]);
    assert_eq!(t.frames.len(), 3);
    assert_eq!(t.frames[0].timestamp, Some(0.5));
    assert_eq!(t.frames[1].points, None, "no landmarks: no face");
    let irises = t.frames[2].points.as_ref().unwrap();
    assert_eq!(irises.len(), FACE_POINTS, "the irises are dropped");
    assert_eq!(irises[10], [0.305, 0.4, (-0.01 * 10.0 / 468.0) as f32]);
    assert_eq!(t.frames[0].points, t.frames[2].points);
}

#[test]
fn bad_tracks_name_file_row_and_point() {
    let good = line(468, "");
    let e = err(&format!("{good}\n{}", line(68, "")));
    assert!(e.contains("track.jsonl: row 2: 68 points"), "{e}");
    let e = err(&with_point(0, "[NaN, 0.4, 0]"));
    assert!(
        e.contains("row 1: point 0: x is not a finite number"),
        "{e}"
    );
    let e = err(&with_point(10, "[0.305, 0.4, Infinity]"));
    assert!(e.contains("point 10: z is not a finite number"), "{e}");
    let e = err(&format!("{good}\n{}", with_point(0, "[0.3, 1.3, 0]")));
    assert!(
        e.contains("row 2: point 0: y = 1.3 lies more than 0.25"),
        "{e}"
    );
    let e = err(&with_point(0, "[-0.26, 0.4, 0]"));
    assert!(e.contains("x = -0.26"), "{e}");
    // Within the margin is a face at the image's edge.
    assert!(parse(Path::new("t"), &with_point(0, "[-0.2, 0.4, 0]")).is_ok());
    let e = err(&with_point(0, "[0.3, 0.4]"));
    assert!(e.contains("row 1: point 0 has 2 values"), "{e}");
    let e = err(&format!("{good}\n{}", good.replace("480", "360")));
    assert!(
        e.contains("row 2: image 640×360, the first row's is 640×480"),
        "{e}"
    );
    let e = err(&good.replace("640", "0"));
    assert!(e.contains("row 1: image 0×480"), "{e}");
    let e = err("{\"width\": 640}");
    assert!(e.contains("row 1: not a MediaPipe frame"), "{e}");
    let e = err(&line(468, ", \"timestamp\": NaN"));
    assert!(e.contains("timestamp is not a finite number"), "{e}");
    let e = err("\n\n");
    assert!(e.contains("track.jsonl: no frames"), "{e}");
    let e = read(Path::new("/nonexistent/track.jsonl"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("/nonexistent/track.jsonl: cannot read"), "{e}");
}
