//! Incision: a scalpel whose edge cuts the springs it sweeps, layer by layer, inside the
//! real-time tick.
//!
//! - [`blade`]: the cutting edge and the surface it sweeps between two ticks, and the
//!   segment-against-sweep test.
//! - [`scalpel`]: the scalpel beside a simulation: press, puncture, cut, and the tissue's
//!   cutting force on the blade.

pub mod blade;
pub mod scalpel;

pub use blade::{Blade, Sweep};
pub use scalpel::{BladeState, EdgeInTissue, Scalpel, ScalpelSettings, ScalpelTick, ScalpelTotals, Toughness};
