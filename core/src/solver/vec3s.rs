//! Three parallel arrays, one per axis: the solver's layout for positions, velocities and
//! forces, so the kernels stream each component with unit stride.

use crate::real::Real;

/// `x`, `y`, `z` components of N vectors, stored as three arrays of length N.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Vec3s<T> {
    /// x components.
    pub x: Vec<T>,
    /// y components.
    pub y: Vec<T>,
    /// z components.
    pub z: Vec<T>,
}

impl<T: Real> Vec3s<T> {
    /// N zero vectors.
    pub fn zeros(n: usize) -> Self {
        Self { x: vec![T::ZERO; n], y: vec![T::ZERO; n], z: vec![T::ZERO; n] }
    }

    /// From double-precision triples, rounded to `T`.
    pub fn from_f64(points: &[[f64; 3]]) -> Self {
        Self {
            x: points.iter().map(|p| T::from_f64(p[0])).collect(),
            y: points.iter().map(|p| T::from_f64(p[1])).collect(),
            z: points.iter().map(|p| T::from_f64(p[2])).collect(),
        }
    }

    /// Number of vectors.
    pub fn len(&self) -> usize {
        self.x.len()
    }

    /// True when empty.
    pub fn is_empty(&self) -> bool {
        self.x.is_empty()
    }

    /// Vector `i` as `f64`.
    pub fn get_f64(&self, i: usize) -> [f64; 3] {
        [self.x[i].to_f64(), self.y[i].to_f64(), self.z[i].to_f64()]
    }

    /// Sets vector `i`.
    pub fn set(&mut self, i: usize, v: [T; 3]) {
        self.x[i] = v[0];
        self.y[i] = v[1];
        self.z[i] = v[2];
    }

    /// Vector `i`.
    #[inline]
    pub fn get(&self, i: usize) -> [T; 3] {
        [self.x[i], self.y[i], self.z[i]]
    }

    /// Sets every component to zero (no allocation).
    pub fn fill_zero(&mut self) {
        self.x.fill(T::ZERO);
        self.y.fill(T::ZERO);
        self.z.fill(T::ZERO);
    }

    /// Copies `other` into `self` (same length; no allocation).
    pub fn copy_from(&mut self, other: &Self) {
        self.x.copy_from_slice(&other.x);
        self.y.copy_from_slice(&other.y);
        self.z.copy_from_slice(&other.z);
    }

    /// The three component slices.
    #[inline]
    pub fn slices(&self) -> [&[T]; 3] {
        [&self.x, &self.y, &self.z]
    }

    /// The three component slices, mutable.
    #[inline]
    pub fn slices_mut(&mut self) -> [&mut [T]; 3] {
        [&mut self.x, &mut self.y, &mut self.z]
    }

    /// True when every component is finite.
    pub fn all_finite(&self) -> bool {
        self.x.iter().chain(&self.y).chain(&self.z).all(|v| v.is_finite())
    }
}
