//! Errors at the boundary: a [`Failure`] is a status code with its message; [`guard`] runs
//! the body of every exported function, keeps the message of a failed call in a thread-local
//! slot and turns a panic into [`LaminaStatus::Panic`], so no unwinding reaches the caller.

use core::ffi::CStr;
use std::cell::RefCell;
use std::ffi::CString;
use std::panic::{AssertUnwindSafe, catch_unwind};

use crate::types::LaminaStatus;

/// A failed call: its status and the text `lamina_last_error_message()` gives.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct Failure {
    /// The code returned to the caller (never `Ok`).
    pub status: LaminaStatus,
    /// What went wrong, naming the argument, the value and the bound.
    pub message: String,
}

impl Failure {
    /// A failure with `status` and `message`.
    pub fn new(status: LaminaStatus, message: impl Into<String>) -> Self {
        Self { status, message: message.into() }
    }
}

thread_local! {
    /// The message of the last failed call on this thread, NUL-terminated.
    static LAST_ERROR: RefCell<CString> = RefCell::new(CString::default());
}

/// Keeps `message` as this thread's last error (inner NUL bytes become spaces).
fn set_last_error(message: &str) {
    let text = CString::new(message.replace('\0', " ")).unwrap_or_default();
    LAST_ERROR.with(|slot| *slot.borrow_mut() = text);
}

/// A pointer to this thread's last error message, valid until the next failing call on this
/// thread (the slot lives as long as the thread).
pub(crate) fn last_error_ptr() -> *const core::ffi::c_char {
    LAST_ERROR.with(|slot| slot.borrow().as_ptr())
}

/// Copies this thread's last error message into `out` (truncated to fit, always
/// NUL-terminated when `out` is not empty); returns the message's full length in bytes.
pub(crate) fn copy_last_error(out: &mut [u8]) -> usize {
    LAST_ERROR.with(|slot| {
        let text = slot.borrow();
        let bytes = text.as_bytes();
        if let Some(room) = out.len().checked_sub(1) {
            let n = bytes.len().min(room);
            out[..n].copy_from_slice(&bytes[..n]);
            out[n] = 0;
        }
        bytes.len()
    })
}

/// The text of a panic's payload.
fn panic_text(payload: &(dyn core::any::Any + Send)) -> &str {
    if let Some(s) = payload.downcast_ref::<&str>() {
        s
    } else if let Some(s) = payload.downcast_ref::<String>() {
        s
    } else {
        "no message"
    }
}

/// Runs `body` for the exported function `function`: `Ok` gives [`LaminaStatus::Ok`] (the
/// last error stays as it was, as `errno` does), a [`Failure`] its status with its message
/// kept, and a panic [`LaminaStatus::Panic`] with a message naming the function.
pub(crate) fn guard(function: &str, body: impl FnOnce() -> Result<(), Failure>) -> LaminaStatus {
    match catch_unwind(AssertUnwindSafe(body)) {
        Ok(Ok(())) => LaminaStatus::Ok,
        Ok(Err(failure)) => {
            set_last_error(&failure.message);
            failure.status
        }
        Err(payload) => {
            set_last_error(&format!(
                "{function}: internal error (a Rust panic, caught): {}; please report it",
                panic_text(payload.as_ref())
            ));
            LaminaStatus::Panic
        }
    }
}

/// `pointer` as a mutable reference, or [`LaminaStatus::NullPointer`] naming `argument` of
/// `function`; a misaligned pointer is [`LaminaStatus::InvalidArgument`].
///
/// # Safety
/// A non-null `pointer` points to a `T` the caller lets this call write.
pub(crate) unsafe fn out_ref<'a, T>(pointer: *mut T, function: &str, argument: &str) -> Result<&'a mut T, Failure> {
    check_pointer(pointer.cast_const(), function, argument)?;
    // SAFETY: non-null and aligned (checked); valid for writes by the caller's contract.
    Ok(unsafe { &mut *pointer })
}

/// `pointer` as a shared reference, with the checks of [`out_ref`].
///
/// # Safety
/// A non-null `pointer` points to a `T` valid for reads during the call.
pub(crate) unsafe fn in_ref<'a, T>(pointer: *const T, function: &str, argument: &str) -> Result<&'a T, Failure> {
    check_pointer(pointer, function, argument)?;
    // SAFETY: non-null and aligned (checked); valid for reads by the caller's contract.
    Ok(unsafe { &*pointer })
}

