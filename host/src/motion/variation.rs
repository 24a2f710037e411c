//! What makes two sequences of one label differ, as they do when people make them (motion sets of
//! version 2, docs/MOTION.md "What makes sequences differ"): each class's pattern
//! ([`super::classes::PATTERNS`]) is its centre, and around it
//! - per identity and label, a **style**: the pattern's weights drawn around the centre, some
//!   parts dropped, deltas of the neighbouring classes added, the pattern leaning towards one
//!   neighbouring class of its family ([`FAMILIES`]), and an asymmetry between left and right;
//! - per sequence, an **envelope** over the parts' rise (sometimes a hold and a partial release,
//!   sometimes two peaks, sometimes not reaching the apex), **co-activations** of deltas outside
//!   the class (a blink, a brow movement, a slight smile) at random times, and per-frame
//!   **tracking noise** on the landmarks.
//!
//! Every spread is a knob of [`Variation`], scaled by its `difficulty`; every draw comes from the
//! motion set's seeded stream.

use serde::{Deserialize, Serialize};

use super::classes::{LABELS, PATTERNS, Part};
use crate::training::random::Stream;

/// Classes whose centres share deltas, as CoMA's expressions share muscles: the families a
/// style leans within and whose deltas it borrows. A label's neighbours are the other members of
/// every family it belongs to.
pub const FAMILIES: [&[&str]; 5] = [
    // The mouth-opening family (jawOpen).
    &["mouth_open", "mouth_extreme", "mouth_middle"],
    // The smile family (mouthUpperUp, the cheeks).
    &["high_smile", "lips_up", "bareteeth"],
    // The lip-stretch family (mouthStretch).
    &["lips_back", "bareteeth", "mouth_extreme"],
    // The pucker (mouthPucker, mouthFunnel).
    &["cheeks_in", "mouth_middle"],
    // The chin and lower lip (mouthShrugLower, mouthPress).
    &["mouth_down", "mouth_up"],
];

/// The deltas co-activations draw from, each event one group: a blink, a brow raise, a slight
/// smile, a brow frown.
pub const COACTIVATIONS: [&[&str]; 4] = [
    &["eyeBlink_L", "eyeBlink_R"],
    &["browInnerUp_L", "browInnerUp_R"],
    &["mouthSmile_L", "mouthSmile_R"],
    &["browDown_L", "browDown_R"],
];

/// The knobs of a version-2 motion set. Spreads and probabilities are multiplied by
/// `difficulty` (probabilities capped at 1); `difficulty` 0 leaves each label's pattern with the
/// timing, intensity and weight jitter of version 1.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Variation {
    /// Scales every knob below (at least 0).
    pub difficulty: f32,
    /// σ of each part's style factor, `max(0.2, 1 + σ · N(0, 1))`, per identity and label.
    pub style: f32,
    /// Probability that a style drops a part (never the strongest).
    pub drop: f32,
    /// Probability that a style adds each delta of a neighbouring class that its pattern lacks,
    /// at a weight uniform in [0, 0.3].
    pub borrow: f32,
    /// Most a style leans towards one neighbouring class: λ uniform in [0, lean], the style
    /// `(1 − λ) · own + λ · neighbour`.
    pub lean: f32,
    /// σ of a style's left-right asymmetry a: `_L` deltas × (1 + a), `_R` × (1 − a).
    pub asymmetry: f32,
    /// Most a sequence mixes in the identity's style of one neighbouring class: μ uniform in
    /// [0, mix], the sequence's parts `(1 − μ) · style + μ · neighbour's style`.
    pub mix: f32,
    /// Probability of each of two co-activation events in a sequence.
    pub coactivation: f32,
    /// Probability that a sequence holds its apex and then partly releases it.
    pub release: f32,
    /// Probability that a sequence has two peaks.
    pub two_peaks: f32,
    /// Probability that a sequence stops short of its apex.
    pub short: f32,
    /// σ of the landmarks' per-frame tracking noise, in the set's units (cm).
    pub tracking_noise: f32,
}

impl Default for Variation {
    fn default() -> Self {
        Self {
            difficulty: 1.0,
            style: 0.4,
            drop: 0.2,
            borrow: 0.25,
            lean: 0.65,
            asymmetry: 0.25,
            mix: 0.65,
            coactivation: 0.4,
            release: 0.3,
            two_peaks: 0.2,
            short: 0.25,
            tracking_noise: 0.001,
        }
    }
}

impl Variation {
    /// None: each label's pattern, as version-1 sets were made.
    pub fn none() -> Self {
        Self {
            difficulty: 0.0,
            ..Self::default()
        }
    }

