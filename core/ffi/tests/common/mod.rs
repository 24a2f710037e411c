//! What the C API's tests share: the golden files, error records, and a model handle that frees
//! itself.
#![allow(unsafe_code)] // Calling the C API is `unsafe` by nature; each call site says why it holds.
#![allow(dead_code)] // each test binary uses its own part of it

use std::ffi::CStr;
use std::path::PathBuf;
use std::ptr::null_mut;

use sinew::*;

/// A golden file of `tests/data/`.
pub fn data(name: &str) -> Vec<u8> {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../tests/data")
        .join(name);
    std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// An error record before any call.
pub fn new_error() -> SinewError {
    SinewError {
        status: SinewStatus::Internal,
        message: [0; SINEW_MESSAGE_LEN],
    }
}

/// The error record's message.
pub fn message(err: &SinewError) -> String {
    // Safety: the library always NUL-terminates the message within the array.
    unsafe { CStr::from_ptr(err.message.as_ptr()) }
        .to_str()
        .unwrap()
        .to_owned()
}

/// An open model over bytes the struct keeps alive (the handle borrows them).
pub struct Model {
    /// The handle.
    pub handle: *mut SinewModel,
    _bytes: Vec<u8>,
}

impl Model {
    /// Opens a golden model, requiring success and an empty error record.
    pub fn open(name: &str) -> Self {
        let bytes = data(name);
        let mut handle = null_mut();
        let mut err = new_error();
        // Safety: `bytes` outlives the handle (both in `Model`, freed in `drop` first).
        let status =
            unsafe { sinew_model_open(bytes.as_ptr(), bytes.len(), &mut handle, &mut err) };
        assert_eq!(status, SinewStatus::Ok, "{name}: {}", message(&err));
        assert_eq!(err.status, SinewStatus::Ok);
        assert_eq!(message(&err), "");
        Self {
            handle,
            _bytes: bytes,
        }
    }

    /// The model's info, requiring success.
    pub fn info(&self) -> SinewModelInfo {
        let mut info = std::mem::MaybeUninit::uninit();
        // Safety: a live handle and a writable info.
        let status = unsafe { sinew_model_info(self.handle, info.as_mut_ptr(), null_mut()) };
        assert_eq!(status, SinewStatus::Ok);
        // Safety: written on success.
        unsafe { info.assume_init() }
    }
}

impl Drop for Model {
    fn drop(&mut self) {
        // Safety: opened by `Model::open`, freed once.
        unsafe { sinew_model_free(self.handle) };
    }
}
