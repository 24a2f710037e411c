//! Pictures: the software rasteriser with heatmaps and colour bars, photographs of a face through
//! a pinhole camera (`photo`), and the loss and error plots.

pub mod photo;
pub mod plot;
pub mod render;