/// `pointer` as a slice of `len` elements, with the checks of [`out_ref`].
///
/// # Safety
/// A non-null `pointer` points to at least `len` elements the caller lets this call write.
pub(crate) unsafe fn out_slice<'a, T>(
    pointer: *mut T,
    len: usize,
    function: &str,
    argument: &str,
) -> Result<&'a mut [T], Failure> {
    check_pointer(pointer.cast_const(), function, argument)?;
    // SAFETY: non-null and aligned (checked); `len` elements valid for writes by the
    // caller's contract (the caller gave a capacity of at least `len`).
    Ok(unsafe { core::slice::from_raw_parts_mut(pointer, len) })
}

fn check_pointer<T>(pointer: *const T, function: &str, argument: &str) -> Result<(), Failure> {
    if pointer.is_null() {
        return Err(Failure::new(LaminaStatus::NullPointer, format!("{function}: {argument} is NULL")));
    }
    if !pointer.is_aligned() {
        return Err(Failure::new(
            LaminaStatus::InvalidArgument,
            format!("{function}: {argument} ({pointer:p}) is not aligned to {} bytes", align_of::<T>()),
        ));
    }
    Ok(())
}

/// The text of a NUL-terminated UTF-8 string argument.
///
/// # Safety
/// A non-null `pointer` points to a NUL-terminated string valid during the call.
pub(crate) unsafe fn in_str<'a>(
    pointer: *const core::ffi::c_char,
    function: &str,
    argument: &str,
) -> Result<&'a str, Failure> {
    if pointer.is_null() {
        return Err(Failure::new(LaminaStatus::NullPointer, format!("{function}: {argument} is NULL")));
    }
    // SAFETY: non-null and NUL-terminated by the caller's contract.
    let text = unsafe { CStr::from_ptr(pointer) };
    text.to_str()
        .map_err(|e| Failure::new(LaminaStatus::InvalidArgument, format!("{function}: {argument} is not UTF-8 ({e})")))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_panic_in_the_body_becomes_a_status_and_a_message_works() {
        let status = guard("lamina_test", || panic!("boom {}", 7));
        assert_eq!(status, LaminaStatus::Panic);
        // SAFETY: the slot's pointer is valid until the next failing call on this thread.
        let text = unsafe { CStr::from_ptr(last_error_ptr()) }.to_str().unwrap().to_owned();
        assert!(text.starts_with("lamina_test: internal error"), "{text}");
        assert!(text.contains("boom 7"), "{text}");
    }

    #[test]
    fn a_failure_keeps_its_message_and_success_leaves_it_works() {
        let status = guard("f", || Err(Failure::new(LaminaStatus::Timeout, "nothing within 5 ms")));
        assert_eq!(status, LaminaStatus::Timeout);
        assert_eq!(guard("g", || Ok(())), LaminaStatus::Ok);
        let mut buf = [0u8; 8];
        let len = copy_last_error(&mut buf);
        assert_eq!(len, "nothing within 5 ms".len());
        assert_eq!(&buf, b"nothing\0", "truncated to 7 bytes and a NUL");
        assert_eq!(copy_last_error(&mut []), len, "an empty buffer only gets the length");
    }

    #[test]
    fn null_and_misaligned_pointers_are_refused_works() {
        // SAFETY: the checks refuse both pointers before any access.
        let null = unsafe { out_ref::<u64>(core::ptr::null_mut(), "f", "out") }.unwrap_err();
        assert_eq!(null, Failure::new(LaminaStatus::NullPointer, "f: out is NULL"));
        let mut words = [0u64; 2];
        let odd = words.as_mut_ptr().cast::<u8>().wrapping_add(1).cast::<u64>();
        // SAFETY: as above.
        let misaligned = unsafe { out_ref::<u64>(odd, "f", "out") }.unwrap_err();
        assert_eq!(misaligned.status, LaminaStatus::InvalidArgument);
        assert!(misaligned.message.contains("not aligned to 8 bytes"), "{}", misaligned.message);
    }
}
