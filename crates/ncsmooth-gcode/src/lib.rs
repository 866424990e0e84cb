//! G-code (placeholder).
