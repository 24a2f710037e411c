//! Pictures: the software rasteriser with heatmaps and colour bars, and the loss and error plots.

pub mod plot;
pub mod render;