    /// Each knob with its command-line option, for validation and messages.
    pub fn knobs(&self) -> [(&'static str, f32, bool); 12] {
        // (option, value, whether it is a probability)
        [
            ("--difficulty", self.difficulty, false),
            ("--style", self.style, false),
            ("--drop", self.drop, true),
            ("--borrow", self.borrow, true),
            ("--lean", self.lean, true),
            ("--asymmetry", self.asymmetry, false),
            ("--mix", self.mix, true),
            ("--coactivation", self.coactivation, true),
            ("--release", self.release, true),
            ("--two-peaks", self.two_peaks, true),
            ("--short", self.short, true),
            ("--tracking-noise", self.tracking_noise, false),
        ]
    }

    fn p(&self, p: f32) -> f32 {
        (p * self.difficulty).min(1.0)
    }

    fn s(&self, spread: f32) -> f32 {
        spread * self.difficulty
    }

    /// The tracking noise's σ.
    pub fn noise(&self) -> f32 {
        self.s(self.tracking_noise)
    }
}

/// One identity's way of making one label.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Style {
    /// The neighbouring class it leans towards, if any.
    pub lean_to: Option<String>,
    /// How far, λ.
    pub lean: f32,
    /// Left-right asymmetry a.
    pub asymmetry: f32,
    /// Per variant of the label's pattern, the style's parts: (delta, weight at full
    /// intensity), in the pattern's order, then the borrowed and leaned-in deltas.
    pub parts: Vec<Vec<(String, f32)>>,
}

/// The neighbours of `label` (indices into [`LABELS`]), in [`LABELS`] order.
pub fn neighbours(label: usize) -> Vec<usize> {
    let name = LABELS[label];
    let mut out: Vec<usize> = FAMILIES
        .iter()
        .filter(|f| f.contains(&name))
        .flat_map(|f| f.iter())
        .filter_map(|n| super::classes::label_index(n))
        .filter(|&n| n != label)
        .collect();
    out.sort_unstable();
    out.dedup();
    out
}

fn add(parts: &mut Vec<(String, f32)>, name: &str, w: f32) {
    match parts.iter_mut().find(|(n, _)| n == name) {
        Some(p) => p.1 += w,
        None => parts.push((name.to_owned(), w)),
    }
}

/// Draws one identity's style of `label`.
pub fn style(v: &Variation, label: usize, rng: &mut Stream) -> Style {
    let near = neighbours(label);
    let lean_to = (!near.is_empty() && v.difficulty > 0.0).then(|| near[rng.below(near.len())]);
    let lean = match lean_to {
        Some(_) => rng.uniform_f32(0.0, v.p(v.lean)),
        None => 0.0,
    };
    let asymmetry = (v.s(v.asymmetry) * rng.normal() as f32).clamp(-0.8, 0.8);
    let parts = PATTERNS[label]
        .iter()
        .map(|pattern| {
            let strongest = strongest(pattern);
            let mut parts: Vec<(String, f32)> = Vec::new();
            for (j, &(name, w)) in pattern.iter().enumerate() {
                let factor = (1.0 + v.s(v.style) * rng.normal() as f32).max(0.2);
                let dropped = j != strongest && rng.unit() < f64::from(v.p(v.drop));
                let w = if dropped { 0.0 } else { w * factor };
                add(&mut parts, name, (1.0 - lean) * w);
            }
            for &n in &near {
                for variant in PATTERNS[n] {
                    for &(name, w) in *variant {
                        if pattern.iter().any(|(own, _)| *own == name) {
                            continue;
                        }
                        if rng.unit() < f64::from(v.p(v.borrow)) {
                            add(&mut parts, name, w * rng.uniform_f32(0.0, 0.3));
                        }
                    }
                }
            }
            if let Some(n) = lean_to {
                for &(name, w) in PATTERNS[n][0] {
                    add(&mut parts, name, lean * w);
                }
            }
            for (name, w) in &mut parts {
                if name.ends_with("_L") {
                    *w *= 1.0 + asymmetry;
                } else if name.ends_with("_R") {
                    *w *= 1.0 - asymmetry;
                }
                *w = w.clamp(0.0, 1.0);
            }
            parts
        })
        .collect();
    Style {
        lean_to: lean_to.map(|n| LABELS[n].to_owned()),
        lean,
        asymmetry,
        parts,
    }
}

fn strongest(pattern: &[Part]) -> usize {
    let mut best = 0;
    for (j, p) in pattern.iter().enumerate() {
        if p.1 > pattern[best].1 {
            best = j;
        }
    }
    best
}

