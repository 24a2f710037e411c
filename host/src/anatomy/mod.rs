//! The actor's anatomy: sparse skin-to-bone constraints (AIM eq. 12), template bones fitted inside
//! a neutral face (`sinew bones fit`), and the real Badin skin + bone pair that checks them.

pub mod badin;
pub mod bones;
pub mod constraints;
pub mod fit;
