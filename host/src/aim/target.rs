//! Training to an accuracy instead of a step count: the run measures its error on the training
//! shapes every few hundred steps and stops once the targets are met, `--steps` staying the
//! upper bound.
//!
//! A check poses every training shape at every template vertex with the model as it stands
//! (AIM eq. 10 through burn, as the objective does) and compares it with the shape: the mean and
//! the 95th percentile of the per-vertex distance over all shapes, in millimetres, the measure
//! the report gives after baking (which reads the same numbers through the core, to f32
//! rounding). The jaw counts as settled when `jawOpen`'s learned rotation moved by at most
//! [`Target::jaw_settle_degrees`] since the previous check (a set without `jawOpen` has no jaw
//! criterion), and reaches [`Target::jaw_degrees`] when one is asked for.

use burn::tensor::{Int, Tensor, TensorData};
use serde::{Deserialize, Serialize};

use super::TrainingSet;
use super::model::{AimNet, normalise};
use crate::training::nn::to_vec;

/// What a run aims for.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Target {
    /// Mean per-vertex error over the training shapes, mm.
    pub mean_mm: f64,
    /// 95th percentile of the per-vertex error, mm.
    pub p95_mm: f64,
    /// The most `jawOpen`'s learned jaw rotation may move between two checks for the jaw to
    /// count as settled, degrees.
    pub jaw_settle_degrees: f64,
    /// The least rotation `jawOpen`'s learned jaw must reach, degrees (0: none asked).
    pub jaw_degrees: f64,
    /// Steps between two checks.
    pub every: usize,
}

impl Default for Target {
    /// Mean 0.10 mm, p95 0.25 mm, the jaw settled to 0.25° between checks 250 steps apart.
    fn default() -> Self {
        Self {
            mean_mm: 0.10,
            p95_mm: 0.25,
            jaw_settle_degrees: 0.25,
            jaw_degrees: 0.0,
            every: 250,
        }
    }
}

/// A target that cannot be met or makes no sense, named by its option.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum InvalidTarget {
    /// An error target that is not a positive finite number of millimetres.
    #[error("--{option} {value}: an error target is a positive number of millimetres")]
    Error {
        /// The option (`target-mean`, `target-p95`).
        option: &'static str,
        /// Its value.
        value: f64,
    },
    /// A 95th percentile below the mean, which no set of errors has.
    #[error(
        "--target-p95 {p95} is below --target-mean {mean}: the 95th percentile of errors is never below their mean"
    )]
    P95BelowMean {
        /// The mean asked.
        mean: f64,
        /// The percentile asked.
        p95: f64,
    },
    /// A jaw criterion that is negative, not finite or beyond a half-turn.
    #[error("--{option} {value}: give degrees from 0 to 180")]
    Degrees {
        /// The option (`target-jaw-settle`, `target-jaw-degrees`).
        option: &'static str,
        /// Its value.
        value: f64,
    },
    /// Checks zero steps apart.
    #[error("--check-every 0: checks must be at least one step apart")]
    Every,
}

impl Target {
    /// Checks the target; the error names the option.
    pub fn validate(&self) -> Result<(), InvalidTarget> {
        for (option, value) in [("target-mean", self.mean_mm), ("target-p95", self.p95_mm)] {
            if !(value.is_finite() && value > 0.0) {
                return Err(InvalidTarget::Error { option, value });
            }
        }
        if self.p95_mm < self.mean_mm {
            return Err(InvalidTarget::P95BelowMean {
                mean: self.mean_mm,
                p95: self.p95_mm,
            });
        }
        for (option, value) in [
            ("target-jaw-settle", self.jaw_settle_degrees),
            ("target-jaw-degrees", self.jaw_degrees),
        ] {
            if !(0.0..=180.0).contains(&value) {
                return Err(InvalidTarget::Degrees { option, value });
            }
        }
        if self.every == 0 {
            return Err(InvalidTarget::Every);
        }
        Ok(())
    }

