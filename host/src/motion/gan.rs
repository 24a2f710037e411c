// S2D eq. 2–4: L_adv (WGAN-GP on log maps, eq. 2–3) and L_r (eq. 4), L_M = α1 L_adv + α2 L_r.
//! Motion3DGAN's conditional Wasserstein GAN with gradient penalty on burn (S2D section 3.1):
//! a generator G(z, c) of tangent vectors at the reference motion p, and a critic D(s, c) on
//! tangent vectors, the label c one-hot.
//!
//! burn 0.22 differentiates once only, so the gradient penalty cannot differentiate autodiff's
//! own input gradient. The critic is an MLP with leaky-ReLU hidden layers, whose input gradient
//! is the product `∇ₓD = W₀ᵀ diag(m₀) W₁ᵀ diag(m₁) … W_Lᵀ` of its weight matrices and the
//! (detached, piecewise-constant) activation slopes m; [`Critic::input_gradient`] writes it as
//! ordinary tensor operations, which autodiff then differentiates with respect to the weights.
//! A test checks it against finite differences.
//!
//! Differences from the TensorFlow reference, and why: both networks are MLPs (the reference's
//! generator is a 2-D convolutional up-sampler and its critic has strided convolutions with batch
//! normalisation), because `sinew-core` must evaluate the generator with its existing MLP kernel
//! and the explicit input gradient is a product of matrices only for a critic without batch
//! normalisation; the label joins the input only (the reference concatenates it after every
//! layer). The generator's output is projected onto the tangent space at p (`s − ⟨s, p⟩ p`,
//! `sinew_core::srvf::project_tangent` at playback), so `log_p(exp_p(G))` is G itself for
//! ‖G‖ < π and eq. 2 and 4 use G directly.

use burn::module::Module;
use burn::nn::Linear;
use burn::optim::GradientsParams;
use burn::tensor::{Device, Int, Tensor};
use serde::{Deserialize, Serialize};
use sinew_core::nn::Activation;
use sinew_core::srvf::FRAMES;

use super::guide::LabelGuide;
use crate::training::adam::Adam;
use crate::training::nn::{Mlp, pytorch_linear, tensor, to_vec};

/// The training settings (the paper's where it gives them, section 4.2).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GanConfig {
    /// Seed of the weights, the noise and the batches.
    pub seed: u64,
    /// Generator steps.
    pub steps: usize,
    /// Sequences per batch.
    pub batch: usize,
    /// Critic steps per generator step (4).
    pub critic_steps: usize,
    /// Adam's learning rate (β = (0.5, 0.9)); 2e-4, twice the paper's.
    pub lr: f64,
    /// α1, the adversarial loss's weight (1).
    pub alpha_adv: f32,
    /// α2, the reconstruction loss's weight (10).
    pub alpha_rec: f32,
    /// λ, the gradient penalty's weight (10).
    pub lambda: f32,
    /// Noise dimensions (128).
    pub noise: usize,
    /// Hidden widths of the generator and of the critic.
    pub hidden: Vec<usize>,
    /// Slope of the leaky ReLUs.
    pub slope: f32,
    /// Which real motion of its label each generated one is reconstructed against in L_r.
    /// Checkpoints written before the setting existed trained with [`Pairing::Batch`].
    #[serde(default = "Pairing::batch")]
    pub pairing: Pairing,
    /// λ_div, the weight of the diversity term ([`diversity_term`]; 1; 0: none, as the paper).
    /// Checkpoints written before the setting existed trained without it.
    #[serde(default)]
    pub diversity: f32,
    /// λ_cls, the weight of the label guide's cross-entropy on the generated motions
    /// ([`super::guide`]; 10; 0: no guide, as the paper). Checkpoints written before the setting
    /// existed trained without it.
    #[serde(default)]
    pub class_weight: f32,
}

