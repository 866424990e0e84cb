//! Verification (placeholder while being written).
