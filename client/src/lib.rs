//! `lamina-client`: a C ABI for programs that are not Rust (C, C++, C# through P/Invoke) to
//! join a running Lamina core on the same host.
//!
//! # What a program does
//! 1. [`lamina_open`] joins the user's iceoryx2 domain under a service prefix and waits for
//!    the core's topology; it gives a [`LaminaClient`] handle.
//! 2. [`lamina_topology_info`], [`lamina_layer_info`], [`lamina_surface_info`],
//!    [`lamina_surface_indices`], [`lamina_triangles`] and [`lamina_rest_positions`] read the
//!    model.
//! 3. [`lamina_next_frame`] (every frame, in order) or [`lamina_latest_frame`] (the newest)
//!    copies a node frame into the caller's buffer: **one copy**, from the core's shared
//!    memory straight into the buffer, and the core's chunk is returned before the call ends.
//! 4. [`lamina_send_sphere`], [`lamina_send_grasp`], [`lamina_send_scalpel`] or [`lamina_send_tool`] move the tool;
//!    [`lamina_latest_feedback`] reads the contact force.
//! 5. [`lamina_close`].
//!
//! Every call returns a [`LaminaStatus`]; on failure [`lamina_last_error_message`] gives the
//! text (per thread). No call unwinds into the caller: each body runs under `catch_unwind`,
//! and a caught panic is [`LaminaStatus::Panic`]. Handles are numbers checked on every call,
//! so a closed or made-up handle is refused, not followed.
//!
//! # Examples
//!
//! ```
//! use lamina_client::*;
//!
//! let mut client: LaminaClient = 0;
//! // No core runs on this prefix: the call waits 50 ms and says so.
//! let status = unsafe { lamina_open(c"doc_client_none".as_ptr(), 50, &mut client) };
//! assert_eq!(status, LaminaStatus::Timeout);
//! assert_eq!(client, 0);
//! let message = unsafe { core::ffi::CStr::from_ptr(lamina_last_error_message()) };
//! assert!(message.to_str().unwrap().contains("no Lamina core answered on prefix 'doc_client_none'"));
//! ```

mod client;
mod failure;
mod handles;
pub mod types;

use core::ffi::c_char;
use core::time::Duration;

use client::{Client, check_capacity};
use failure::{guard, in_ref, in_str, out_ref, out_slice};
pub use types::*;

fn millis(timeout_ms: u32) -> Duration {
    Duration::from_millis(u64::from(timeout_ms))
}

/// The ABI version of this library (`LAMINA_ABI_VERSION` of the header it was built with).
#[unsafe(no_mangle)]
pub extern "C" fn lamina_abi_version() -> u32 {
    LAMINA_ABI_VERSION
}

/// The message of the last call on this thread that failed, UTF-8, NUL-terminated; "" when
/// none failed. The pointer stays valid until the next failing call on this thread.
#[unsafe(no_mangle)]
pub extern "C" fn lamina_last_error_message() -> *const c_char {
    std::panic::catch_unwind(failure::last_error_ptr).unwrap_or(c"".as_ptr())
}

/// Copies the last error message of this thread into `buffer` (`capacity` bytes), truncated
/// to fit and NUL-terminated when `capacity` > 0; returns the message's full length in bytes
/// without the NUL. For callers that cannot read a C string (C# on Mono: copy into a `byte[]`).
///
/// # Safety
/// `buffer` is NULL (then only the length is returned) or valid for `capacity` bytes.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn lamina_last_error_copy(buffer: *mut c_char, capacity: usize) -> usize {
    std::panic::catch_unwind(|| {
        if buffer.is_null() {
            return failure::copy_last_error(&mut []);
        }
        // SAFETY: non-null and valid for `capacity` bytes by the caller's contract.
        let out = unsafe { core::slice::from_raw_parts_mut(buffer.cast::<u8>(), capacity) };
        failure::copy_last_error(out)
    })
    .unwrap_or(0)
}

