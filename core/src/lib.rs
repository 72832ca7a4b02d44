//! Lamina physics core.
