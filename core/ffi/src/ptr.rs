//! Turning the caller's pointers into slices and references, with every check that can be made
//! from this side: NULL, alignment, and a length that fits the address space. What cannot be
//! checked (that the memory is really there, and not written by someone else meanwhile) is the
//! caller's promise, stated on each entry point.

use std::ffi::{CStr, c_char};
use std::mem::{align_of, size_of};

use crate::status::{Fail, Result, SinewStatus};

/// Checks `ptr` for a `len`-element slice of `T`: not NULL (even when `len` is 0), aligned, and
/// `len` elements within `isize::MAX` bytes.
fn check<T>(ptr: *const T, len: usize, what: &str) -> Result<()> {
    if ptr.is_null() {
        return Err(Fail::null(what));
    }
    if !(ptr as usize).is_multiple_of(align_of::<T>()) {
        return Err(Fail::new(
            SinewStatus::BufferLength,
            format_args!("{what} is not aligned to {} bytes", align_of::<T>()),
        ));
    }
    if len
        .checked_mul(size_of::<T>())
        .is_none_or(|bytes| bytes > isize::MAX as usize)
    {
        return Err(Fail::new(
            SinewStatus::BufferLength,
            format_args!("{what}: length {len} is larger than memory"),
        ));
    }
    Ok(())
}

/// The caller's `len` elements at `ptr`, read-only.
///
/// The returned lifetime is the caller's to uphold: the memory must stay valid and unwritten for
/// as long as the slice is used (one call, or a handle's life for model and replay bytes).
pub(crate) fn slice<'a, T>(ptr: *const T, len: usize, what: &str) -> Result<&'a [T]> {
    check(ptr, len, what)?;
    #[allow(unsafe_code)]
    // Safety: `ptr` is not NULL, aligned and `len` elements fit in `isize::MAX` bytes (checked
    // above); the caller promises `len` initialised elements there, not written during the call.
    Ok(unsafe { std::slice::from_raw_parts(ptr, len) })
}

/// The caller's `len` elements at `ptr`, writable.
pub(crate) fn slice_mut<'a, T>(ptr: *mut T, len: usize, what: &str) -> Result<&'a mut [T]> {
    check(ptr, len, what)?;
    #[allow(unsafe_code)]
    // Safety: as in `slice`; the caller also promises that nothing else reads or writes the
    // memory during the call (in particular that it does not overlap another argument).
    Ok(unsafe { std::slice::from_raw_parts_mut(ptr, len) })
}

/// Like [`slice`], but a NULL `ptr` is `None` (an optional argument).
pub(crate) fn optional<'a, T>(ptr: *const T, len: usize, what: &str) -> Result<Option<&'a [T]>> {
    if ptr.is_null() {
        Ok(None)
    } else {
        slice(ptr, len, what).map(Some)
    }
}

/// Like [`slice_mut`], but a NULL `ptr` is `None` (an optional argument).
pub(crate) fn optional_mut<'a, T>(
    ptr: *mut T,
    len: usize,
    what: &str,
) -> Result<Option<&'a mut [T]>> {
    if ptr.is_null() {
        Ok(None)
    } else {
        slice_mut(ptr, len, what).map(Some)
    }
}

/// The caller's nine floats at `ptr` (a 6D rotation and a translation).
pub(crate) fn nine(ptr: *const f32, what: &str) -> Result<[f32; 9]> {
    let s = slice(ptr, 9, what)?;
    let mut out = [0.0; 9];
    out.copy_from_slice(s);
    Ok(out)
}

/// Writes `value` to the caller's `*ptr` (an out-parameter, which may be uninitialised).
pub(crate) fn write<T: Copy>(ptr: *mut T, value: T, what: &str) -> Result<()> {
    check(ptr, 1, what)?;
    #[allow(unsafe_code)]
    // Safety: `ptr` is not NULL and aligned (checked above); the caller promises it points to
    // writable memory for one `T`. `write` neither reads nor drops the old contents.
    unsafe {
        ptr.write(value);
    }
    Ok(())
}

/// Hands `value` to the caller as a new handle in `*out`, to be released with [`release`] by the
/// type's `_free` entry point. `out` is checked before the handle is made, so a bad `out` leaks
/// nothing.
pub(crate) fn hand_out<T>(out: *mut *mut T, value: T, what: &str) -> Result<()> {
    check(out, 1, what)?;
    write(out, Box::into_raw(Box::new(value)), what)
}

/// Releases a handle made by [`hand_out`]; NULL is ignored. Dropping a handle runs no code of
/// ours that could panic, but a panic must never unwind into C, so it is caught all the same
/// (and the handle leaked).
///
/// # Safety
/// `handle` is NULL or a handle of this `T` from [`hand_out`] not yet released; no other call may
/// be using it, and it must not be used afterwards.
#[allow(unsafe_code)]
pub(crate) unsafe fn release<T>(handle: *mut T) {
    if handle.is_null() {
        return;
    }
    let _ = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        // Safety: `handle` came from `Box::into_raw` in `hand_out` and is released once (the
        // caller's promise above).
        drop(unsafe { Box::from_raw(handle) });
    }));
}

/// The caller's handle at `ptr`, shared.
pub(crate) fn handle<'a, T>(ptr: *const T, what: &str) -> Result<&'a T> {
    slice(ptr, 1, what).map(|s| &s[0])
}

/// Copies `text` and a terminating NUL into the caller's `buf` of `len` bytes, and writes the
/// bytes that takes (the text's length plus one) to `*needed` when `needed` is not NULL. A NULL
/// `buf` with `len` 0 and a non-NULL `needed` is a size query: only `*needed` is written.
pub(crate) fn write_text(
    text: &str,
    buf: *mut c_char,
    len: usize,
    needed: *mut usize,
) -> Result<()> {
    let need = text.len() + 1;
    if !needed.is_null() {
        write(needed, need, "needed")?;
        if buf.is_null() && len == 0 {
            return Ok(());
        }
    }
    let out = slice_mut(buf.cast::<u8>(), len, "buf")?;
    let Some((head, tail)) = out.split_at_mut_checked(text.len()) else {
        return Err(Fail::new(
            SinewStatus::BufferLength,
            format_args!("buf has {len} bytes, the text needs {need} with its NUL"),
        ));
    };
    let Some(nul) = tail.first_mut() else {
        return Err(Fail::new(
            SinewStatus::BufferLength,
            format_args!("buf has {len} bytes, the text needs {need} with its NUL"),
        ));
    };
    head.copy_from_slice(text.as_bytes());
    *nul = 0;
    Ok(())
}

/// The caller's NUL-terminated UTF-8 string at `ptr`.
///
/// The caller promises a NUL within readable memory at `ptr`.
pub(crate) fn c_str<'a>(ptr: *const c_char, what: &str) -> Result<&'a str> {
    if ptr.is_null() {
        return Err(Fail::null(what));
    }
    #[allow(unsafe_code)]
    // Safety: `ptr` is not NULL; the caller promises a NUL-terminated string there, unchanged
    // during the call.
    let s = unsafe { CStr::from_ptr(ptr) };
    s.to_str().map_err(|_| {
        Fail::new(
            SinewStatus::InvalidInput,
            format_args!("{what} is not UTF-8"),
        )
    })
}