/// The name of a status code (`"LAMINA_STATUS_TIMEOUT"`), or `"LAMINA_STATUS_UNKNOWN"` for a
/// value that is none. The string is static.
#[unsafe(no_mangle)]
pub extern "C" fn lamina_status_name(status: i32) -> *const c_char {
    let name = match status {
        0 => c"LAMINA_STATUS_OK",
        1 => c"LAMINA_STATUS_NULL_POINTER",
        2 => c"LAMINA_STATUS_INVALID_ARGUMENT",
        3 => c"LAMINA_STATUS_BAD_HANDLE",
        4 => c"LAMINA_STATUS_WRONG_THREAD",
        5 => c"LAMINA_STATUS_CONNECT",
        6 => c"LAMINA_STATUS_TIMEOUT",
        7 => c"LAMINA_STATUS_CORE_GONE",
        8 => c"LAMINA_STATUS_PROTOCOL",
        9 => c"LAMINA_STATUS_BUFFER_TOO_SMALL",
        10 => c"LAMINA_STATUS_NO_TOOL",
        11 => c"LAMINA_STATUS_IPC",
        12 => c"LAMINA_STATUS_PANIC",
        _ => c"LAMINA_STATUS_UNKNOWN",
    };
    name.as_ptr()
}

/// Joins the core on service prefix `prefix` (`"lamina"` unless the core was started with
/// `--prefix`): opens the user's iceoryx2 domain (creating its folder `0700` when this
/// client comes first), subscribes to node frames and feedback, and waits up to `timeout_ms`
/// milliseconds for the core's topology (a running core hands it over within a second).
/// On success `*out_client` is the new handle; on failure it is left as it was.
///
/// Errors: `LAMINA_STATUS_TIMEOUT` when no core answered in time, `LAMINA_STATUS_CONNECT`
/// when the domain or a service cannot be opened, `LAMINA_STATUS_INVALID_ARGUMENT` for a
/// prefix that is not UTF-8 or not a valid service prefix.
///
/// # Safety
/// `prefix` is NULL or a NUL-terminated string; `out_client` is NULL or valid for writes.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn lamina_open(
    prefix: *const c_char,
    timeout_ms: u32,
    out_client: *mut LaminaClient,
) -> LaminaStatus {
    const F: &str = "lamina_open";
    guard(F, || {
        // SAFETY: the caller's contract.
        let prefix = unsafe { in_str(prefix, F, "prefix") }?;
        // SAFETY: the caller's contract.
        let out = unsafe { out_ref(out_client, F, "out_client") }?;
        let client = Client::open(prefix, millis(timeout_ms))?;
        *out = handles::insert(client);
        Ok(())
    })
}

/// Closes `client`: its ports and iceoryx2 node go; the handle is refused from then on.
#[unsafe(no_mangle)]
pub extern "C" fn lamina_close(client: LaminaClient) -> LaminaStatus {
    const F: &str = "lamina_close";
    guard(F, || handles::remove(F, client))
}

/// Fills `*out` with the model's counts and the scene's tool.
///
/// # Safety
/// `out` is NULL or valid for writes.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn lamina_topology_info(client: LaminaClient, out: *mut LaminaTopologyInfo) -> LaminaStatus {
    const F: &str = "lamina_topology_info";
    guard(F, || {
        // SAFETY: the caller's contract.
        let out = unsafe { out_ref(out, F, "out") }?;
        *out = handles::with(F, client, |c| Ok(c.topology_info()))?;
        Ok(())
    })
}

/// Fills `*out` with layer `index` (below `layer_count`).
///
/// # Safety
/// `out` is NULL or valid for writes.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn lamina_layer_info(
    client: LaminaClient,
    index: u32,
    out: *mut LaminaLayerInfo,
) -> LaminaStatus {
    const F: &str = "lamina_layer_info";
    guard(F, || {
        // SAFETY: the caller's contract.
        let out = unsafe { out_ref(out, F, "out") }?;
        *out = handles::with(F, client, |c| c.layer_info(index))?;
        Ok(())
    })
}

