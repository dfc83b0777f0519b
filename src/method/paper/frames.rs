//! Frames of `N` samples per microphone with 50% overlap (the paper's Section II), in
//! blocks that the analyzer works through on several threads.

use super::spectrum::Window;

/// Frames analysed together on the thread pool. Memory is bounded by two blocks of audio
/// (16 KB a frame for 8 microphones at N = 1024, as frames share their samples) and one of
/// spectra (33 KB a frame).
pub(crate) const BLOCK: usize = 128;

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

/// How a recording is cut into frames: their length and window, and the part analysed.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[cfg_attr(feature = "flags", derive(clap::Args))]
#[serde(default, deny_unknown_fields)]
#[non_exhaustive]
pub struct Framing {
    /// The frame size N.
    #[cfg_attr(feature = "flags", command(flatten))]
    pub size: FrameSize,
    /// Analysis window
    #[cfg_attr(feature = "flags", arg(long, default_value = "hann", value_parser = crate::flags::choice::<Window>(), hide_short_help = true))]
    pub window: Window,
    /// Analyse from this time on (seconds from the start of each file; rounded down to a hop, so times and frames stay the file's)
    #[cfg_attr(feature = "flags", arg(long = "start", value_name = "S", default_value_t = 0.0, value_parser = crate::flags::non_negative_f64))]
    pub start_s: f64,
    /// Analyse up to this time (seconds from the start of each file; none: to its end)
    #[cfg_attr(feature = "flags", arg(long = "end", value_name = "S", value_parser = crate::flags::non_negative_f64))]
    pub end_s: Option<f64>,
}

impl Default for Framing {
    fn default() -> Self {
        Framing {
            size: FrameSize::Auto,
            window: Window::Hann,
            start_s: 0.0,
            end_s: None,
        }
    }
}

/// The frame size N: about 21 ms at each rate, a number of samples, or the power of two
/// nearest to a length in milliseconds at each file's rate.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FrameSize {
    /// About 21 ms: 1024 samples at 44.1/48 kHz, 256 at 16 kHz (`default_frame_size`).
    #[default]
    Auto,
    /// This many samples (`-n`), even, 16 to `MAX_FRAME_SIZE`.
    Samples(usize),
    /// The power of two nearest (in ratio) to this many milliseconds at each file's rate
    /// (`--frame-ms`), the same length at every rate.
    Ms(f64),
}

#[cfg(feature = "flags")]
impl clap::FromArgMatches for FrameSize {
    fn from_arg_matches(m: &clap::ArgMatches) -> Result<Self, clap::Error> {
        Ok(
            match (
                m.get_one::<usize>("frame_size"),
                m.get_one::<f64>("frame_ms"),
            ) {
                (Some(&n), _) => FrameSize::Samples(n),
                (None, Some(&ms)) => FrameSize::Ms(ms),
                (None, None) => FrameSize::Auto,
            },
        )
    }

    fn update_from_arg_matches(&mut self, m: &clap::ArgMatches) -> Result<(), clap::Error> {
        *self = Self::from_arg_matches(m)?;
        Ok(())
    }
}

#[cfg(feature = "flags")]
impl clap::Args for FrameSize {
    fn augment_args(cmd: clap::Command) -> clap::Command {
        use clap::Arg;
        cmd.arg(
            Arg::new("frame_size")
                .hide_short_help(true)
                .short('n')
                .long("frame-size")
                .value_name("N")
                .value_parser(clap::value_parser!(usize))
                .conflicts_with("frame_ms")
                .help("Frame size N in samples [default: about 21 ms: 1024 at 44.1/48 kHz, 256 at 16 kHz]"),
        )
        .arg(
            Arg::new("frame_ms")
                .hide_short_help(true)
                .long("frame-ms")
                .value_name("MS")
                .value_parser(crate::flags::positive)
                .help("Frame length in milliseconds, the same at every sample rate: N is the power of two nearest to it at each file's rate"),
        )
    }

    fn augment_args_for_update(cmd: clap::Command) -> clap::Command {
        Self::augment_args(cmd)
    }
}