/// The real motion L_r (eq. 4) compares a generated one with; both are of the same label.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum Pairing {
    /// The batch's real motion in the same row, as the reference pairs them: every generated
    /// motion is pulled towards all of its label's motions in turn, so towards their centre.
    Batch,
    /// The batch's real motion of the same label nearest to it (tangent-space distance): each
    /// generated motion is pulled towards the real motion it already resembles, so the noise
    /// keeps choosing between them.
    Nearest,
    /// Both ways, averaged (a Chamfer distance within each label of the batch): each generated
    /// motion against the nearest real one of its label, and each real motion against the
    /// nearest generated one of its label, so that a label's generated motions are pulled to
    /// cover every kind of its real ones (mouth_side's left and right) rather than their centre
    /// or only the kind they resemble. The default.
    #[default]
    Chamfer,
}

impl Pairing {
    /// [`Pairing::Batch`], for serde's default.
    fn batch() -> Self {
        Self::Batch
    }
}

impl Default for GanConfig {
    fn default() -> Self {
        Self {
            seed: 1,
            // 16.6 minutes on 2 idle cores (docs/MOTION.md, "Training time"): the budget for the
            // default run is 30. 2,000 steps meet Table 3's three goals on both rows, where
            // 1,500 miss the diversity goal by a point (docs/MOTION.md, "Table 3 on the default
            // (version-2) set"). Nothing in a step depends on the total (the learning rate is
            // constant; each step's noise and batch come from the seed and the step), so a
            // shorter run is the start of this one bit for bit.
            steps: 2000,
            batch: 64,
            critic_steps: 4,
            // Twice the paper's 1e-4: in the 1,500 steps measured, it gave Table 3 a lower
            // Fréchet distance and more diverse motions at the same accuracy
            // (docs/MOTION.md, "Table 3 on the default (version-2) set").
            lr: 2e-4,
            alpha_adv: 1.0,
            alpha_rec: 10.0,
            lambda: 10.0,
            noise: 128,
            hidden: vec![512, 512],
            slope: 0.2,
            pairing: Pairing::Chamfer,
            // The label guide and the diversity term together: the motions are labelled more
            // often than the real ones and are more varied than with neither (docs/MOTION.md,
            // "Table 3 on the default (version-2) set").
            diversity: 1.0,
            class_weight: 10.0,
        }
    }
}

/// The critic: an MLP with leaky-ReLU hidden layers and one linear output.
#[derive(Module, Debug)]
pub struct Critic {
    /// The hidden affine layers, first to last, each followed by a leaky ReLU.
    pub hidden: Vec<Linear>,
    /// The output layer (one score).
    pub out: Linear,
    /// Slope of the leaky ReLUs.
    #[module(skip)]
    pub slope: f32,
}

impl Critic {
    /// A critic of `inputs` inputs with the given hidden widths (PyTorch's initialisation).
    pub fn new(inputs: usize, hidden: &[usize], slope: f32, device: &Device) -> Self {
        let widths: Vec<usize> = std::iter::once(inputs)
            .chain(hidden.iter().copied())
            .collect();
        Self {
            hidden: widths
                .windows(2)
                .map(|w| pytorch_linear(w[0], w[1], device))
                .collect(),
            out: pytorch_linear(widths[widths.len() - 1], 1, device),
            slope,
        }
    }

    /// The scores and each hidden layer's activation slopes (1 where the pre-activation is
    /// positive, `slope` elsewhere; detached).
    ///
    /// # Shapes
    /// - x: `[n, inputs]`
    /// - scores: `[n, 1]`; slopes: one `[n, width]` per hidden layer
    pub fn forward_with_slopes(&self, x: Tensor<2>) -> (Tensor<2>, Vec<Tensor<2>>) {
        let mut slopes = Vec::with_capacity(self.hidden.len());
        let mut h = x;
        for layer in &self.hidden {
            let pre = layer.forward(h);
            let positive = pre.clone().detach().greater_elem(0.0).float();
            let m = positive.mul_scalar(1.0 - self.slope).add_scalar(self.slope);
            h = pre * m.clone();
            slopes.push(m);
        }
        (self.out.forward(h), slopes)
    }