/// Draws how far a sequence of `label` mixes in a neighbouring class: the neighbour and μ, or
/// `None` (no neighbour, or no difficulty).
pub fn mix(v: &Variation, label: usize, rng: &mut Stream) -> Option<(usize, f32)> {
    let near = neighbours(label);
    if near.is_empty() || v.difficulty == 0.0 {
        return None;
    }
    let n = near[rng.below(near.len())];
    Some((n, rng.uniform_f32(0.0, v.p(v.mix))))
}

/// A sequence's parts: `(1 − μ) · own + μ · neighbour`, merged by delta (own parts first).
pub fn mixed(own: &[(String, f32)], neighbour: &[(String, f32)], mu: f32) -> Vec<(String, f32)> {
    let mut parts: Vec<(String, f32)> = Vec::with_capacity(own.len() + neighbour.len());
    for (name, w) in own {
        add(&mut parts, name, (1.0 - mu) * w);
    }
    for (name, w) in neighbour {
        add(&mut parts, name, mu * w);
    }
    for p in &mut parts {
        p.1 = p.1.clamp(0.0, 1.0);
    }
    parts
}

/// How a sequence's parts move together over time, on top of each part's own rise.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Envelope {
    /// The fraction of the way to its apex each part's rise gets to by the end (1: all the way).
    pub reach: f32,
    /// A hold and a partial release: from time `.0` the weights fall linearly to `.1` of their
    /// value by the end.
    pub release: Option<(f32, f32)>,
    /// Two peaks: around time `.0`, within ± `.1`, the weights dip to `.2` of their value.
    pub dip: Option<(f32, f32, f32)>,
}

impl Envelope {
    /// No envelope: every part rises to its apex and stays (version-1 sequences).
    pub fn flat() -> Self {
        Self {
            reach: 1.0,
            release: None,
            dip: None,
        }
    }

    /// The envelope's factor at time t.
    pub fn at(&self, t: f32) -> f32 {
        let mut g = 1.0;
        if let Some((start, level)) = self.release
            && t > start
        {
            g *= 1.0 - (1.0 - level) * (t - start) / (1.0 - start);
        }
        if let Some((centre, half, depth)) = self.dip {
            let x = ((t - centre).abs() / half).min(1.0);
            g *= 1.0 - (1.0 - depth) * (1.0 - x);
        }
        g
    }
}

/// Draws a sequence's envelope; returns it and the range its parts' peak times are drawn from
/// (earlier when the sequence has something to do after its apex).
pub fn envelope(v: &Variation, rng: &mut Stream) -> (Envelope, (f32, f32)) {
    let mut e = Envelope::flat();
    let mut peaks = (0.65, 1.0);
    if rng.unit() < f64::from(v.p(v.release)) {
        let start = rng.uniform_f32(0.7, 0.85);
        e.release = Some((start, rng.uniform_f32(0.4, 0.8)));
        peaks = (0.4, start);
    }
    if rng.unit() < f64::from(v.p(v.two_peaks)) {
        e.dip = Some((
            rng.uniform_f32(0.55, 0.7),
            rng.uniform_f32(0.1, 0.15),
            rng.uniform_f32(0.3, 0.6),
        ));
        peaks = (0.3, 0.45);
    }
    if e.release.is_none() && e.dip.is_none() && rng.unit() < f64::from(v.p(v.short)) {
        e.reach = rng.uniform_f32(0.45, 0.8);
    }
    (e, peaks)
}

/// A co-activation: a group of deltas outside the class rising and falling once.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Event {
    /// The deltas ([`COACTIVATIONS`]).
    pub shapes: Vec<String>,
    /// Their weight at the event's height.
    pub weight: f32,
    /// When it starts.
    pub start: f32,
    /// How long it lasts.
    pub duration: f32,
}

impl Event {
    /// Its weight at time t: `weight · sin(π (t − start) / duration)` inside, 0 outside.
    pub fn at(&self, t: f32) -> f32 {
        let x = (t - self.start) / self.duration;
        if (0.0..=1.0).contains(&x) {
            self.weight * (std::f32::consts::PI * x).sin()
        } else {
            0.0
        }
    }
}

/// Draws a sequence's co-activations (none, one or two).
pub fn events(v: &Variation, rng: &mut Stream) -> Vec<Event> {
    let mut out = Vec::new();
    for _ in 0..2 {
        if rng.unit() >= f64::from(v.p(v.coactivation)) {
            continue;
        }
        let g = rng.below(COACTIVATIONS.len());
        // A blink closes the eye and is quick; the others are slight and slower.
        let (weight, duration) = if g == 0 {
            (rng.uniform_f32(0.6, 1.0), rng.uniform_f32(0.06, 0.15))
        } else {
            (rng.uniform_f32(0.15, 0.4), rng.uniform_f32(0.2, 0.45))
        };
        out.push(Event {
            shapes: COACTIVATIONS[g].iter().map(|s| (*s).to_owned()).collect(),
            weight,
            start: rng.uniform_f32(0.05, 1.0 - duration),
            duration,
        });
    }
    out
}

