//! Loss-curve plots: training losses against iteration, on a linear or log10 y axis, drawn with
//! [`crate::figures::render::Image`] (its lines and bitmap font), so they need nothing beyond `png`.

use crate::figures::render::{Image, LINE_HEIGHT, format_value, text_scale, text_width};

/// Series colours, in order (the widely used "tab10" palette: distinct, and readable for the
/// common colour-vision deficiencies). Series past the tenth reuse them.
pub const PALETTE: [[u8; 3]; 10] = [
    [31, 119, 180],
    [255, 127, 14],
    [44, 160, 44],
    [214, 39, 40],
    [148, 103, 189],
    [140, 86, 75],
    [227, 119, 194],
    [127, 127, 127],
    [188, 189, 34],
    [23, 190, 207],
];

const WHITE: [u8; 3] = [255, 255, 255];
const INK: [u8; 3] = [30, 30, 30];
const GRID: [u8; 3] = [228, 228, 228];

/// A line plot of `series` (name, points as (iteration, loss)) titled `title`, `width` × `height`
/// pixels: axes with tick labels, light grid lines, and a legend at the top right of the plot
/// area with each series' [`PALETTE`] colour. With `log_y` the y axis is log10 and points with a
/// non-positive loss are left out; non-finite points are always left out. A left-out point
/// breaks its line there rather than bridging the gap. Points are joined in the order given.
/// Empty input gives empty axes; no input makes it panic.
pub fn loss_curves(
    series: &[(&str, &[(f64, f64)])],
    title: &str,
    log_y: bool,
    width: u32,
    height: u32,
) -> Image {
    let y_caption = if log_y { "loss (log scale)" } else { "loss" };
    line_plot(series, title, "iteration", y_caption, log_y, width, height)
}

/// [`loss_curves`] with other axis captions (e.g. a cumulative error distribution).
pub fn line_plot(
    series: &[(&str, &[(f64, f64)])],
    title: &str,
    x_caption: &str,
    y_caption: &str,
    log_y: bool,
    width: u32,
    height: u32,
) -> Image {
    let mut img = Image::new(width, height, WHITE);
    let fr = layout(series, title, log_y, width, height);
    let s = fr.scale;
    let lh = i64::from(LINE_HEIGHT * s);
    let cap = i64::from(7 * s);
    let tick = i64::from(4 * s);

    if !title.is_empty() {
        let tw = i64::from(text_width(title, s));
        img.text((i64::from(width) - tw) / 2, fr.pad, title, INK, s);
    }
    if !fr.drawable() {
        return img;
    }
    let (l, t, r, b) = (fr.left, fr.top, fr.right, fr.bottom);

    for &(v, _) in &fr.x_ticks {
        let (x, _) = fr.px(v, fr.y_lo);
        img.fill_rect(x.round() as i64, t, 1, b - t, GRID);
    }
    for &(v, _) in &fr.y_ticks {
        let (_, y) = fr.px(fr.x_lo, v);
        img.fill_rect(l, y.round() as i64, r - l, 1, GRID);
    }

    let thickness = s;
    for (i, (_, pts)) in series.iter().enumerate() {
        let color = PALETTE[i % PALETTE.len()];
        let mapped: Vec<Option<(f32, f32)>> = pts
            .iter()
            .map(|&(x, y)| match (x.is_finite(), fr.transform(y)) {
                (true, Some(ty)) => Some(fr.px(x, ty)),
                _ => None,
            })
            .collect();
        for (k, p) in mapped.iter().enumerate() {
            let Some((x, y)) = *p else { continue };
            let prev = if k > 0 { mapped[k - 1] } else { None };
            let next = mapped.get(k + 1).copied().flatten();
            if let Some((px, py)) = prev {
                img.line(px, py, x, y, color, thickness);
            } else if next.is_none() {
                // An isolated point has no segment to show it, so it gets a dot.
                let d = i64::from(3 * s);
                img.fill_rect(
                    x.round() as i64 - d / 2,
                    y.round() as i64 - d / 2,
                    d,
                    d,
                    color,
                );
            }
        }
    }

    img.stroke_rect(l, t, r - l + 1, b - t + 1, INK);
    for &(v, ref label) in &fr.x_ticks {
        let x = fr.px(v, fr.y_lo).0.round() as i64;
        img.fill_rect(x, b + 1, 1, tick, INK);
        let lw = i64::from(text_width(label, s));
        img.text(x - lw / 2, b + tick + 2 * i64::from(s), label, INK, s);
    }
    for &(v, ref label) in &fr.y_ticks {
        let y = fr.px(fr.x_lo, v).1.round() as i64;
        img.fill_rect(l - tick, y, tick, 1, INK);
        let lw = i64::from(text_width(label, s));
        img.text(l - tick - i64::from(2 * s) - lw, y - cap / 2, label, INK, s);
    }
    for &v in &fr.y_minor {
        let y = fr.px(fr.x_lo, v).1.round() as i64;
        img.fill_rect(l - tick / 2, y, tick / 2, 1, INK);
    }
    let xc = x_caption;
    let xw = i64::from(text_width(xc, s));
    img.text(
        (l + r - xw) / 2,
        b + tick + 2 * i64::from(s) + lh,
        xc,
        INK,
        s,
    );
    let yc = y_caption;
    img.text(fr.pad, t - lh - i64::from(s), yc, INK, s);

    draw_legend(&mut img, series, &fr);
    img
}