    /// Whether `check` meets the target, `previous` the check before it (for the jaw).
    pub fn met(&self, check: &Check, previous: Option<&Check>) -> bool {
        let jaw = match check.jaw_open_degrees {
            None => true,
            Some(now) => {
                let settled = previous
                    .and_then(|p| p.jaw_open_degrees)
                    .is_some_and(|before| (now - before).abs() <= self.jaw_settle_degrees);
                settled && now >= self.jaw_degrees
            }
        };
        check.mean_mm <= self.mean_mm && check.p95_mm <= self.p95_mm && jaw
    }

    /// How far `check` is from the target, in words ("mean 0.120 mm, 0.020 mm above its 0.100
    /// mm target", …); empty
    /// when it meets it.
    pub fn shortfall(&self, check: &Check, previous: Option<&Check>) -> Vec<String> {
        let mut out = Vec::new();
        if check.mean_mm > self.mean_mm {
            out.push(format!(
                "mean {:.3} mm, {:.3} mm above its {:.3} mm target",
                check.mean_mm,
                check.mean_mm - self.mean_mm,
                self.mean_mm
            ));
        }
        if check.p95_mm > self.p95_mm {
            out.push(format!(
                "p95 {:.3} mm, {:.3} mm above its {:.3} mm target",
                check.p95_mm,
                check.p95_mm - self.p95_mm,
                self.p95_mm
            ));
        }
        if let Some(now) = check.jaw_open_degrees {
            match previous.and_then(|p| p.jaw_open_degrees) {
                Some(before) if (now - before).abs() > self.jaw_settle_degrees => out.push(
                    format!(
                        "jawOpen's jaw still moving ({:.2}° since the last check, more than {:.2}°)",
                        (now - before).abs(),
                        self.jaw_settle_degrees
                    ),
                ),
                None => out.push("jawOpen's jaw not yet checked twice".into()),
                _ => {}
            }
            if now < self.jaw_degrees {
                out.push(format!(
                    "jawOpen turns the jaw {now:.1}°, below {:.1}°",
                    self.jaw_degrees
                ));
            }
        }
        out
    }
}

/// One measurement of a run against its training shapes.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Check {
    /// Steps done when measured.
    pub step: usize,
    /// Mean per-vertex error over all training shapes, mm.
    pub mean_mm: f64,
    /// Its 95th percentile, mm.
    pub p95_mm: f64,
    /// `jawOpen`'s learned jaw rotation, degrees (`None` without a `jawOpen` shape).
    pub jaw_open_degrees: Option<f64>,
}

/// Why a run ended.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Ending {
    /// The target was met at a check.
    Target,
    /// A resumed run already met its target: no step was taken.
    AlreadyMet,
    /// The step limit came first.
    Steps,
}

/// Vertices posed per batch by [`measure`]: bounds the memory of the corrective network's
/// output (`[B, M, 3]`).
const MEASURE_BATCH: usize = 4096;

/// Measures `net` (an inference model) on every training shape at every template vertex of
/// `set`, with input normalisation `norm`; `step` is recorded as is.
pub fn measure(net: &AimNet, set: &TrainingSet, norm: [f32; 4], step: usize) -> Check {
    let device = net.jaw.val().device();
    let tpl = &set.template.positions;
    let n = set.shapes.len();
    let rows = |v: Vec<f32>| {
        let len = v.len() / 3;
        Tensor::<2>::from_data(TensorData::new(v, [len, 3]), &device)
    };
    let pivot = rows(set.jaw_pivot.to_vec());
    let mut errors = Vec::with_capacity(n * tpl.len());
    for start in (0..tpl.len()).step_by(MEASURE_BATCH) {
        let end = (start + MEASURE_BATCH).min(tpl.len());
        let x = rows((start..end).flat_map(|i| normalise(tpl[i], norm)).collect());
        let c = rows((start..end).flat_map(|i| tpl[i]).collect());
        let p = net.predict(x, c);
        for (s, shape) in set.shapes.iter().enumerate() {
            let index = Tensor::<1, Int>::from_data(
                TensorData::new(vec![s as i64; end - start], [end - start]),
                &device,
            );
            let posed = to_vec(net.pose(&p, index, pivot.clone()));
            for (i, q) in posed.chunks_exact(3).enumerate() {
                let want = shape[start + i];
                let d: f64 = (0..3)
                    .map(|k| f64::from(q[k] - want[k]).powi(2))
                    .sum::<f64>()
                    .sqrt();
                errors.push(d * f64::from(set.mm_per_unit));
            }
        }
    }
    let mean = errors.iter().sum::<f64>() / errors.len().max(1) as f64;
    errors.sort_by(f64::total_cmp);
    let p95 = errors
        .get(((errors.len() as f64 * 0.95) as usize).min(errors.len().saturating_sub(1)))
        .copied()
        .unwrap_or(0.0);
    let jaw_open_degrees = jaw_open(set).map(|s| {
        let jaw = to_vec(net.jaw.val().narrow(0, s - 1, 1));
        let nine: [f32; 9] = std::array::from_fn(|i| jaw[i]);
        super::eval::rotation_degrees(&nine)
    });
    Check {
        step,
        mean_mm: mean,
        p95_mm: p95,
        jaw_open_degrees,
    }
}

