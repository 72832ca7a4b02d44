//! What a scene section's reader returns when a value is out of range: the field and what is
//! wrong. [`super::Scene::from_toml_str`] adds the file and the field's line.

/// A value out of range in one scene section.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct FieldError {
    /// Dotted field, e.g. `effects.loads[2]` or `solver.substeps`.
    pub field: String,
    /// What is wrong, e.g. `between 1 and 256`.
    pub message: String,
}

impl FieldError {
    pub(crate) fn new(field: impl Into<String>, message: impl Into<String>) -> Self {
        Self { field: field.into(), message: message.into() }
    }
}

/// All three components finite.
pub(crate) fn finite3(v: &[f64; 3]) -> bool {
    v.iter().all(|x| x.is_finite())
}

/// `value`, when given, must be finite and non-negative.
pub(crate) fn non_negative(value: Option<f64>, field: &str) -> Result<Option<f64>, FieldError> {
    match value {
        Some(v) if !(v.is_finite() && v >= 0.0) => Err(FieldError::new(field, "must be finite and non-negative")),
        v => Ok(v),
    }
}
