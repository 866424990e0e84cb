//! The controllers the written program is for: what each accepts ([`dialect`], the
//! capability table), the block floor of the controllers that are given no short blocks
//! ([`floor`]), how each runs an arc ([`arcs`]) and LinuxCNC's model of what it executes
//! ([`linuxcnc`]). The writers call
//! these through the [`Dialect`](dialect::Dialect) and options they are given.

pub mod arcs;
pub mod dialect;
pub mod floor;
pub mod linuxcnc;
