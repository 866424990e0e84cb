//! # ncsmooth
//!
//! The numerical core of ncsmooth: geometry ([`geom`]), the path model ([`path`]) and the
//! verification core ([`verify`]) by which every smoothing and planning result is judged.
//!
//! The pipeline is parse (crate `ncsmooth-gcode`) -> [`path`] -> smooth -> plan
//! ([`feed`]) -> interpolate -> [`verify`] -> write.
#![forbid(unsafe_code)]

pub mod decimal;
pub mod feed;
pub mod geom;
pub mod interp;
pub mod par;
pub mod path;
pub mod profiles;
pub mod smooth;
pub mod stats;
pub mod verify;

pub use geom::{Segment, Vec3};
pub use path::{Block, Event, EventKind, Move, MoveKind, Toolpath, Units};
