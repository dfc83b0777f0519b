//! The stages beyond the paper, each in its own file with the measurements that chose it
//! (docs/method.md): the threshold calibrated against the background, the steady
//! background subtracted from the correlations, the reverberation's diffuse part removed
//! from the cross-spectra, the steered response (partial agreement, further sources),
//! further sources from a frame's own correlations, each talker's learned pattern
//! removed before a second look, the directions of single frequency bins, and a count
//! of pairs whose delays run past the geometry's. They use
//! the paper's stages and the frame's layout and state; the engine
//! ([`super::engine`]) builds their plans and calls them.

pub(crate) mod background;
pub(crate) mod dereverb;
pub(crate) mod edges;
pub(crate) mod frame_sources;
pub(crate) mod patterns;
pub(crate) mod steered;
pub(crate) mod threshold;
pub(crate) mod votes;