    /// The scores.
    ///
    /// # Shapes
    /// - x: `[n, inputs]` → `[n, 1]`
    pub fn forward(&self, x: Tensor<2>) -> Tensor<2> {
        self.forward_with_slopes(x).0
    }

    /// `∂D/∂x` for each row, from the slopes of [`Critic::forward_with_slopes`] at that x:
    /// `W_outᵀ`, then for each hidden layer from the last, `⊙ m_i` and `· W_iᵀ`. Differentiable
    /// with respect to the weights.
    ///
    /// # Shapes
    /// - slopes: one `[n, width]` per hidden layer → `[n, inputs]`
    pub fn input_gradient(&self, slopes: &[Tensor<2>]) -> Tensor<2> {
        // The output layer is [width, 1] in burn's [in, out] layout: its transpose is ∂D/∂h.
        let mut g = self.out.weight.val().transpose();
        for (layer, m) in self.hidden.iter().zip(slopes).rev() {
            g = (g * m.clone()).matmul(layer.weight.val().transpose());
        }
        g
    }
}

/// The scale of the generator's output layer at initialisation, against PyTorch's.
pub const OUTPUT_INIT: f64 = 0.1;

/// The generator: an MLP from `[z ‖ one-hot label]` to a tangent vector at p.
#[derive(Module, Debug)]
pub struct Generator {
    /// The MLP (leaky ReLU hidden layers, a linear output of `FRAMES · dims`).
    pub mlp: Mlp,
}

impl Generator {
    /// A generator of `noise + labels` inputs and `outputs` outputs.
    pub fn new(
        noise: usize,
        labels: usize,
        outputs: usize,
        hidden: &[usize],
        slope: f32,
        device: &Device,
    ) -> Self {
        let widths: Vec<usize> = std::iter::once(noise + labels)
            .chain(hidden.iter().copied())
            .chain(std::iter::once(outputs))
            .collect();
        let mut activations = vec![Activation::LeakyRelu { slope }; hidden.len()];
        activations.push(Activation::Identity);
        let mut mlp = Mlp::new(&widths, &activations, device);
        // The label's rows of the first layer start √noise times larger: PyTorch's
        // initialisation gives every input the same scale, so one hot input among `noise`
        // standard normals would start √noise times weaker than the noise together, and the
        // label would hardly shape the motion (the reference concatenates it after every layer
        // instead, which the core's MLP cannot).
        let rows: Vec<f32> = (0..noise + labels)
            .map(|i| {
                if i < noise {
                    1.0
                } else {
                    (noise as f32).sqrt()
                }
            })
            .collect();
        let first = &mut mlp.layers[0];
        let w = first.weight.val() * tensor(rows, [noise + labels, 1], device);
        first.weight = burn::module::Param::from_tensor(w.detach());
        // The output layer starts at a tenth of its scale, so the first motions lie near p (the
        // training motions' mean) rather than a random tangent vector several times longer than
        // theirs.
        let last = mlp.layers.len() - 1;
        let out = &mut mlp.layers[last];
        let scaled = |t: Tensor<2>| t.mul_scalar(OUTPUT_INIT).detach();
        out.weight = burn::module::Param::from_tensor(scaled(out.weight.val()));
        if let Some(b) = out.bias.take() {
            out.bias = Some(burn::module::Param::from_tensor(
                b.val().mul_scalar(OUTPUT_INIT).detach(),
            ));
        }
        Self { mlp }
    }

    /// The tangent vectors: the MLP's output less its component along `p`.
    ///
    /// # Shapes
    /// - input: `[n, noise + labels]`, p: `[1, outputs]` → `[n, outputs]`
    pub fn forward(&self, input: Tensor<2>, p: Tensor<2>) -> Tensor<2> {
        project(self.mlp.forward(input), p)
    }
}

