//! Networks stored in a `.sinew` file: how an [`Mlp`] is laid out as sections, and its loader.
//!
//! An MLP under prefix `p` with `L` layers is stored as
//! - `p.act`: `u32 [L]`, the activation code of each layer ([`Activation::code`]);
//! - `p.par`: `f32 [L]`, the activation parameter of each layer (ω0 for sine, α for ELU, else 0);
//! - `p.<i>.w`: `f32 [out, in]`, layer `i`'s weight, row-major (one row per output);
//! - `p.<i>.b`: `f32 [out]`, layer `i`'s bias.

use crate::error::{Bound, FormatError, NetworkLimit, SectionName};
use crate::format::SinewFile;
use crate::nn::{Activation, Dense, MAX_LAYERS, Mlp};

/// Longest MLP prefix, so that `prefix.<i>.w` fits the format's section-name field.
pub const MAX_PREFIX_LEN: usize = crate::format::NAME_LEN - 5;

fn name(
    prefix: &str,
    layer: usize,
    suffix: &str,
) -> Result<heapless::String<{ crate::format::NAME_LEN }>, FormatError> {
    let mut s = heapless::String::new();
    let mut digits = [0u8; 2];
    let digit_str = match layer {
        0..=9 => {
            digits[0] = b'0' + layer as u8;
            core::str::from_utf8(digits.get(..1).unwrap_or(&[])).unwrap_or("")
        }
        10..=99 => {
            digits = [b'0' + (layer / 10) as u8, b'0' + (layer % 10) as u8];
            core::str::from_utf8(&digits).unwrap_or("")
        }
        _ => return Err(FormatError::limit_exceeded(prefix, layer + 1, 100)),
    };
    let parts = [prefix, ".", digit_str, suffix];
    let len: usize = parts.iter().map(|p| p.len()).sum();
    for part in parts {
        s.push_str(part)
            .map_err(|()| FormatError::limit_exceeded(prefix, len, crate::format::NAME_LEN))?;
    }
    Ok(s)
}

fn simple_name(
    prefix: &str,
    suffix: &str,
) -> Result<heapless::String<{ crate::format::NAME_LEN }>, FormatError> {
    let mut s = heapless::String::new();
    let too_long = |()| {
        let len = prefix.len() + suffix.len();
        FormatError::limit_exceeded(prefix, len, crate::format::NAME_LEN)
    };
    s.push_str(prefix).map_err(too_long)?;
    s.push_str(suffix).map_err(too_long)?;
    Ok(s)
}

/// Loads the MLP stored under `prefix` (see the module documentation), validating every shape.
pub fn load_mlp<'a>(file: &SinewFile<'a>, prefix: &str) -> Result<Mlp<'a>, FormatError> {
    if prefix.len() > MAX_PREFIX_LEN {
        return Err(FormatError::limit_exceeded(
            prefix,
            prefix.len(),
            MAX_PREFIX_LEN,
        ));
    }
    let acts_name = simple_name(prefix, ".act")?;
    let acts_section = file
        .section(&acts_name)
        .ok_or_else(|| crate::format::missing(&acts_name))?;
    let acts = acts_section
        .u32s()
        .ok_or_else(|| crate::format::wrong_dtype(&acts_name))?;
    let layers = acts.len();
    if layers == 0 || acts_section.dims().len() != 1 {
        return Err(FormatError::incompatible_shapes(&acts_name));
    }
    if layers > MAX_LAYERS {
        return Err(FormatError::limit_exceeded(&acts_name, layers, MAX_LAYERS));
    }
    let params = file.f32_tensor_within(
        &simple_name(prefix, ".par")?,
        &[layers as u32],
        Bound::Factor,
    )?;
    let mut dense: heapless::Vec<Dense<'a>, MAX_LAYERS> = heapless::Vec::new();
    for i in 0..layers {
        let w_name = name(prefix, i, ".w")?;
        let (shape, rank) = file.dims_of(&w_name)?;
        let [outputs, inputs, ..] = shape;
        if rank != 2 {
            return Err(FormatError::incompatible_shapes(&w_name));
        }
        let weight = file.f32_tensor(&w_name, &[outputs, inputs])?;
        // Each layer takes the previous layer's outputs (named here by the layer's own weight).
        if dense.last().is_some_and(|l| l.outputs() != inputs as usize) {
            return Err(FormatError::incompatible_shapes(&w_name));
        }
        let bias = file.f32_tensor(&name(prefix, i, ".b")?, &[outputs])?;
        let act = Activation::from_code(acts.at(i), params.at(i)).map_err(|e| match e {
            FormatError::UnknownCode { code, .. } => FormatError::unknown_code(&acts_name, i, code),
            e => e,
        })?;
        let layer = Dense::new(weight, bias, inputs as usize, outputs as usize, act)
            .map_err(|e| e.in_section(&w_name))?;
        dense
            .push(layer)
            .map_err(|_| FormatError::limit_exceeded(&acts_name, layers, MAX_LAYERS))?;
    }
    Mlp::new(&dense).map_err(|e| e.in_section(prefix))
}

/// The worst-case magnitude of the outputs of `mlp`, loaded under `prefix`, for inputs of
/// magnitude at most `input` ([`Mlp::bound`]): what a loader checks before it accepts a network
/// (docs/FORMAT.md, "Value bounds").
///
/// # Errors
/// [`FormatError::Unbounded`] naming the layer's weight section `prefix.<i>.w` and the row.
pub fn check_bound(mlp: &Mlp<'_>, prefix: &str, input: f64) -> Result<f64, FormatError> {
    check_bound_within(mlp, prefix, input, NetworkLimit::Values)
}

/// [`check_bound`] with the network's outputs held to `outputs` as well
/// ([`Mlp::bound_within`]).
///
/// # Errors
/// As [`check_bound`], the error naming `outputs` where the last layer passes it.
pub fn check_bound_within(
    mlp: &Mlp<'_>,
    prefix: &str,
    input: f64,
    outputs: NetworkLimit,
) -> Result<f64, FormatError> {
    let last = mlp.layers().len().saturating_sub(1);
    mlp.bound_within(input, outputs.value())
        .map_err(|(layer, row)| FormatError::Unbounded {
            section: name(prefix, layer, ".w")
                .map_or_else(|_| SectionName::new(prefix), |n| SectionName::new(&n)),
            row: u32::try_from(row).unwrap_or(u32::MAX),
            limit: if layer == last {
                outputs
            } else {
                NetworkLimit::Values
            },
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn section_names() {
        assert_eq!(name("b", 0, ".w").unwrap().as_str(), "b.0.w");
        assert_eq!(name("net", 12, ".b").unwrap().as_str(), "net.12.b");
        assert!(name("x", 100, ".w").is_err());
        assert!(name(&"p".repeat(MAX_PREFIX_LEN), 99, ".w").is_ok());
        assert!(name(&"p".repeat(MAX_PREFIX_LEN + 1), 99, ".w").is_err());
    }
}