/// Fills `*out` with surface `index` (below `surface_count`).
///
/// # Safety
/// `out` is NULL or valid for writes.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn lamina_surface_info(
    client: LaminaClient,
    index: u32,
    out: *mut LaminaSurfaceInfo,
) -> LaminaStatus {
    const F: &str = "lamina_surface_info";
    guard(F, || {
        // SAFETY: the caller's contract.
        let out = unsafe { out_ref(out, F, "out") }?;
        *out = handles::with(F, client, |c| c.surface_info(index))?;
        Ok(())
    })
}

/// The shared body of the calls that copy a table of the topology into the caller's buffer:
/// `pick` chooses the table, `per_entry` values make one entry (3 for a position), and
/// `capacity` and `*out_count` count entries.
///
/// # Safety
/// `buffer` is NULL or valid for `per_entry · capacity` writes; `out_count` is NULL or valid
/// for writes.
unsafe fn copy_table<T: Copy>(
    function: &'static str,
    client: LaminaClient,
    (buffer, argument): (*mut T, &'static str),
    capacity: usize,
    per_entry: usize,
    out_count: *mut usize,
    pick: impl FnOnce(&Client) -> Result<&[T], failure::Failure>,
) -> LaminaStatus {
    guard(function, || {
        // SAFETY: the caller's contract.
        let count = unsafe { out_ref(out_count, function, "out_count") }?;
        handles::with(function, client, |c| {
            let table = pick(c)?;
            check_capacity(function, argument, capacity, table.len() / per_entry)?;
            // SAFETY: the caller's contract; `per_entry · capacity` >= the length written.
            unsafe { out_slice(buffer, table.len(), function, argument) }?.copy_from_slice(table);
            *count = table.len() / per_entry;
            Ok(())
        })
    })
}

/// Copies surface `index`'s node indices (`index_count` of them: a grid row-major, or three
/// per triangle) into `indices`, which holds `capacity` entries; `*out_count` is set to the
/// number written.
///
/// # Safety
/// `indices` is NULL or valid for `capacity` writes; `out_count` is NULL or valid for writes.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn lamina_surface_indices(
    client: LaminaClient,
    index: u32,
    indices: *mut u32,
    capacity: usize,
    out_count: *mut usize,
) -> LaminaStatus {
    const F: &str = "lamina_surface_indices";
    // SAFETY: the caller's contract, passed on.
    unsafe {
        copy_table(F, client, (indices, "indices"), capacity, 1, out_count, |c| Ok(&c.surface(F, index)?.indices))
    }
}

/// Copies the outer-surface triangles into `indices` (three node indices per triangle,
/// counter-clockwise seen from outside), which holds `capacity` entries (at least
/// `3 · triangle_count`); `*out_count` is set to the number of entries written.
///
/// # Safety
/// As `lamina_surface_indices`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn lamina_triangles(
    client: LaminaClient,
    indices: *mut u32,
    capacity: usize,
    out_count: *mut usize,
) -> LaminaStatus {
    // SAFETY: the caller's contract, passed on.
    unsafe {
        copy_table("lamina_triangles", client, (indices, "indices"), capacity, 1, out_count, |c| {
            Ok(c.topology().triangles.as_flattened())
        })
    }
}

/// Copies the nodes' rest positions (`[x, y, z]` per node, m, model frame) into `positions`,
/// which holds `capacity_nodes` nodes (`3 · capacity_nodes` floats); `*out_count` is set to
/// the number of nodes written (0 when the core sends none).
///
/// # Safety
/// `positions` is NULL or valid for `3 · capacity_nodes` writes; `out_count` is NULL or valid
/// for writes.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn lamina_rest_positions(
    client: LaminaClient,
    positions: *mut f32,
    capacity_nodes: usize,
    out_count: *mut usize,
) -> LaminaStatus {
    // SAFETY: the caller's contract, passed on.
    unsafe {
        copy_table("lamina_rest_positions", client, (positions, "positions"), capacity_nodes, 3, out_count, |c| {
            Ok(c.topology().rest_positions.as_flattened())
        })
    }
}

