//! A new factor for the cut model, built off the loop and taken at a tick.
//!
//! After a cut the prefactored preconditioner of `implicit_factored` still holds the cut
//! springs: it stays a valid preconditioner (symmetric positive definite, stiffer than the
//! system), only a weaker one. A thread of the lowest priority (`SCHED_IDLE` on Linux)
//! factors the matrix of the model as cut so far; the loop takes it at the next tick after
//! it is ready ([`FactorSwap::WhenReady`], for the real-time loop) or exactly `n` ticks after
//! it asked ([`FactorSwap::AfterTicks`], waiting if need be: the same bits run to run). The
//! loop swaps the factors without allocating and hands the old one back to the builder's
//! thread, which frees it.
//!
//! One build is outstanding at a time: it covers the cuts made when it was asked for; cuts
//! made meanwhile ask for the next build when it is taken.

use super::factored_preconditioner::{FactoredPreconditioner, PreconditionerInputs};
use super::implicit_factored::ImplicitFactored;
use super::simd::SimdLevel;
use super::sparse_cholesky::FactorStorage;
use crate::law::SpringLaw;
use crate::model::Model;
use crate::real::Real;
use crossbeam::channel::{Receiver, Sender, TryRecvError, bounded};
use std::sync::Arc;
use std::sync::atomic::{AtomicU32, AtomicUsize, Ordering};
use std::time::Instant;

/// When the loop takes a factor of the cut model.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FactorSwap {
    /// At the first tick after it is ready (the real-time loop never waits).
    WhenReady,
    /// Exactly this many ticks after it was asked for, waiting for it if need be
    /// (deterministic: two runs take it at the same tick).
    AfterTicks(u32),
}

/// What the factor builds have done.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RefactorStatus {
    /// Factors of the cut model taken by the loop.
    pub taken: u64,
    /// Cuts the factor in use holds.
    pub cuts_in_factor: usize,
    /// Wall time of the last build, s (on the builder's thread, at the lowest priority).
    pub last_build_s: f64,
    /// Longest build, s.
    pub longest_build_s: f64,
    /// Ticks from the last ask to the tick its factor was taken.
    pub last_ticks_to_take: u64,
}

/// A factor built for the first `cuts` cuts.
struct Built<T: Real> {
    pre: Box<FactoredPreconditioner<T>>,
    cuts: usize,
    seconds: f64,
}

/// The loop's side: the cut springs shared with the builder, the channels, the status.
pub(crate) struct Refactor<T: Real> {
    /// Cut springs in cut order (the first `cut_count` hold).
    cut_order: Arc<[AtomicU32]>,
    cut_count: Arc<AtomicUsize>,
    requests: Sender<usize>,
    ready: Receiver<Built<T>>,
    retired: Sender<Box<FactoredPreconditioner<T>>>,
    swap: FactorSwap,
    tick: u64,
    /// The tick of the outstanding ask, and how many cuts it covers.
    asked: Option<(u64, usize)>,
    status: RefactorStatus,
}

/// Coefficients of `c_m M + c_c C + c_k K` and how the factor is stored.
#[derive(Clone, Copy)]
pub(crate) struct FactorRecipe {
    pub cm: f64,
    pub cc: f64,
    pub ck: f64,
    pub simd: SimdLevel,
    pub storage: FactorStorage,
}

