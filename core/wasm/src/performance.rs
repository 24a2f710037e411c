//! A fitted performance (`sinew fit --out FIT.sinew`) that owns its bytes, played on the AIM
//! actor it was fitted to: per frame the core's [`Performance::pose`] (AIM eq. 17, with the local
//! coefficients of eq. 19 where the fit has them) and the frame hash every target computes
//! ([`sinew_core::performance::play_frame_hash`]).

use self_cell::self_cell;
use sinew_core::aim::AimActor;
use sinew_core::performance::{self as perf, Performance as CorePerformance};
use sinew_core::replay::ReplayError;

use crate::error::Error;
use crate::model::{Kind, Model, ModelInner, POSE_9D};

self_cell!(
    struct PerformanceCell {
        owner: Box<[u8]>,
        #[covariant]
        dependent: CorePerformance,
    }
    impl {Debug}
);

/// A validated fitted performance that owns its bytes.
#[derive(Debug)]
pub struct Performance {
    cell: PerformanceCell,
}

/// One frame of a performance: the head and jaw, and the coefficients of a global fit.
#[derive(Clone, Debug, PartialEq)]
pub struct PerformanceFrame {
    /// `[9]` head pose (6D rotation, translation).
    pub head: [f32; POSE_9D],
    /// `[9]` jaw pose about the actor's pivot.
    pub jaw: [f32; POSE_9D],
    /// `[M]` the frame's coefficients for a global fit; `None` for a local fit, whose
    /// coefficients vary per vertex.
    pub coefficients: Option<Vec<f32>>,
}

impl Performance {
    /// Validates `bytes` as a fitted performance ([`CorePerformance::from_bytes`]).
    ///
    /// # Errors
    /// The core's [`sinew_core::FormatError`] message; for another kind of artefact, that of
    /// `WrongKind` with the kind found.
    pub fn load(bytes: Vec<u8>) -> Result<Self, Error> {
        let file = sinew_core::format::SinewFile::from_bytes(&bytes)?;
        if file.kind != sinew_core::format::ArtifactKind::Performance {
            return Err(Error::new(format!(
                "{} ({}, not a fitted performance)",
                sinew_core::FormatError::WrongKind,
                file.kind
            )));
        }
        let cell = PerformanceCell::try_new(bytes.into_boxed_slice(), |b| {
            CorePerformance::from_bytes(b).map_err(Error::from)
        })?;
        Ok(Self { cell })
    }

    fn core(&self) -> &CorePerformance<'_> {
        self.cell.borrow_dependent()
    }

    /// Number of frames (at least one).
    pub fn frames(&self) -> usize {
        self.core().frames()
    }

    /// Coefficients per frame (per vertex for a local fit): the actor's corrective count.
    pub fn shape_count(&self) -> usize {
        self.core().shape_count()
    }

    /// Whether the coefficients vary per vertex (a local fit, AIM eq. 19).
    pub fn is_local(&self) -> bool {
        self.core().is_local()
    }

    /// The content hash of the actor it was fitted to.
    pub fn model_hash(&self) -> u64 {
        self.core().model_hash()
    }

    /// Whether the file carries each frame's hash as baked (`perf.hash`).
    pub fn has_hashes(&self) -> bool {
        self.core().expected(0).is_some()
    }

    /// The AIM actor of `model`, or why it cannot play this performance.
    fn actor<'m>(&self, model: &'m Model) -> Result<&'m AimActor<'m>, Error> {
        let ModelInner::Aim(cell) = &model.inner else {
            return Err(Error::new(format!(
                "a performance plays on {}, this model is {}",
                Kind::Aim.long_name(),
                model.kind().long_name()
            )));
        };
        let actor = cell.borrow_dependent();
        let found = model.content_hash();
        if found != self.model_hash() {
            return Err(Error::new(format!(
                "performance was fitted to the actor {:016x}, this model is {found:016x}",
                self.model_hash()
            )));
        }
        if actor.shape_count() != self.shape_count() {
            return Err(ReplayError::ShapeCount {
                replay: self.shape_count(),
                actor: actor.shape_count(),
            }
            .into());
        }
        Ok(actor)
    }

    /// Checks that this performance was fitted to `model`: an AIM actor with its content hash
    /// and coefficient count ([`CorePerformance::check_actor`]'s rule).
    ///
    /// # Errors
    /// An S2D decoder, another actor, or another coefficient count.
    pub fn check(&self, model: &Model) -> Result<(), Error> {
        self.actor(model).map(|_| ())
    }

    fn check_frame(&self, f: usize) -> Result<(), Error> {
        if f < self.frames() {
            Ok(())
        } else {
            Err(Error::new(format!(
                "frame {f} is past the end of the performance ({} frames)",
                self.frames()
            )))
        }
    }

    /// Frame `f`'s head and jaw, and for a global fit its coefficients.
    ///
    /// # Errors
    /// `f` is past the end.
    pub fn frame(&self, f: usize) -> Result<PerformanceFrame, Error> {
        self.check_frame(f)?;
        let (head, jaw) = self
            .core()
            .head_jaw(f)
            .ok_or_else(|| Error::from(sinew_core::BufferError::Input))?;
        let coefficients = if self.is_local() {
            None
        } else {
            let mut w = vec![0.0; self.shape_count()];
            self.core()
                .global_weights(f, &mut w)
                .ok_or_else(|| Error::from(sinew_core::BufferError::Input))?;
            Some(w)
        };
        Ok(PerformanceFrame {
            head,
            jaw,
            coefficients,
        })
    }

    /// Poses `model` for frame `f` ([`CorePerformance::pose`]).
    ///
    /// # Shapes
    /// Returns `[V, 3]` positions.
    ///
    /// # Errors
    /// A model this performance was not fitted to ([`Self::check`]), or `f` past the end.
    pub fn pose(&self, model: &Model, f: usize) -> Result<Vec<f32>, Error> {
        let actor = self.actor(model)?;
        self.check_frame(f)?;
        let mut scratch = vec![0.0; self.core().scratch_len()];
        let mut out = vec![0.0; 3 * actor.vertex_count()];
        self.core().pose(actor, f, &mut scratch, &mut out)?;
        Ok(out)
    }

    /// Frame `f`'s hash as every target computes it: posed, normals, then
    /// [`sinew_core::performance::play_frame_hash`].
    ///
    /// # Errors
    /// As [`Self::pose`].
    pub fn frame_hash(&self, model: &Model, f: usize) -> Result<u64, Error> {
        let actor = self.actor(model)?;
        self.check_frame(f)?;
        let mut scratch = vec![0.0; self.core().scratch_len()];
        let mut positions = vec![0.0; 3 * actor.vertex_count()];
        let mut normals = vec![0.0; positions.len()];
        Ok(perf::play_frame_hash(
            self.core(),
            actor,
            f,
            &mut scratch,
            &mut positions,
            &mut normals,
        )?)
    }

    /// The hash baked for frame `f`, `None` when the file carries none.
    ///
    /// # Errors
    /// `f` is past the end.
    pub fn expected(&self, f: usize) -> Result<Option<u64>, Error> {
        self.check_frame(f)?;
        Ok(self.core().expected(f))
    }
}
