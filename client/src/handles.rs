//! Handles: a number per open client, never reused, so a closed or made-up handle is found
//! out instead of followed as a dangling pointer.
//!
//! iceoryx2's ports are not thread-safe, so each thread keeps its own clients. A process-wide
//! table remembers which thread holds each open handle, so that a handle used on another
//! thread is told apart from one that is closed.

use std::cell::RefCell;
use std::collections::{BTreeMap, HashMap};
use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};
use std::thread::ThreadId;

use crate::client::Client;
use crate::failure::Failure;
use crate::types::{LaminaClient, LaminaStatus};

/// The next handle to give out (0 is never one).
static NEXT: AtomicU64 = AtomicU64::new(1);

/// Open handles and the thread that holds each.
static OWNERS: Mutex<BTreeMap<LaminaClient, ThreadId>> = Mutex::new(BTreeMap::new());

fn owners() -> std::sync::MutexGuard<'static, BTreeMap<LaminaClient, ThreadId>> {
    // The table stays consistent even if a holder panicked: every update is one insert or
    // remove.
    OWNERS.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// This thread's clients; leaving the thread closes them.
#[derive(Default)]
struct Clients(HashMap<LaminaClient, Client>);

impl Drop for Clients {
    fn drop(&mut self) {
        let mut owners = owners();
        for handle in self.0.keys() {
            owners.remove(handle);
        }
    }
}

thread_local! {
    static CLIENTS: RefCell<Clients> = RefCell::new(Clients::default());
}

/// Registers `client` on this thread and gives its handle.
pub(crate) fn insert(client: Client) -> LaminaClient {
    let handle = NEXT.fetch_add(1, Ordering::Relaxed);
    owners().insert(handle, std::thread::current().id());
    CLIENTS.with(|c| c.borrow_mut().0.insert(handle, client));
    handle
}

/// Why `handle` is not one of this thread's clients.
fn refusal(function: &str, handle: LaminaClient) -> Failure {
    if handle == 0 {
        return Failure::new(
            LaminaStatus::BadHandle,
            format!("{function}: handle 0 is not a client (lamina_open gives handles from 1)"),
        );
    }
    if let Some(owner) = owners().get(&handle) {
        return Failure::new(
            LaminaStatus::WrongThread,
            format!(
                "{function}: handle {handle} belongs to thread {owner:?}; use a client on the thread that opened it"
            ),
        );
    }
    if handle < NEXT.load(Ordering::Relaxed) {
        Failure::new(LaminaStatus::BadHandle, format!("{function}: handle {handle} is closed"))
    } else {
        Failure::new(LaminaStatus::BadHandle, format!("{function}: handle {handle} was never opened"))
    }
}

/// Runs `f` on this thread's client `handle`.
pub(crate) fn with<T>(
    function: &str,
    handle: LaminaClient,
    f: impl FnOnce(&mut Client) -> Result<T, Failure>,
) -> Result<T, Failure> {
    CLIENTS.with(|c| match c.borrow_mut().0.get_mut(&handle) {
        Some(client) => f(client),
        None => Err(refusal(function, handle)),
    })
}

/// Closes this thread's client `handle`.
pub(crate) fn remove(function: &str, handle: LaminaClient) -> Result<(), Failure> {
    let client = CLIENTS.with(|c| c.borrow_mut().0.remove(&handle));
    match client {
        Some(client) => {
            owners().remove(&handle);
            drop(client);
            Ok(())
        }
        None => Err(refusal(function, handle)),
    }
}
