//! Frames of `N` samples per microphone with 50% overlap (the paper's Section II), in
//! blocks that the analyzer works through on several threads.

/// Frames analysed together on the thread pool. Memory is bounded by two blocks of audio
/// (16 KB a frame for 8 microphones at N = 1024, as frames share their samples) and one of
/// spectra (33 KB a frame).
pub const BLOCK: usize = 128;

/// Consecutive frames of `n` samples per microphone with a hop of `n / 2`, up to
/// `capacity` of them in one mic-major buffer: mic `m`'s samples of frame `i` are
/// `data[m * stride + i * hop..][..n]`, so overlapping frames share their samples.
pub(crate) struct FrameBlock {
    pub(crate) n: usize,
    pub(crate) hop: usize,
    pub(crate) stride: usize,
    pub(crate) data: Vec<f32>,
    /// Index of the block's first frame in the file.
    pub first: u64,
    /// Frames in the block.
    pub count: usize,
}

impl FrameBlock {
    /// An empty block for up to `capacity` frames of `n` samples of `mics` microphones.
    pub fn new(n: usize, mics: usize, capacity: usize) -> Self {
        let hop = n / 2;
        let stride = (capacity - 1) * hop + n;
        FrameBlock {
            n,
            hop,
            stride,
            data: vec![0.0; mics * stride],
            first: 0,
            count: 0,
        }
    }

    /// Frame `i` of the block: its samples from `data[0..]`, mic `m` at `m * stride`.
    pub fn frame(&self, i: usize) -> (&[f32], usize) {
        assert!(i < self.count, "frame {i} of a block of {}", self.count);
        (&self.data[i * self.hop..], self.stride)
    }
}
