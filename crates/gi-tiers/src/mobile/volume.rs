//! The probe volume (owned by its own change; placeholder so the crate compiles).

/// The world-space probe volume.
pub struct ProbeVolume;