/// `s − ⟨s, p⟩ p` row by row, with the hypersphere's inner product (`Σ / FRAMES`).
///
/// # Shapes
/// - s: `[n, d]`, p: `[1, d]` → `[n, d]`
pub fn project(s: Tensor<2>, p: Tensor<2>) -> Tensor<2> {
    let a = (s.clone() * p.clone()).sum_dim(1).div_scalar(FRAMES as f64);
    s - a * p
}

/// `exp_p(s)` row by row (S2D eq. 8): `cos(‖s‖) p + sin(‖s‖) s / ‖s‖`, the norm the
/// hypersphere's (`‖s‖² = Σ s² / FRAMES`); `‖s‖` is floored at 1e-12 so that a zero row maps
/// to p with a finite gradient.
///
/// # Shapes
/// - s: `[n, d]`, p: `[1, d]` → `[n, d]`
pub fn exp_rows(s: Tensor<2>, p: Tensor<2>) -> Tensor<2> {
    let norm = s
        .clone()
        .powi_scalar(2)
        .sum_dim(1)
        .div_scalar(FRAMES as f64)
        .add_scalar(1e-24)
        .sqrt();
    let k = norm.clone().sin() / norm.clone();
    norm.cos() * p + s * k
}

/// The geodesic distance between unit rows a and b of the hypersphere, `2 asin(‖a − b‖ / 2)`
/// (the arc of the chord: exact, and smooth where the two meet, unlike `acos ⟨a, b⟩`).
///
/// # Shapes
/// - a, b: `[n, d]` → `[n, 1]`
pub fn geodesic_rows(a: Tensor<2>, b: Tensor<2>) -> Tensor<2> {
    let chord = (a - b)
        .powi_scalar(2)
        .sum_dim(1)
        .div_scalar(FRAMES as f64)
        .add_scalar(1e-24)
        .sqrt();
    chord.div_scalar(2.0).clamp_max(1.0).asin().mul_scalar(2.0)
}

/// L_r, the generator's reconstruction loss against the real motions of the same labels, as the
/// reference computes it: the mean absolute difference of the tangent vectors (eq. 4's L1) plus
/// the mean geodesic distance between the two motions on the sphere. The L1 term alone, a mean
/// over 30 × 204 values of about 0.05 each, is too weak beside the critic's unit-norm gradient
/// for the label to shape the motion; the geodesic term pulls each generated motion towards its
/// label's motions with a gradient of unit norm.
///
/// # Shapes
/// - fake, real: `[n, d]` tangent vectors at p: `[1, d]` → `[1]`
pub fn reconstruction(fake: Tensor<2>, real: Tensor<2>, p: &Tensor<2>) -> Tensor<1> {
    let l1 = (fake.clone() - real.clone()).abs().mean();
    let on_sphere = |s: Tensor<2>| exp_rows(s, p.clone());
    let geodesic = geodesic_rows(on_sphere(fake), on_sphere(real).detach()).mean();
    l1 + geodesic
}

/// For each row of `fake`, the row of `real` with the same one-hot label (`labels`, shared by
/// both: the batch's real labels condition its generated motions) at the smallest squared
/// Euclidean distance; a row's own real motion is always a candidate. With the two swapped, for
/// each real motion the nearest generated one of its label.
///
/// # Shapes
/// - fake, real: `[n, d]`, labels: `[n, classes]` → `[n]`
pub fn nearest_of_label(fake: &Tensor<2>, real: &Tensor<2>, labels: &Tensor<2>) -> Tensor<1, Int> {
    let n = fake.dims()[0];
    let ff = fake.clone().square().sum_dim(1);
    let rr = real.clone().square().sum_dim(1).transpose();
    let cross = fake.clone().matmul(real.clone().transpose());
    let distance = ff + rr - cross.mul_scalar(2.0);
    let same = labels.clone().matmul(labels.clone().transpose());
    // Rows of another label are pushed out of reach.
    let masked = distance + same.neg().add_scalar(1.0).mul_scalar(1e30);
    masked.argmin(1).reshape([n])
}