/// The legend: a white box at the top right of the plot area with one line per series, a short
/// stroke of its colour and its name.
fn draw_legend(img: &mut Image, series: &[(&str, &[(f64, f64)])], fr: &Frame) {
    if series.is_empty() {
        return;
    }
    let s = fr.scale;
    let k = i64::from(s);
    let lh = i64::from(LINE_HEIGHT * s);
    let swatch = 14 * k;
    let inner = 4 * k;
    let name_w = series
        .iter()
        .map(|(n, _)| i64::from(text_width(n, s)))
        .max()
        .unwrap_or(0);
    let bw = inner + swatch + inner + name_w + inner;
    let bh = inner * 2 + lh * series.len() as i64 - 2 * k;
    let bx = fr.right - 6 * k - bw;
    let by = fr.top + 6 * k;
    img.fill_rect(bx, by, bw, bh, WHITE);
    img.stroke_rect(bx, by, bw, bh, [170, 170, 170]);
    for (i, (name, _)) in series.iter().enumerate() {
        let y = by + inner + lh * i as i64;
        let color = PALETTE[i % PALETTE.len()];
        img.fill_rect(bx + inner, y + 3 * k, swatch, 2 * k, color);
        img.text(bx + inner + swatch + inner, y, name, INK, s);
    }
}

/// Where everything goes: the plot area in pixels (inclusive edges), the data ranges it shows
/// (y in plotted units: log10 of the loss when `log_y`), and the ticks with their labels.
#[derive(Debug)]
struct Frame {
    scale: u32,
    pad: i64,
    left: i64,
    top: i64,
    right: i64,
    bottom: i64,
    x_lo: f64,
    x_hi: f64,
    y_lo: f64,
    y_hi: f64,
    log_y: bool,
    x_ticks: Vec<(f64, String)>,
    y_ticks: Vec<(f64, String)>,
    /// Log axis only: positions of 2·10^k … 9·10^k, marked with short ticks.
    y_minor: Vec<f64>,
}

impl Frame {
    /// The plotted y of a loss, or `None` if it cannot be plotted.
    fn transform(&self, y: f64) -> Option<f64> {
        plotted_y(y, self.log_y)
    }

    /// Pixel position of data point (x, plotted y).
    fn px(&self, x: f64, y: f64) -> (f32, f32) {
        let fx = (x - self.x_lo) / (self.x_hi - self.x_lo);
        let fy = (y - self.y_lo) / (self.y_hi - self.y_lo);
        let w = (self.right - self.left) as f64;
        let h = (self.bottom - self.top) as f64;
        (
            (self.left as f64 + fx * w) as f32,
            (self.bottom as f64 - fy * h) as f32,
        )
    }

    /// Whether the plot area is big enough to draw into.
    fn drawable(&self) -> bool {
        self.right - self.left >= 4 && self.bottom - self.top >= 4
    }
}

fn plotted_y(y: f64, log_y: bool) -> Option<f64> {
    if !y.is_finite() {
        None
    } else if log_y {
        (y > 0.0).then(|| y.log10())
    } else {
        Some(y)
    }
}

