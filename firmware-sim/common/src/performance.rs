//! The golden fitted performance: the ICT actor played through a local fit
//! (`tests/data/fit-ict.sinew`), F_W evaluated by the core at every vertex of every frame
//! ([`sinew_core::performance::check_frame`]), each frame's hash compared with the one the host
//! baked into the file.

use sinew_core::aim::AimActor;
use sinew_core::performance::{Performance, check_frame};
use sinew_core::replay::{FrameCheck, ReplayError};

use crate::{Error, Golden, ICT, MAX_VERTICES, PERFORMANCE_SCRATCH, Scratch, Summary, summarise};

/// The golden performance: 4 frames of a local fit (F_W 19 → 32 → 32 → 32 → 19) of the ICT
/// actor. `replay` holds the performance, which carries its own frame hashes.
pub const PERFORMANCE_GOLDENS: [Golden; 1] = [Golden {
    name: "fit-ict.f32",
    model: ICT,
    replay: include_bytes!("../../../tests/data/fit-ict.sinew"),
}];

/// A performance in progress: an iterator over its frames, so that a firmware can time each
/// frame on its own.
#[derive(Debug)]
pub struct PerformanceRun<'s> {
    actor: AimActor<'static>,
    performance: Performance<'static>,
    next: usize,
    scratch: &'s mut Scratch,
}

impl<'s> PerformanceRun<'s> {
    /// Validates the golden's actor and performance, checks that the performance was fitted to
    /// this actor (content hash) and that both fit in `scratch`.
    pub fn new(golden: &Golden, scratch: &'s mut Scratch) -> Result<Self, Error> {
        let actor = AimActor::from_bytes(golden.model).map_err(Error::Model)?;
        let performance = Performance::from_bytes(golden.replay).map_err(Error::Replay)?;
        performance
            .check_actor(golden.model, &actor)
            .map_err(Error::Playback)?;
        if actor.vertex_count() > MAX_VERTICES {
            return Err(Error::TooManyVertices {
                vertices: actor.vertex_count(),
            });
        }
        if performance.scratch_len() > PERFORMANCE_SCRATCH {
            return Err(Error::ScratchTooSmall {
                values: performance.scratch_len(),
            });
        }
        Ok(Self {
            actor,
            performance,
            next: 0,
            scratch,
        })
    }

    /// The loaded actor.
    pub const fn actor(&self) -> &AimActor<'static> {
        &self.actor
    }

    /// The loaded performance.
    pub const fn performance(&self) -> &Performance<'static> {
        &self.performance
    }

    fn play(&mut self, f: usize) -> Result<FrameCheck, Error> {
        let n = 3 * self.actor.vertex_count();
        let refused = |e: sinew_core::EvalError| Error::Playback(ReplayError::from(e));
        let (positions, normals) = self.scratch.frame.split_at_mut(3 * MAX_VERTICES);
        let (Some(positions), Some(normals)) = (positions.get_mut(..n), normals.get_mut(..n))
        else {
            return Err(Error::TooManyVertices {
                vertices: self.actor.vertex_count(),
            });
        };
        check_frame(
            &self.performance,
            &self.actor,
            f,
            &mut self.scratch.performance,
            positions,
            normals,
        )
        .map_err(refused)
    }
}

impl Iterator for PerformanceRun<'_> {
    type Item = Result<FrameCheck, Error>;

    fn next(&mut self) -> Option<Self::Item> {
        let f = self.next;
        if f >= self.performance.frames() {
            return None;
        }
        self.next += 1;
        Some(self.play(f))
    }
}

/// Plays every frame of the performance `golden`, calling `report` after each one, and returns
/// the totals.
pub fn replay_performance(
    golden: &Golden,
    scratch: &mut Scratch,
    report: impl FnMut(&FrameCheck),
) -> Result<Summary, Error> {
    summarise(PerformanceRun::new(golden, scratch)?, report)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::GOLDENS;
    use std::boxed::Box;
    use std::vec::Vec;

    #[test]
    fn the_performance_golden_matches_the_host() {
        for g in &PERFORMANCE_GOLDENS {
            let mut seen = Vec::new();
            let s = replay_performance(g, &mut Box::default(), |r| seen.push(*r)).unwrap();
            assert!(s.passed(), "{}", g.name);
            assert_eq!(s.frames, 4, "{}", g.name);
            assert_ne!(seen[0].hash, seen[3].hash, "{}", g.name);
        }
    }

    #[test]
    fn a_performance_of_another_actor_or_kind_is_refused() {
        let mut scratch = Box::<Scratch>::default();
        // The procedural actor is not the one fitted.
        let g = Golden {
            model: GOLDENS[0].model,
            ..PERFORMANCE_GOLDENS[0]
        };
        let got = PerformanceRun::new(&g, &mut scratch).map(|_| ());
        assert!(matches!(got, Err(Error::Playback(_))), "{got:?}");
        // A replay is no performance.
        let g = Golden {
            replay: GOLDENS[3].replay,
            ..PERFORMANCE_GOLDENS[0]
        };
        let got = PerformanceRun::new(&g, &mut scratch).map(|_| ());
        assert!(matches!(got, Err(Error::Replay(_))), "{got:?}");
    }
}
