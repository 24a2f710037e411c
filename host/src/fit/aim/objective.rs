//! One step of the fit: the points it draws and its objective (AIM eqs. 20–23), and a 2D
//! fit's targets (eq. 21: the landmark tracks through the performance's camera).

use burn::tensor::{Device, Int, Tensor, TensorData};

use crate::fit::setup::{FitConfig, FitNet, Mode};
use crate::io::performance::Performance;
use crate::training::nn::{tensor, to_vec};

use super::error::FitError;
use super::posing::{Fixed, pose};
use crate::training::random::Stream;

/// The loss of step `step`: its draw of points (`subset`'s, or any vertex of `v`), the actor
/// posed there and the objective; every tenth step's value is pushed onto `loss_history`.
pub(super) fn step_loss(
    net: &FitNet,
    fx: &Fixed,
    config: &FitConfig,
    camera: Option<&TwoDTargets>,
    subset: Option<&[i64]>,
    step: usize,
    loss_history: &mut Vec<(usize, f64)>,
) -> Tensor<1> {
    let (j, v) = (fx.frames, fx.vertices);
    let device = fx.rest.device();
    // Each step's draw is its own (seed, step), so a resumed fit draws what an unbroken one does.
    let mut rng = step_rng(config.seed, step as u64);
    let draw: Vec<i64> = match subset {
        None => (0..config.points).map(|_| rng.below(v) as i64).collect(),
        Some(s) if s.len() <= config.points || camera.is_some() => s.to_vec(),
        Some(s) => (0..config.points).map(|_| s[rng.below(s.len())]).collect(),
    };
    let n = draw.len();
    let idx = Tensor::<1, Int>::from_data(TensorData::new(draw, [n]), &device);
    let posed = pose(net, fx, idx.clone(), config.coefficients);
    let mut total = match camera {
        None => {
            let gt = fx.targets.clone().select(1, idx).reshape([j * n, 3]);
            let sq = |a: Tensor<2>| (a - gt.clone()).square().sum_dim(1).mean();
            // AIM eq. 20
            (sq(posed.skin) + sq(posed.lbs)).mul_scalar(config.lambda_3d)
        }
        Some(c) => {
            let sq = |a: Tensor<2>| (c.project(a) - c.pixels.clone()).square().sum_dim(1).mean();
            // AIM eq. 21
            (sq(posed.skin) + sq(posed.lbs)).mul_scalar(config.lambda_2d)
        }
    };
    // AIM eq. 22
    if let Some(w) = posed.weights {
        total = total + w.square().sum_dim(1).mean().mul_scalar(config.lambda_w);
    }
    // AIM eq. 23
    if j > 1 {
        let z = net.codes.val();
        let d = z.clone().narrow(0, 1, j - 1) - z.narrow(0, 0, j - 1);
        total = total + d.square().sum_dim(1).mean().mul_scalar(config.lambda_t);
    }
    if step.is_multiple_of(10) {
        let loss = to_vec(total.clone()).first().copied().unwrap_or(f32::NAN);
        loss_history.push((step, f64::from(loss)));
    }
    total
}

/// A 2D fit's targets: the landmarks' pixels per frame and the camera, in mm.
pub(super) struct TwoDTargets {
    /// `[J·L, 2]`, frame-major as `pose` orders its rows.
    pub(super) pixels: Tensor<2>,
    /// Camera centre in mm, `[1, 3]`.
    position: Tensor<2>,
    focal: [f32; 2],
    principal: [f32; 2],
}

impl TwoDTargets {
    pub(super) fn new(
        perf: &Performance,
        config: &FitConfig,
        mm: f32,
        device: &Device,
    ) -> Result<Option<Self>, FitError> {
        if config.mode != Mode::TwoD {
            return Ok(None);
        }
        let m = &perf.manifest;
        let l = m.landmarks.vertices.len();
        let pixels: Vec<f32> = m
            .landmarks
            .pixels
            .iter()
            .flatten()
            .flatten()
            .copied()
            .collect();
        if !(m.landmarks.pixels.len() == perf.frames.len()
            && pixels.len() == perf.frames.len() * l * 2)
        {
            return Err(FitError::LandmarkTracks {
                path: perf.dir.join("performance.json"),
            });
        }
        let c = &m.camera;
        Ok(Some(Self {
            pixels: tensor(pixels, [perf.frames.len() * l, 2], device),
            position: tensor(c.position.iter().map(|x| x * mm).collect(), [1, 3], device),
            focal: [c.fx, c.fy],
            principal: [c.cx, c.cy],
        }))
    }

    /// `Camera::project` on rows of mm positions: `[n, 3]` → `[n, 2]`.
    pub(super) fn project(&self, x: Tensor<2>) -> Tensor<2> {
        let rel = x - self.position.clone();
        let depth = rel.clone().narrow(1, 2, 1).neg();
        let u = (rel.clone().narrow(1, 0, 1) / depth.clone())
            .mul_scalar(self.focal[0])
            .add_scalar(self.principal[0]);
        let v = (rel.narrow(1, 1, 1) / depth)
            .mul_scalar(-self.focal[1])
            .add_scalar(self.principal[1]);
        Tensor::cat(vec![u, v], 1)
    }
}

/// The random stream of one step of a fit (and `u64::MAX`'s, the constrained subset's).
pub(super) fn step_rng(seed: u64, step: u64) -> Stream {
    Stream::new(seed, step, 0x00a0_2bdb_0000_0000_0000_0000_0000_0f17)
}