/// L_r ([`reconstruction`]) of the generated motions `fake` against the batch's `real` ones,
/// paired as `pairing` says (both of the batch's one-hot `labels`).
///
/// # Shapes
/// - fake, real: `[n, d]` tangent vectors at p, labels: `[n, classes]` → `[1]`
pub fn paired_reconstruction(
    fake: Tensor<2>,
    real: &Tensor<2>,
    labels: &Tensor<2>,
    p: &Tensor<2>,
    pairing: Pairing,
) -> Tensor<1> {
    if pairing == Pairing::Batch {
        return reconstruction(fake, real.clone(), p);
    }
    // Pairs are chosen on the detached motions, not differentiated through.
    let chosen = fake.clone().detach();
    let nearest_real = real
        .clone()
        .select(0, nearest_of_label(&chosen, real, labels));
    if pairing == Pairing::Nearest {
        return reconstruction(fake, nearest_real, p);
    }
    let nearest_fake = nearest_of_label(real, &chosen, labels);
    let to_real = reconstruction(fake.clone(), nearest_real, p);
    let to_fake = reconstruction(fake.select(0, nearest_fake), real.clone(), p);
    (to_real + to_fake).mul_scalar(0.5)
}

/// The diversity term, a difference from the paper (mode seeking, Mao et al., "Mode Seeking
/// Generative Adversarial Networks for Diverse and Faithful Image Synthesis", CVPR 2019): minus
/// the mean geodesic distance on the sphere between the motions `a` and `b` generated for the
/// same labels from different noise. Weighted by λ_div and added to the generator's loss, it
/// rewards motions that differ by their noise, which L_r's pull towards the nearest real motions
/// does not.
///
/// # Shapes
/// - a, b: `[n, d]` tangent vectors at p: `[1, d]` → `[1]`
pub fn diversity_term(a: Tensor<2>, b: Tensor<2>, p: &Tensor<2>) -> Tensor<1> {
    geodesic_rows(exp_rows(a, p.clone()), exp_rows(b, p.clone()))
        .mean()
        .neg()
}

/// Adam with the reference's β = (0.5, 0.9).
pub fn optimizer() -> Adam {
    Adam::default().with_betas(0.5, 0.9)
}

/// One batch: real tangent vectors, their one-hot labels, the generator's noise and the
/// penalty's mixing weights (drawn by the caller, so that a step's randomness is its own).
#[derive(Clone, Debug)]
pub struct Batch {
    /// `[n, d]`.
    pub real: Tensor<2>,
    /// `[n, labels]`.
    pub labels: Tensor<2>,
    /// z ~ N(0, 1), `[n, noise]`.
    pub noise: Tensor<2>,
    /// τ ~ U(0, 1) of eq. 3, `[n, 1]`.
    pub tau: Tensor<2>,
}

/// The losses of one step, detached.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct StepLosses {
    /// The critic's loss, `E[D(fake)] − E[D(real)] + λ GP`.
    pub critic: f32,
    /// The Wasserstein estimate `E[D(real)] − E[D(fake)]`.
    pub wasserstein: f32,
    /// The gradient penalty.
    pub penalty: f32,
    /// The generator's loss, `α1 L_adv + α2 L_r`.
    pub generator: f32,
    /// L_r: the mean absolute difference from the real tangent vectors plus the mean geodesic
    /// distance from the real motions ([`reconstruction`]).
    pub reconstruction: f32,
    /// The label guide's cross-entropy on the generated motions (0 without a guide; histories
    /// written before the guide existed read 0).
    #[serde(default)]
    pub classes: f32,
}

fn scalar(t: Tensor<1>) -> f32 {
    to_vec(t).first().copied().unwrap_or(f32::NAN)
}

