//! Delays beyond the geometry (beyond the paper, a diagnostic): a pair's correlation is
//! searched only over the lags its spacing allows (3% more, and a neighbour each side).
//! When the recording's delays are longer (positions too small, a wrong unit, a wrong
//! speed of sound or sample rate, the wrong channels), a clear pair's correlation peaks
//! past that window. Each correlated frame counts its pairs whose correlation reaches
//! the calibrated threshold per pair (or the detection threshold when higher: under a
//! low fixed one a room's reflections peak past the window too), and how many of them
//! peak past the window (looked for out to
//! twice its width); `ssl analyze` warns when that is common, and `ssl check` names the
//! cause.

/// One frame's count (see the module).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(crate) struct Edges {
    /// Pairs whose correlation reaches the threshold per pair, inside the window or past it.
    pub strong: u32,
    /// Of those, pairs whose correlation is larger past the window than inside it.
    pub beyond: u32,
}

impl Edges {
    /// Counts a pair whose largest value is `inside` the window and `past` it, against
    /// the frame's `threshold` per pair.
    pub fn add(&mut self, inside: f32, past: f32, threshold: f64) {
        if (inside.max(past) as f64) < threshold {
            return;
        }
        self.strong += 1;
        if past > inside {
            self.beyond += 1;
        }
    }
}