impl<T: Real> Refactor<T> {
    /// Starts the builder's thread for `model` (as built, nothing cut), whose factor is made
    /// by `recipe` from `inputs`.
    pub(crate) fn start(
        model: &Model,
        inputs: PreconditionerInputs,
        recipe: FactorRecipe,
        swap: FactorSwap,
    ) -> std::io::Result<Self> {
        let springs = model.springs.len();
        let cut_order: Arc<[AtomicU32]> = (0..springs).map(|_| AtomicU32::new(0)).collect();
        let cut_count = Arc::new(AtomicUsize::new(0));
        let (requests, asks) = bounded::<usize>(1);
        let (done, ready) = bounded::<Built<T>>(1);
        let (retired, to_free) = bounded::<Box<FactoredPreconditioner<T>>>(1);
        let mut cut_model = model.clone();
        let order = cut_order.clone();
        std::thread::Builder::new().name("lamina-refactor".into()).spawn(move || {
            super::idle_priority::lower_this_threads_priority();
            let mut inputs = inputs;
            let mut applied = 0;
            while let Ok(cuts) = asks.recv() {
                let start = Instant::now();
                for k in applied..cuts {
                    let s = order[k].load(Ordering::Acquire) as usize;
                    cut_model.springs.law[s] = SpringLaw::Linear { stiffness: 0.0 };
                    cut_model.springs.damping[s] = 0.0;
                    let (a, b) = (cut_model.springs.a[s], cut_model.springs.b[s]);
                    inputs.skin_volume.remove_tets_with_edge(a, b);
                }
                applied = cuts;
                let Ok(pre) = FactoredPreconditioner::from_inputs(
                    &cut_model,
                    &inputs,
                    recipe.cm,
                    recipe.cc,
                    recipe.ck,
                    recipe.simd,
                    recipe.storage,
                ) else {
                    // A factor that does not build leaves the old one in use.
                    continue;
                };
                let seconds = start.elapsed().as_secs_f64();
                if done.send(Built { pre: Box::new(pre), cuts, seconds }).is_err() {
                    return;
                }
                // Wait for the loop to hand the old factor back, and free it here.
                match to_free.recv() {
                    Ok(old) => drop(old),
                    Err(_) => return,
                }
            }
        })?;
        Ok(Self {
            cut_order,
            cut_count,
            requests,
            ready,
            retired,
            swap,
            tick: 0,
            asked: None,
            status: RefactorStatus::default(),
        })
    }

    /// Records model spring `spring` as cut (in cut order). Allocates nothing.
    pub(crate) fn record(&mut self, spring: usize) {
        let k = self.cut_count.load(Ordering::Relaxed);
        if let Some(slot) = self.cut_order.get(k) {
            slot.store(spring as u32, Ordering::Release);
            self.cut_count.store(k + 1, Ordering::Release);
        }
    }

    /// Called once per tick before the step: takes a ready factor into `solver` when its tick
    /// has come, and asks for a build of the cuts not yet in one. Allocates nothing.
    pub(crate) fn tick(&mut self, solver: &mut ImplicitFactored<T>) {
        self.tick += 1;
        if let Some((at, _)) = self.asked {
            let built = match self.swap {
                FactorSwap::WhenReady => match self.ready.try_recv() {
                    Ok(b) => Some(b),
                    Err(TryRecvError::Empty) => None,
                    Err(TryRecvError::Disconnected) => {
                        self.asked = None;
                        None
                    }
                },
                FactorSwap::AfterTicks(n) if self.tick >= at + u64::from(n) => {
                    // Polled with short sleeps, not a blocking receive: that one allocates its
                    // waiting context on first use.
                    loop {
                        match self.ready.try_recv() {
                            Ok(b) => break Some(b),
                            Err(TryRecvError::Empty) => std::thread::sleep(std::time::Duration::from_micros(50)),
                            Err(TryRecvError::Disconnected) => {
                                self.asked = None;
                                break None;
                            }
                        }
                    }
                }
                FactorSwap::AfterTicks(_) => None,
            };
            if let Some(mut b) = built {
                solver.swap_preconditioner(&mut b.pre);
                let _ = self.retired.try_send(b.pre);
                self.status.taken += 1;
                self.status.cuts_in_factor = b.cuts;
                self.status.last_build_s = b.seconds;
                self.status.longest_build_s = self.status.longest_build_s.max(b.seconds);
                self.status.last_ticks_to_take = self.tick - at;
                self.asked = None;
            }
        }
        let cuts = self.cut_count.load(Ordering::Relaxed);
        if self.asked.is_none() && cuts > self.status.cuts_in_factor && self.requests.try_send(cuts).is_ok() {
            self.asked = Some((self.tick, cuts));
        }
    }

    /// What the builds have done.
    pub(crate) fn status(&self) -> RefactorStatus {
        self.status
    }
}
