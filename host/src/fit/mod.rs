//! Fitting a baked AIM actor to performances (AIM Sec. 4.2, 5.3): synthetic performances to fit
//! (`performance`).

pub mod performance;
