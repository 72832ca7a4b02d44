//! The wire contract between Lamina processes (iceoryx2).