/// The shared body of the two frame calls.
///
/// # Safety
/// As `lamina_next_frame`.
unsafe fn frame(
    function: &'static str,
    client: LaminaClient,
    timeout_ms: u32,
    positions: *mut f32,
    capacity_nodes: usize,
    out_info: *mut LaminaFrameInfo,
    newest: bool,
) -> LaminaStatus {
    guard(function, || {
        // SAFETY: the caller's contract.
        let info = unsafe { out_ref(out_info, function, "out_info") }?;
        handles::with(function, client, |c| {
            let nodes = c.topology().node_count as usize;
            check_capacity(function, "capacity_nodes", capacity_nodes, nodes)?;
            // SAFETY: the caller's contract; `3 · capacity_nodes` >= the length written.
            let out = unsafe { out_slice(positions, 3 * nodes, function, "positions") }?;
            *info =
                if newest { c.latest_frame(millis(timeout_ms), out)? } else { c.next_frame(millis(timeout_ms), out)? };
            Ok(())
        })
    })
}

/// Takes the oldest queued node frame (frames come in order; the core queues 16 for this
/// client and drops the oldest beyond that), waiting up to `timeout_ms` ms when none is
/// queued, and copies its positions (`[x, y, z]` per node, m) into `positions`, which holds
/// `capacity_nodes` nodes (at least the topology's `node_count`); `*out_info` gets its header.
/// One copy, from shared memory into `positions`.
///
/// Errors: `LAMINA_STATUS_TIMEOUT` when no frame came, `LAMINA_STATUS_CORE_GONE` when the
/// core stopped or was killed, `LAMINA_STATUS_PROTOCOL` for a frame of another node count.
///
/// # Safety
/// `positions` is NULL or valid for `3 · capacity_nodes` writes; `out_info` is NULL or valid
/// for writes.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn lamina_next_frame(
    client: LaminaClient,
    timeout_ms: u32,
    positions: *mut f32,
    capacity_nodes: usize,
    out_info: *mut LaminaFrameInfo,
) -> LaminaStatus {
    // SAFETY: the caller's contract, passed on.
    unsafe { frame("lamina_next_frame", client, timeout_ms, positions, capacity_nodes, out_info, false) }
}

/// As `lamina_next_frame`, but takes the newest frame and drops the older queued ones (a
/// renderer's call). Only the newest is copied.
///
/// # Safety
/// As `lamina_next_frame`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn lamina_latest_frame(
    client: LaminaClient,
    timeout_ms: u32,
    positions: *mut f32,
    capacity_nodes: usize,
    out_info: *mut LaminaFrameInfo,
) -> LaminaStatus {
    // SAFETY: the caller's contract, passed on.
    unsafe { frame("lamina_latest_frame", client, timeout_ms, positions, capacity_nodes, out_info, true) }
}

/// Sends `*command` on the core's `tool` service. Refused before sending
/// (`LAMINA_STATUS_INVALID_ARGUMENT`): a position coordinate not finite or at or beyond
/// 1000 m in magnitude (the bound is per coordinate), a radius or blade length outside
/// `0 <= r < 1` m, an orientation not finite, a `kind` other than `LAMINA_TOOL_SPHERE` and
/// `LAMINA_TOOL_SCALPEL`, a scalpel whose orientation is all zeros.
/// `LAMINA_STATUS_NO_TOOL` when the scene's tool does not follow commands. The core takes
/// the newest command each tick and parks the tool (zero force) when none came for the
/// scene's `timeout_ms` (100 ms by default): send at least every 100 ms.
///
/// # Safety
/// `command` is NULL or valid for reads.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn lamina_send_tool(client: LaminaClient, command: *const LaminaToolCommand) -> LaminaStatus {
    const F: &str = "lamina_send_tool";
    guard(F, || {
        // SAFETY: the caller's contract.
        let command = unsafe { in_ref(command, F, "command") }?;
        handles::with(F, client, |c| c.send_tool(F, command))
    })
}

