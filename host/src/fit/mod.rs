//! Fitting a baked AIM actor to performances (AIM Sec. 4.2, 5.3; the performances are
//! [`crate::io::performance`]'s folders, made by [`crate::performance`]): the blendshape
//! baselines of Table 1 (`baseline`), the AIM fit on burn
//! (`aim`; its settings and variables in `setup`, its checkpoints in `checkpoint`), a fit baked
//! into a `.sinew` performance and played through the core (`bake`), per-frame error heatmaps
//! of several fits side by side (`heatmaps`), the commands' work (`commands`) and a fit played
//! on another actor (`retarget`, AIM Sec. 5.4).

pub mod aim;
pub mod bake;
pub mod baseline;
pub mod checkpoint;
pub mod commands;
pub mod heatmaps;
pub mod retarget;
pub mod setup;
