//! Springs between pairs of nodes, stored as structure of arrays in file order.

use crate::law::SpringLaw;

/// The springs of a model. Order is the model's canonical (file) order; the solver builds
/// its own streaming order from it.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SpringSet {
    /// First node index.
    pub a: Vec<u32>,
    /// Second node index.
    pub b: Vec<u32>,
    /// Rest length, m.
    pub rest_length: Vec<f64>,
    /// Force law.
    pub law: Vec<SpringLaw>,
    /// Dashpot coefficient along the spring, N·s/m.
    pub damping: Vec<f64>,
    /// Index of the layer the spring belongs to.
    pub layer: Vec<u16>,
}

impl SpringSet {
    /// Number of springs.
    pub fn len(&self) -> usize {
        self.a.len()
    }

    /// True when there are no springs.
    pub fn is_empty(&self) -> bool {
        self.a.is_empty()
    }

    /// Appends a spring; returns its index.
    pub fn push(&mut self, a: u32, b: u32, rest_length: f64, law: SpringLaw, damping: f64, layer: u16) -> u32 {
        self.a.push(a);
        self.b.push(b);
        self.rest_length.push(rest_length);
        self.law.push(law);
        self.damping.push(damping);
        self.layer.push(layer);
        (self.a.len() - 1) as u32
    }
}
