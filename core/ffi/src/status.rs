//! Status codes, the caller's error record, and the one wrapper every entry point runs in.

use std::ffi::{CStr, c_char};
use std::fmt::Display;
use std::panic::{AssertUnwindSafe, catch_unwind};

use sinew_core::replay::ReplayError;
use sinew_core::{BufferError, EvalError, FormatError, InputError};

/// Bytes in [`SinewError::message`], the terminating NUL included. Longer messages are cut at a
/// character boundary.
pub const SINEW_MESSAGE_LEN: usize = 256;

/// What a call returns. `SINEW_STATUS_OK` is 0; every failure is non-zero and, when the caller
/// passed a [`SinewError`], comes with a message naming the problem.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SinewStatus {
    /// Success.
    Ok = 0,
    /// A required pointer argument is NULL.
    NullPointer = 1,
    /// The bytes are not a valid artefact (truncated, corrupted, misshapen); the message says why.
    InvalidFormat = 2,
    /// The artefact or handle is of another kind than the call needs (e.g. an AIM call on an S2D
    /// decoder, a network file given as a model).
    WrongKind = 3,
    /// A buffer has the wrong length or a float buffer is not 4-byte aligned.
    BufferLength = 4,
    /// An index or code is out of range (frame past the end, unknown mode).
    OutOfRange = 5,
    /// The model cannot do what was asked (Q16 mode on a model baked without the Q16.16 cache).
    Unsupported = 6,
    /// A replay was recorded with another model, or does not fit this one.
    ModelMismatch = 7,
    /// An internal error was caught before it crossed the C boundary (a bug: please report it).
    Internal = 8,
    /// A number the caller gave is refused: NaN, infinite, outside its documented range, or
    /// degenerate (a 6D rotation's column too short or parallel to the other, a landmark set
    /// whose points all coincide). The message names the argument and the index.
    InvalidInput = 9,
    /// What was asked for is not in the artefact: a metadata key it does not record.
    NotFound = 10,
}

impl SinewStatus {
    /// What the status means, in a few words (the text `sinew_status_string` returns).
    const fn text(code: u32) -> &'static CStr {
        match code {
            0 => c"success",
            1 => c"a required pointer is NULL",
            2 => c"the bytes are not a valid artefact",
            3 => c"the artefact or handle is of another kind than the call needs",
            4 => c"a buffer has the wrong length or alignment",
            5 => c"an index or code is out of range",
            6 => c"the model cannot do what was asked",
            7 => c"the replay was recorded with another model, or does not fit it",
            8 => c"internal error (a bug: please report it)",
            9 => c"an input value is NaN, infinite, out of range or degenerate",
            10 => c"the artefact does not record what was asked for",
            _ => c"unknown status",
        }
    }
}

/// What a status code means, as a static NUL-terminated sentence ("a buffer has the wrong length
/// or alignment"), for callers that passed no `SinewError`. An unknown code gives "unknown
/// status". The string is never freed.
// Safety (of the unmangled symbol): the name is unique to this library, prefixed `sinew_`.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub extern "C" fn sinew_status_string(status: u32) -> *const c_char {
    SinewStatus::text(status).as_ptr()
}

/// A call's failure, written by every entry point that takes one (pass NULL to skip it). On
/// success `status` is `SINEW_STATUS_OK` and `message` is empty.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct SinewError {
    /// The same status the call returned.
    pub status: SinewStatus,
    /// A NUL-terminated UTF-8 sentence naming the problem.
    pub message: [c_char; SINEW_MESSAGE_LEN],
}

/// A failure inside the crate, before it is written out for the caller.
#[derive(Debug)]
pub(crate) struct Fail {
    pub(crate) status: SinewStatus,
    pub(crate) message: String,
}

impl Fail {
    pub(crate) fn new(status: SinewStatus, message: impl Display) -> Self {
        Self {
            status,
            message: message.to_string(),
        }
    }

    pub(crate) fn null(what: &str) -> Self {
        Self::new(SinewStatus::NullPointer, format_args!("{what} is NULL"))
    }

    pub(crate) fn format(what: &str, e: FormatError) -> Self {
        Self::new(SinewStatus::InvalidFormat, format_args!("{what}: {e}"))
    }

    pub(crate) fn buffer(what: &str, e: BufferError) -> Self {
        Self::new(SinewStatus::BufferLength, format_args!("{what}: {e}"))
    }

    /// A refused input: the core's message names the argument (as the C parameter) and index.
    pub(crate) fn input(e: InputError) -> Self {
        Self::new(SinewStatus::InvalidInput, e)
    }

    /// A frame call's failure: a buffer (`what: ` and the core's message) or a refused input.
    pub(crate) fn eval(what: &str, e: EvalError) -> Self {
        match e {
            EvalError::Input(e) => Self::input(e),
            EvalError::Buffer(e) => Self::buffer(what, e),
            e => Self::new(SinewStatus::Internal, format_args!("{what}: {e}")),
        }
    }

    pub(crate) fn replay(e: ReplayError) -> Self {
        let status = match e {
            ReplayError::NoQ16Cache => SinewStatus::Unsupported,
            ReplayError::Buffer(_) => SinewStatus::BufferLength,
            ReplayError::Input(_) => SinewStatus::InvalidInput,
            _ => SinewStatus::ModelMismatch,
        };
        Self::new(status, e)
    }
}

pub(crate) type Result<T, E = Fail> = std::result::Result<T, E>;

/// Writes `status` and `message` to `err` (when not NULL), cut to fit with a NUL at the end.
fn report(err: *mut SinewError, status: SinewStatus, message: &str) {
    if err.is_null() {
        return;
    }
    let mut cut = message.len().min(SINEW_MESSAGE_LEN - 1);
    while !message.is_char_boundary(cut) {
        cut -= 1;
    }
    let mut record = SinewError {
        status,
        message: [0; SINEW_MESSAGE_LEN],
    };
    for (d, s) in record.message.iter_mut().zip(&message.as_bytes()[..cut]) {
        *d = *s as c_char;
    }
    #[allow(unsafe_code)]
    // Safety: `err` is not NULL, and the caller promises it points to a writable `SinewError`
    // (documented on every entry point); an unaligned pointer is written unaligned.
    unsafe {
        err.write_unaligned(record);
    }
}

/// Runs one entry point's body: catches any panic (it must not unwind into C), and reports the
/// outcome to `err`.
pub(crate) fn guard(err: *mut SinewError, body: impl FnOnce() -> Result<()>) -> SinewStatus {
    let outcome = catch_unwind(AssertUnwindSafe(body)).unwrap_or_else(|payload| {
        let what = payload
            .downcast_ref::<&str>()
            .copied()
            .or_else(|| payload.downcast_ref::<String>().map(String::as_str))
            .unwrap_or("unknown");
        Err(Fail::new(
            SinewStatus::Internal,
            format_args!("internal error (caught panic: {what})"),
        ))
    });
    match outcome {
        Ok(()) => {
            report(err, SinewStatus::Ok, "");
            SinewStatus::Ok
        }
        Err(fail) => {
            report(err, fail.status, &fail.message);
            fail.status
        }
    }
}