/// Moves the sphere's centre to `(x, y, z)` (m, model frame) with radius `radius_m` (0: the
/// scene's), no button held. As `lamina_send_tool`.
#[unsafe(no_mangle)]
pub extern "C" fn lamina_send_sphere(client: LaminaClient, x: f64, y: f64, z: f64, radius_m: f64) -> LaminaStatus {
    const F: &str = "lamina_send_sphere";
    let command = LaminaToolCommand { position: [x, y, z], radius_m, ..LaminaToolCommand::default() };
    guard(F, || handles::with(F, client, |c| c.send_tool(F, &command)))
}

/// Holds the scalpel with its tip at `(x, y, z)` (m, model frame) and its cutting edge
/// `blade_length_m` long (0: the scene's) straight up from the tip (model +y, the identity
/// orientation: across the skin of Lamina's limbs from above while the tip is below it). The
/// blade cuts what its edge sweeps between two core ticks. For an edge turned another way,
/// `lamina_send_tool` with `kind` `LAMINA_TOOL_SCALPEL` and an orientation. As
/// `lamina_send_tool`.
#[unsafe(no_mangle)]
pub extern "C" fn lamina_send_scalpel(
    client: LaminaClient,
    x: f64,
    y: f64,
    z: f64,
    blade_length_m: f64,
) -> LaminaStatus {
    const F: &str = "lamina_send_scalpel";
    let command = LaminaToolCommand {
        position: [x, y, z],
        kind: LAMINA_TOOL_SCALPEL,
        blade_length_m,
        ..LaminaToolCommand::default()
    };
    guard(F, || handles::with(F, client, |c| c.send_tool(F, &command)))
}

/// As `lamina_send_sphere`, with the grasp button: `closed` 1 holds the free nodes within
/// 1.25 radii of the centre, 0 lets them go. Other values of `closed` are refused.
#[unsafe(no_mangle)]
pub extern "C" fn lamina_send_grasp(
    client: LaminaClient,
    x: f64,
    y: f64,
    z: f64,
    radius_m: f64,
    closed: u32,
) -> LaminaStatus {
    const F: &str = "lamina_send_grasp";
    guard(F, || {
        if closed > 1 {
            return Err(failure::Failure::new(
                LaminaStatus::InvalidArgument,
                format!("{F}: closed = {closed} is neither 0 (open) nor 1 (closed)"),
            ));
        }
        let command =
            LaminaToolCommand { position: [x, y, z], radius_m, buttons: closed, ..LaminaToolCommand::default() };
        handles::with(F, client, |c| c.send_tool(F, &command))
    })
}

/// Fills `*out` with the newest contact feedback (the core sends one every tick while its
/// tool follows commands), polling up to `timeout_ms` ms when none is queued.
///
/// Errors: `LAMINA_STATUS_TIMEOUT` (the message says when the scene's tool sends none),
/// `LAMINA_STATUS_CORE_GONE`.
///
/// # Safety
/// `out` is NULL or valid for writes.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn lamina_latest_feedback(
    client: LaminaClient,
    timeout_ms: u32,
    out: *mut LaminaFeedback,
) -> LaminaStatus {
    const F: &str = "lamina_latest_feedback";
    guard(F, || {
        // SAFETY: the caller's contract.
        let out = unsafe { out_ref(out, F, "out") }?;
        *out = handles::with(F, client, |c| c.latest_feedback(millis(timeout_ms)))?;
        Ok(())
    })
}