/// The landmarks' tracking noise of sequence `s` (`[frames × dims]`, frame 0 zero: the neutral
/// is exact), σ `sigma`; from the set's seed and the sequence's index alone, so that a reader
/// recomputes it.
pub fn tracking_noise(seed: u64, s: usize, frames: usize, dims: usize, sigma: f32) -> Vec<f32> {
    let mut out = vec![0.0f32; frames * dims];
    if sigma == 0.0 {
        return out;
    }
    let mut rng = Stream::new(
        seed,
        0x7ac4_1e55,
        0x00a0_2bdb_0000_0000_0000_0001_0000_0000 + s as u128,
    );
    for x in &mut out[dims..] {
        *x = sigma * rng.normal() as f32;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn families_name_labels_and_neighbours_are_symmetric() {
        for f in FAMILIES {
            assert!(
                f.iter()
                    .all(|n| super::super::classes::label_index(n).is_some()),
                "{f:?}"
            );
        }
        for (a, name) in LABELS.iter().enumerate() {
            for b in neighbours(a) {
                assert!(neighbours(b).contains(&a), "{name} {}", LABELS[b]);
            }
        }
        let open = super::super::classes::label_index("mouth_open").unwrap();
        let names: Vec<&str> = neighbours(open).iter().map(|&n| LABELS[n]).collect();
        assert_eq!(names, ["mouth_extreme", "mouth_middle"]);
        assert!(neighbours(super::super::classes::label_index("eyebrow").unwrap()).is_empty());
    }

    #[test]
    fn no_difficulty_is_the_pattern_and_the_envelope_is_flat() {
        let v = Variation::none();
        let mut rng = Stream::new(1, 2, 3);
        for (label, variants) in PATTERNS.iter().enumerate() {
            let s = style(&v, label, &mut rng);
            assert_eq!(s.lean, 0.0);
            assert_eq!(s.asymmetry, 0.0);
            for (parts, pattern) in s.parts.iter().zip(*variants) {
                let expected: Vec<(String, f32)> =
                    pattern.iter().map(|(n, w)| ((*n).to_owned(), *w)).collect();
                assert_eq!(parts, &expected);
            }
            let (e, peaks) = envelope(&v, &mut rng);
            assert_eq!(
                (e.reach, e.release, e.dip, peaks),
                (1.0, None, None, (0.65, 1.0))
            );
            assert!(events(&v, &mut rng).is_empty());
        }
        assert!(tracking_noise(1, 0, 3, 4, 0.0).iter().all(|&x| x == 0.0));
    }

    #[test]
    fn styles_envelopes_and_events_vary_within_their_ranges() {
        let v = Variation {
            difficulty: 2.0,
            ..Variation::default()
        };
        let mut rng = Stream::new(4, 5, 6);
        let (mut leaned, mut dips, mut releases, mut shorts, mut events_seen) = (0, 0, 0, 0, 0);
        for k in 0..200 {
            let label = k % LABELS.len();
            let s = style(&v, label, &mut rng);
            leaned += usize::from(s.lean > 0.0);
            assert!((0.0..=1.0).contains(&s.lean) && s.asymmetry.abs() <= 0.8);
            for parts in &s.parts {
                assert!(parts.iter().all(|(_, w)| (0.0..=1.0).contains(w)));
                // The strongest part of the pattern survives.
                assert!(parts.iter().any(|(_, w)| *w > 0.0));
            }
            let (e, _) = envelope(&v, &mut rng);
            dips += usize::from(e.dip.is_some());
            releases += usize::from(e.release.is_some());
            shorts += usize::from(e.reach < 1.0);
            for t in 0..=20 {
                let g = e.at(t as f32 / 20.0);
                assert!((0.0..=1.0).contains(&g), "{g}");
            }
            for ev in events(&v, &mut rng) {
                events_seen += 1;
                assert!(ev.start >= 0.0 && ev.start + ev.duration <= 1.0);
                assert_eq!(ev.at(ev.start), 0.0);
                assert!(ev.at(ev.start + ev.duration / 2.0) > 0.1);
            }
        }
        assert!(leaned > 50 && dips > 20 && releases > 20 && shorts > 5 && events_seen > 50);
        let a = tracking_noise(1, 3, 4, 5, 0.1);
        assert_eq!(a, tracking_noise(1, 3, 4, 5, 0.1));
        assert_ne!(a, tracking_noise(1, 4, 4, 5, 0.1));
        assert!(a[..5].iter().all(|&x| x == 0.0) && a[5..].iter().all(|&x| x != 0.0));
    }
}