/// The index of the `jawOpen` shape in `set` (however spelled), if it has one (never 0, the
/// neutral).
fn jaw_open(set: &TrainingSet) -> Option<usize> {
    let key = crate::io::arkit::comparable("jawOpen");
    set.names
        .iter()
        .enumerate()
        .skip(1)
        .find(|(_, n)| crate::io::arkit::comparable(n) == key)
        .map(|(s, _)| s)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(step: usize, mean: f64, p95: f64, jaw: Option<f64>) -> Check {
        Check {
            step,
            mean_mm: mean,
            p95_mm: p95,
            jaw_open_degrees: jaw,
        }
    }

    #[test]
    fn the_target_needs_every_criterion() {
        let t = Target::default();
        let before = check(250, 0.2, 0.5, Some(20.0));
        // Accurate and the jaw within 0.25° of the last check.
        assert!(t.met(&check(500, 0.09, 0.24, Some(20.2)), Some(&before)));
        assert!(
            t.shortfall(&check(500, 0.09, 0.24, Some(20.2)), Some(&before))
                .is_empty()
        );
        // Each criterion alone fails it, and the shortfall says which.
        for (c, words) in [
            (
                check(500, 0.11, 0.24, Some(20.2)),
                "mean 0.110 mm, 0.010 mm above its 0.100 mm target",
            ),
            (
                check(500, 0.09, 0.26, Some(20.2)),
                "p95 0.260 mm, 0.010 mm above its 0.250 mm target",
            ),
            (check(500, 0.09, 0.24, Some(21.0)), "still moving"),
        ] {
            assert!(!t.met(&c, Some(&before)), "{c:?}");
            let s = t.shortfall(&c, Some(&before)).join("; ");
            assert!(s.contains(words), "{s}");
        }
        // The first check cannot tell whether the jaw settled.
        assert!(!t.met(&check(250, 0.09, 0.24, Some(20.0)), None));
        // Without jawOpen the jaw does not count.
        assert!(t.met(&check(250, 0.09, 0.24, None), None));
        // A least opening, when asked.
        let wide = Target {
            jaw_degrees: 25.0,
            ..Target::default()
        };
        let c = check(500, 0.09, 0.24, Some(20.2));
        assert!(!wide.met(&c, Some(&before)));
        assert!(wide.shortfall(&c, Some(&before))[0].contains("below 25.0°"));
    }

    #[test]
    fn targets_that_make_no_sense_are_refused_by_option() {
        let bad = |t: Target| t.validate().unwrap_err().to_string();
        assert!(
            bad(Target {
                mean_mm: -0.1,
                ..Target::default()
            })
            .starts_with("--target-mean -0.1")
        );
        assert!(
            bad(Target {
                p95_mm: f64::NAN,
                ..Target::default()
            })
            .starts_with("--target-p95 NaN")
        );
        assert!(
            bad(Target {
                mean_mm: 0.3,
                ..Target::default()
            })
            .contains("below --target-mean 0.3")
        );
        assert!(
            bad(Target {
                jaw_degrees: 200.0,
                ..Target::default()
            })
            .starts_with("--target-jaw-degrees 200")
        );
        assert!(
            bad(Target {
                every: 0,
                ..Target::default()
            })
            .starts_with("--check-every 0")
        );
        assert_eq!(Target::default().validate(), Ok(()));
    }
}
