//! How a smoothing job shares its tolerance, by controller: the flattening chord, the
//! controller's blending (LinuxCNC's `G64 P Q`) and the curves. Shares of `tol`; the
//! figures that chose them are in `docs/benchmarks/`.

/// Default flattening chord for a controller that runs the written path exactly.
pub(crate) const DEFAULT_CHORD_SHARE: f64 = 0.1;
/// Default chord for a stepper dialect ([`crate::Dialect::block_floor_mm`]): no blending
/// takes a share there, and longer blocks let grbl's 15-block look-ahead see farther.
pub(crate) const STEPPER_CHORD_SHARE: f64 = 0.3;
/// The chord when `Method::None` with an emitter compresses the program's own lines
/// (nothing else is built: the chord takes what blending and rounding leave, with room).
pub(crate) const COMPRESS_CHORD_SHARE: f64 = 0.8;
/// The same for a controller that does not blend: the chord takes the whole tolerance but
/// the rounding (twice over) and this share's remainder.
pub(crate) const COMPRESS_EXACT_CHORD_SHARE: f64 = 0.97;
/// Accuracy of the verification.
pub(crate) const VERIFY_ACCURACY_SHARE: f64 = 1e-3;
/// Largest tolerance (mm): a deviation larger than a machine's travel bounds nothing, and
/// the `G64 P` it gives would not be a number LinuxCNC reads.
pub(crate) const TOL_MAX_MM: f64 = 1000.0;
/// Largest firmware arc setting (mm) `--arc-segment` takes (a segment length, or grbl's
/// arc tolerance): chords that long are no arc worth writing.
pub(crate) const ARC_SEGMENT_MAX_MM: f64 = 100.0;
/// Smallest curve tolerance, as a share of the tolerance, smoothing is asked to build to.
pub(crate) const MIN_CURVE_TOL_SHARE: f64 = 0.25;