/// One critic step (eq. 2, 3): returns the critic and its losses.
pub fn critic_step(
    generator: &Generator,
    critic: Critic,
    optim: &mut Adam,
    batch: &Batch,
    p: &Tensor<2>,
    config: &GanConfig,
) -> (Critic, StepLosses) {
    let [_, d] = batch.real.dims();
    let fake = generator
        .forward(
            Tensor::cat(vec![batch.noise.clone(), batch.labels.clone()], 1),
            p.clone(),
        )
        .detach();
    let with = |x: Tensor<2>| Tensor::cat(vec![x, batch.labels.clone()], 1);
    let d_real = critic.forward(with(batch.real.clone())).mean();
    let d_fake = critic.forward(with(fake.clone())).mean();
    let tau = batch.tau.clone();
    let mixed = batch.real.clone() * tau.clone() + fake * tau.neg().add_scalar(1.0);
    let (_, slopes) = critic.forward_with_slopes(with(mixed));
    let grad = critic.input_gradient(&slopes).narrow(1, 0, d);
    let penalty = (grad.powi_scalar(2).sum_dim(1).sqrt().sub_scalar(1.0))
        .powi_scalar(2)
        .mean();
    let wasserstein = d_real.clone() - d_fake.clone();
    let loss = d_fake - d_real + penalty.clone().mul_scalar(config.lambda as f64);
    let losses = StepLosses {
        critic: scalar(loss.clone().detach()),
        wasserstein: scalar(wasserstein.detach()),
        penalty: scalar(penalty.detach()),
        ..StepLosses::default()
    };
    let grads = GradientsParams::from_grads(loss.backward(), &critic);
    (optim.step(config.lr, critic, grads), losses)
}

/// One generator step (`L_M = α1 L_adv + α2 L_r`, eq. 2, 4, plus λ_div times the diversity term
/// and λ_cls times the `guide`'s cross-entropy where they are on): returns the generator and its
/// losses.
pub fn generator_step(
    generator: Generator,
    critic: &Critic,
    guide: Option<&LabelGuide>,
    optim: &mut Adam,
    batch: &Batch,
    p: &Tensor<2>,
    config: &GanConfig,
) -> (Generator, StepLosses) {
    let fake = generator.forward(
        Tensor::cat(vec![batch.noise.clone(), batch.labels.clone()], 1),
        p.clone(),
    );
    let adv = critic
        .forward(Tensor::cat(vec![fake.clone(), batch.labels.clone()], 1))
        .mean()
        .neg();
    let rec = paired_reconstruction(fake.clone(), &batch.real, &batch.labels, p, config.pairing);
    let mut loss =
        adv.mul_scalar(config.alpha_adv as f64) + rec.clone().mul_scalar(config.alpha_rec as f64);
    let mut classes = 0.0;
    if let Some(guide) = guide.filter(|_| config.class_weight > 0.0) {
        let ce = guide.cross_entropy(fake.clone(), batch.labels.clone());
        classes = scalar(ce.clone().detach());
        loss = loss + ce.mul_scalar(config.class_weight as f64);
    }
    let n = batch.noise.dims()[0];
    // A batch of one row has no other noise to pair with.
    if config.diversity > 0.0 && n > 1 {
        // The same labels with each row's noise taken from the next row (the last from the
        // first): other noise, no other draw, so a step's randomness stays the batch's.
        let other = Tensor::cat(
            vec![
                batch.noise.clone().narrow(0, 1, n - 1),
                batch.noise.clone().narrow(0, 0, 1),
            ],
            0,
        );
        let again = generator.forward(Tensor::cat(vec![other, batch.labels.clone()], 1), p.clone());
        let div = diversity_term(fake, again, p);
        loss = loss + div.mul_scalar(config.diversity as f64);
    }
    let losses = StepLosses {
        generator: scalar(loss.clone().detach()),
        reconstruction: scalar(rec.detach()),
        classes,
        ..StepLosses::default()
    };
    let grads = GradientsParams::from_grads(loss.backward(), &generator);
    (optim.step(config.lr, generator, grads), losses)
}

#[cfg(test)]
mod tests;