fn layout(
    series: &[(&str, &[(f64, f64)])],
    title: &str,
    log_y: bool,
    width: u32,
    height: u32,
) -> Frame {
    // Data ranges over the plottable points.
    let (mut x_lo, mut x_hi) = (f64::INFINITY, f64::NEG_INFINITY);
    let (mut y_lo, mut y_hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for (_, pts) in series {
        for &(x, y) in pts.iter() {
            if let (true, Some(ty)) = (x.is_finite(), plotted_y(y, log_y)) {
                x_lo = x_lo.min(x);
                x_hi = x_hi.max(x);
                y_lo = y_lo.min(ty);
                y_hi = y_hi.max(ty);
            }
        }
    }
    if x_lo > x_hi {
        (x_lo, x_hi) = (0.0, 1.0);
        (y_lo, y_hi) = if log_y { (-1.0, 0.0) } else { (0.0, 1.0) };
    }
    if x_hi - x_lo <= 0.0 {
        (x_lo, x_hi) = (x_lo - 1.0, x_hi + 1.0);
    }
    if y_hi - y_lo <= 0.0 {
        // A flat curve sits mid-height: half a decade either way on a log axis, 10% linear.
        let d = if log_y || y_lo == 0.0 {
            0.5
        } else {
            y_lo.abs() * 0.1
        };
        (y_lo, y_hi) = (y_lo - d, y_hi + d);
    } else {
        // A little headroom so the extreme points do not sit on the frame.
        let d = (y_hi - y_lo) * 0.05;
        (y_lo, y_hi) = (y_lo - d, y_hi + d);
    }

    let x_ticks = linear_ticks(x_lo, x_hi, 6);
    let (y_ticks, y_minor) = if log_y {
        log_ticks(y_lo, y_hi)
    } else {
        (linear_ticks(y_lo, y_hi, 6), Vec::new())
    };

    let scale = text_scale(width, height);
    let k = i64::from(scale);
    let pad = 6 * k;
    let lh = i64::from(LINE_HEIGHT * scale);
    let tick = 4 * k;
    let y_label_w = y_ticks
        .iter()
        .map(|(_, l)| i64::from(text_width(l, scale)))
        .max()
        .unwrap_or(0);
    let x_label_w = x_ticks
        .iter()
        .map(|(_, l)| i64::from(text_width(l, scale)))
        .max()
        .unwrap_or(0);
    let title_h = if title.is_empty() { 0 } else { lh + pad };
    Frame {
        scale,
        pad,
        left: pad + y_label_w + 2 * k + tick,
        top: pad + title_h + lh + 2 * k,
        right: i64::from(width) - pad - x_label_w / 2,
        bottom: i64::from(height) - (tick + 2 * k + 2 * lh + pad),
        x_lo,
        x_hi,
        y_lo,
        y_hi,
        log_y,
        x_ticks,
        y_ticks,
        y_minor,
    }
}

/// "Nice" ticks (1, 2 or 5 × 10^k apart, about `target` of them) covering [lo, hi], labelled with
/// as many decimals as the spacing needs.
fn linear_ticks(lo: f64, hi: f64, target: u32) -> Vec<(f64, String)> {
    let span = hi - lo;
    if !(span > 0.0 && span.is_finite()) {
        return Vec::new();
    }
    let raw = span / f64::from(target.max(1));
    let mag = 10f64.powf(raw.log10().floor());
    let norm = raw / mag;
    let step = mag
        * if norm < 1.5 {
            1.0
        } else if norm < 3.0 {
            2.0
        } else if norm < 7.0 {
            5.0
        } else {
            10.0
        };
    let first = (lo / step).ceil() as i64;
    let last = (hi / step).floor() as i64;
    let decimals = (-(step.log10() + 1e-9).floor()).max(0.0) as usize;
    (first..=last)
        .take(64)
        .map(|i| {
            let v = i as f64 * step;
            let label = if i == 0 {
                "0".to_string()
            } else if decimals > 4 || v.abs() >= 1e6 {
                format_value(v)
            } else {
                format!("{v:.decimals$}")
            };
            (v, label)
        })
        .collect()
}

/// Ticks for a log10 axis showing plotted values [lo, hi]: whole decades when the range spans
/// at least one (thinned to about six, with minor ticks at 2…9 when every decade is labelled),
/// otherwise nice linear values of the loss itself placed at their logarithms.
fn log_ticks(lo: f64, hi: f64) -> (Vec<(f64, String)>, Vec<f64>) {
    let (kmin, kmax) = (lo.ceil() as i64, hi.floor() as i64);
    if kmax - kmin < 1 {
        let ticks = linear_ticks(10f64.powf(lo), 10f64.powf(hi), 5)
            .into_iter()
            .filter(|(v, _)| *v > 0.0)
            .map(|(v, l)| (v.log10(), l))
            .collect();
        return (ticks, Vec::new());
    }
    let step = ((kmax - kmin) as f64 / 6.0).ceil().max(1.0) as i64;
    let ticks = (kmin..=kmax)
        .filter(|k| k.rem_euclid(step) == 0)
        .map(|k| {
            let label = match k {
                -2 => "0.01".to_string(),
                -1 => "0.1".to_string(),
                0 => "1".to_string(),
                1 => "10".to_string(),
                2 => "100".to_string(),
                _ => format!("1e{k}"),
            };
            (k as f64, label)
        })
        .collect();
    let mut minor = Vec::new();
    if step == 1 {
        for k in lo.floor() as i64..=hi.ceil() as i64 {
            for m in 2..=9 {
                let v = k as f64 + f64::from(m).log10();
                if v > lo && v < hi {
                    minor.push(v);
                }
            }
        }
    }
    (ticks, minor)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Whether a pixel within `r` of (x, y) has exactly `color`.
    fn near(img: &Image, x: f32, y: f32, r: i64, color: [u8; 3]) -> bool {
        let (cx, cy) = (x.round() as i64, y.round() as i64);
        (-r..=r).any(|dy| (-r..=r).any(|dx| img.get(cx + dx, cy + dy) == Some(color)))
    }

    #[test]
    fn lines_drawn_in_plot_area_in_series_colours() {
        let a: Vec<(f64, f64)> = (0..=10)
            .map(|i| (f64::from(i) * 10.0, 1.0 - f64::from(i) * 0.09))
            .collect();
        let b: Vec<(f64, f64)> = (0..=10).map(|i| (f64::from(i) * 10.0, 0.4)).collect();
        let series: [(&str, &[(f64, f64)]); 2] = [("train", &a), ("validation", &b)];
        let (w, h) = (400, 300);
        let img = loss_curves(&series, "Loss", false, w, h);
        let fr = layout(&series, "Loss", false, w, h);
        for x in [5.0, 25.0, 45.0] {
            let (px, py) = fr.px(x, 1.0 - x * 0.009);
            assert!(near(&img, px, py, 1, PALETTE[0]), "train at {x}");
            let (px, py) = fr.px(x, 0.4);
            assert!(near(&img, px, py, 1, PALETTE[1]), "validation at {x}");
        }
        // Series colours appear only inside the plot area (lines and legend).
        for y in 0..i64::from(h) {
            for x in 0..i64::from(w) {
                let c = img.get(x, y).unwrap();
                if c == PALETTE[0] || c == PALETTE[1] {
                    assert!(
                        (fr.left - 1..=fr.right + 1).contains(&x)
                            && (fr.top - 1..=fr.bottom + 1).contains(&y),
                        "colour outside the plot at ({x},{y})"
                    );
                }
            }
        }
        // Ticks: nice values on both axes, and the title is drawn.
        let labels: Vec<&str> = fr.x_ticks.iter().map(|(_, l)| l.as_str()).collect();
        assert_eq!(labels, ["0", "20", "40", "60", "80", "100"]);
        let labels: Vec<&str> = fr.y_ticks.iter().map(|(_, l)| l.as_str()).collect();
        assert_eq!(labels, ["0.2", "0.4", "0.6", "0.8", "1.0"]);
        assert!((0..fr.top).any(|y| (0..i64::from(w)).any(|x| img.get(x, y) == Some(INK))));
        // Deterministic: the same input gives the same pixels.
        assert_eq!(img, loss_curves(&series, "Loss", false, w, h));
    }

    #[test]
    fn log_axis_spans_six_decades_and_skips_non_positive() {
        // loss = 10^(-6t): a straight line on a log axis, from 1 down to 1e-6.
        let mut pts: Vec<(f64, f64)> = (0..=60)
            .map(|i| (f64::from(i) * 10.0, 10f64.powf(-f64::from(i) / 10.0)))
            .collect();
        pts[20].1 = 0.0;
        pts[21].1 = -1.0;
        pts[22].1 = f64::NAN;
        let series: [(&str, &[(f64, f64)]); 1] = [("loss", &pts)];
        let img = loss_curves(&series, "", true, 500, 400);
        let fr = layout(&series, "", true, 500, 400);
        assert!((fr.y_lo - (-6.3)).abs() < 1e-9 && (fr.y_hi - 0.3).abs() < 1e-9);
        let labels: Vec<&str> = fr.y_ticks.iter().map(|(_, l)| l.as_str()).collect();
        assert_eq!(labels, ["1e-6", "1e-5", "1e-4", "1e-3", "0.01", "0.1", "1"]);
        assert!(!fr.y_minor.is_empty());
        // 1e-3 at x = 300 lands half way up the plot.
        let (px, py) = fr.px(300.0, -3.0);
        assert!((py - (fr.top + fr.bottom) as f32 / 2.0).abs() <= 1.0);
        assert!(near(&img, px, py, 1, PALETTE[0]));
        // The gap where losses were not positive is not bridged.
        let (gx, gy) = fr.px(210.0, -2.1);
        assert!(!near(&img, gx, gy, 2, PALETTE[0]));
        // On a linear axis the same point hugs the bottom.
        let clean: Vec<(f64, f64)> = pts.iter().copied().filter(|p| p.1 > 0.0).collect();
        let lin = layout(&[("loss", &clean)], "", false, 500, 400);
        let (_, ly) = lin.px(300.0, 1e-3);
        assert!(f64::from(ly) > lin.bottom as f64 - 0.1 * (lin.bottom - lin.top) as f64);
    }

    #[test]
    fn empty_and_degenerate_input_do_not_panic() {
        let none: [(&str, &[(f64, f64)]); 0] = [];
        let img = loss_curves(&none, "nothing", false, 200, 120);
        assert_eq!((img.width, img.height), (200, 120));
        let empty: [(f64, f64); 0] = [];
        let nan = [(f64::NAN, 1.0), (1.0, f64::INFINITY)];
        let one = [(5.0, 0.25)];
        let neg = [(0.0, -1.0), (1.0, 0.0)];
        let series: [(&str, &[(f64, f64)]); 4] = [
            ("empty", &empty),
            ("nan", &nan),
            ("one", &one),
            ("neg", &neg),
        ];
        for log in [false, true] {
            for (w, h) in [(300, 200), (20, 10), (0, 0), (1, 50)] {
                let img = loss_curves(&series, "t", log, w, h);
                assert_eq!(img.rgb.len(), w as usize * h as usize * 3);
            }
        }
        // The single point is drawn as a dot where it belongs.
        let img = loss_curves(&series, "t", true, 300, 200);
        let fr = layout(&series, "t", true, 300, 200);
        let (px, py) = fr.px(5.0, 0.25f64.log10());
        assert!(near(&img, px, py, 1, PALETTE[2]));
    }

    #[test]
    fn tick_helpers() {
        let t = linear_ticks(0.0, 1.0, 5);
        let l: Vec<&str> = t.iter().map(|(_, s)| s.as_str()).collect();
        assert_eq!(l, ["0", "0.2", "0.4", "0.6", "0.8", "1.0"]);
        assert!(linear_ticks(1.0, 1.0, 5).is_empty());
        assert!(linear_ticks(0.0, f64::INFINITY, 5).is_empty());
        // Less than a decade on a log axis: linear values at their logarithms.
        let (t, minor) = log_ticks(0.2f64.log10(), 0.9f64.log10());
        assert!(minor.is_empty());
        assert!(
            t.iter()
                .any(|(v, l)| l == "0.5" && (v - 0.5f64.log10()).abs() < 1e-12)
        );
        // Many decades are thinned.
        let (t, _) = log_ticks(-30.0, 0.0);
        assert!(t.len() <= 7 && t.len() >= 4, "{t:?}");
    }
}
