//! The paper's stages, in its order: frames (Sec. II), spectra and the mean power spectrum
//! (eq. 2), the noise estimate and spectral weighting (eq. 4, 5), the weighted PHAT
//! cross-correlation (eq. 6), the M highest peaks (eq. 7), the consistent set of delays
//! (eq. 8), and the far-field least-squares direction (eq. 9-13). Each stage takes what
//! it needs as arguments and knows nothing of the stages after it or of the engine that
//! schedules them (`method/engine/`).

pub mod correlation;
pub mod direction;
pub mod frames;
pub mod pairs;
pub mod peaks;
pub mod search;
pub mod spectrum;
pub mod weighting;
