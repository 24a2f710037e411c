//! Fitting a baked AIM actor to performances (AIM Sec. 4.2, 5.3): synthetic performances to fit
//! (`performance`) and the blendshape baselines of Table 1 (`baseline`).

pub mod baseline;
pub mod performance;
