//! Why a call failed ([`Error`]), and which input the core refused ([`Refused`]), named as the
//! JavaScript API names it.

use std::fmt;

use sinew_core::error::{Argument, EvalError, InputError};
use sinew_core::replay;

/// Why a call failed: the core's message ([`sinew_core::FormatError`], `BufferError`,
/// `InputError` or `ReplayError` as displayed, a refused input named as the JavaScript API names
/// the argument) or this crate's own about a caller's input.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Error {
    pub(crate) message: String,
    pub(crate) input: Option<Refused>,
}

/// Which input the core refused, named as the JavaScript call names the argument: what the
/// JavaScript `InputError` carries besides the message.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Refused {
    /// The argument's name in the JavaScript API (`head`, `coefficients`, `neutralLandmarks`).
    pub argument: &'static str,
    /// The value's index in it (for a degenerate 6D rotation, its column's first index).
    pub index: usize,
}

impl Error {
    pub(crate) fn new(message: impl Into<String>) -> Self {
        Self {
            message: message.into(),
            input: None,
        }
    }

    /// The message.
    pub fn message(&self) -> &str {
        &self.message
    }

    /// The refused input, when the core refused one of the call's values.
    pub fn refused(&self) -> Option<Refused> {
        self.input
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::error::Error for Error {}

impl From<sinew_core::FormatError> for Error {
    fn from(e: sinew_core::FormatError) -> Self {
        Self::new(e.to_string())
    }
}

impl From<sinew_core::BufferError> for Error {
    fn from(e: sinew_core::BufferError) -> Self {
        Self::new(e.to_string())
    }
}

impl From<replay::ReplayError> for Error {
    fn from(e: replay::ReplayError) -> Self {
        match e {
            replay::ReplayError::Input(e) => e.into(),
            e => Self::new(e.to_string()),
        }
    }
}

impl From<InputError> for Error {
    fn from(e: InputError) -> Self {
        Self::input(e, &[])
    }
}

impl From<EvalError> for Error {
    fn from(e: EvalError) -> Self {
        match e {
            EvalError::Input(e) => e.into(),
            e => Self::new(e.to_string()),
        }
    }
}

impl Error {
    /// The core's message about a refused input, with the argument named as the JavaScript call
    /// names it: `coefficients` for the core's `weights`, and the names in `rename`.
    pub(crate) fn input(e: InputError, rename: &[(Argument, &'static str)]) -> Self {
        let core = e.argument.name();
        let js = rename
            .iter()
            .find(|(a, _)| *a == e.argument)
            .map(|(_, name)| *name)
            .unwrap_or(match e.argument {
                Argument::Weights => "coefficients",
                _ => core,
            });
        let message = e.to_string();
        Self {
            message: match message.strip_prefix(core) {
                Some(rest) => format!("{js}{rest}"),
                None => message,
            },
            input: Some(Refused {
                argument: js,
                index: e.index,
            }),
        }
    }

    /// [`Self::input`] for an input refusal, the message as it is otherwise.
    pub(crate) fn eval(e: EvalError, rename: &[(Argument, &'static str)]) -> Self {
        match e {
            EvalError::Input(e) => Self::input(e, rename),
            e => e.into(),
        }
    }
}
