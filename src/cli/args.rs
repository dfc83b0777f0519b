//! The command line's arguments (clap). `man/` is generated from these definitions;
//! `ssl analyze`'s method flags are the configuration's sections ([`crate::Config`]).
//! The doc comments here are help texts, not rustdoc (`[[mic]]` is TOML).
#![allow(rustdoc::broken_intra_doc_links)]

use super::values::{expected, shard, Shard};
use crate::flags::{choice, non_negative};
use crate::{Config, Format};
use clap::{Args, Parser, Subcommand};
use std::path::PathBuf;

/// Find where sounds come from in multichannel microphone-array recordings.
#[derive(Debug, Parser)]
#[command(
    name = "ssl",
    version,
    propagate_version = true,
    disable_help_subcommand = true,
    about = "Find where sounds come from in multichannel microphone-array recordings",
    long_about = "Find where sounds come from in multichannel microphone-array recordings.\n\n\
        ssl implements the time-delay method of Valin, Michaud, Rouat and Letourneau (IROS 2003): \
        weighted PHAT cross-correlation of every microphone pair, a consistency-checked search over \
        the M highest peaks of each, and a far-field least-squares direction. It writes timestamped \
        directions (azimuth, elevation, unit vector) as CSV, JSON or NDJSON.",
    after_help = "Examples:\n  \
        ssl analyze testdata/example.wav --geometry testdata/prism.toml\n  \
        ssl simulate testdata/scene.toml -o scene.wav && ssl analyze scene.wav -g testdata/prism.toml | ssl evaluate --truth scene.truth.json -\n  \
        ssl completions bash > ~/.local/share/bash-completion/completions/ssl"
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    #[command(
        about = "Localize sound sources in WAV or FLAC recordings",
        long_about = "Localize sound sources in WAV or FLAC recordings.\n\n\
        Writes one record per detected source per analysis frame (frames of N samples, hop N/2): \
        time_s (frame centre), azimuth_deg, elevation_deg, x, y, z (unit vector from the array centre), \
        score (summed weighted correlation of the chosen delays, one term per microphone pair: at most 1 each \
        with --no-weighting, several for a source that stands out of the noise with the weighting), then \
        file, frame, mics, source (the tracked source; empty with --no-track) and uncertainty_deg (the cone \
        around the direction that holds the true one with 95% probability). Frames with no consistent set of \
        delays, or scoring under the detection threshold (calibrated against each file's background; a fixed \
        score per pair with --min-score), give no record. --events writes one record per stretch of activity \
        of a source instead, --sources one per source. Files are analysed in argument order; a file that fails is reported on stderr and the \
        others still run (exit status 1). When every file fails, nothing is written.\n\n\
        Exit status: 0 success, 1 a file or the geometry could not be analysed, 2 a usage error.",
        after_help = "Examples:\n  \
        ssl analyze rec.wav -g array.toml                     CSV on standard output\n  \
        ssl analyze rec.wav -g array.toml -f json -o rec.json  one JSON document\n  \
        sox in.mp3 -t wav - | ssl analyze - -g array.toml     from a pipe\n  \
        ssl analyze *.wav -g array.toml --min-score 0.3      a lower threshold per microphone pair"
    )]
    Analyze(Box<AnalyzeArgs>),
    #[command(
        about = "Show what ssl understood of an array geometry file",
        long_about = "Show what ssl understood of an array geometry file: each microphone and its channel, \
        the shape (3-D, planar or linear) and what it cannot tell, the aperture, and every pair's largest delay \
        at --rate.\n\n\
        The file (TOML), positions in metres in the array's frame: x forward, y left, z up:\n\n  \
        name = \"my-circle\"            # optional\n  \
        speed_of_sound = 343.0        # optional, m/s\n  \
        side = [0.0, 0.0, 1.0]        # optional: the side a planar array reports (default up)\n  \
        [orientation]                 # optional: the array's pose in the room\n  \
        yaw_deg = 0.0                 # turns x toward y (about z)\n  \
        pitch_deg = 0.0               # lifts x toward z\n  \
        roll_deg = 0.0                # lifts y toward z\n  \
        [[mic]]\n  \
        position = [0.0463, 0.0, 0.0]\n  \
        channel = 0                   # optional 0-based WAV channel (all mics or none)\n  \
        [[mic]]\n  \
        position = [0.0232, 0.0401, 0.0]\n  \
        channel = 1\n\n\
        Without channel keys, the mics are the WAV's channels in order. With [orientation], the array is \
        rolled, then pitched, then turned by yaw (or `matrix = [[..], [..], [..]]`, whose columns are the \
        array's axes in the room), and directions are reported in the room's frame. Unknown keys are errors. \
        docs/interface.md gives the whole contract."
    )]
    Geometry(GeometryArgs),
    #[command(
        about = "Check that a recording fits its geometry and channel order",
        long_about = "Check that a recording fits its geometry and channel order.\n\n\
        From a recording with some clear sound (hand claps or speech near the array; the first 600 s are \
        read), checks each channel (dead, clipped, duplicated, polarity-inverted, gain mismatch) and how \
        well the geometry explains the delays of the clearest frames: delays longer than the microphones' \
        spacing allows, or much shorter (a unit), a channel order that fits much better (every order of up \
        to 8 microphones is tried, every swap of two beyond), or one microphone that does not fit its \
        position. Each misfit is named with what to do.\n\n\
        Exit status: 0 the recording fits, 1 a misfit was found (or nothing clear enough to check), \
        2 a usage error or an unreadable recording or geometry.",
        after_help = "Examples:\n  \
        ssl check claps.wav -g array.toml\n  \
        ssl check claps.wav -g array.toml --format json"
    )]
    Check(CheckArgs),
    #[command(
        about = "Simulate a recording with known truth from a scene file",
        long_about = "Simulate a recording with known truth from a scene file.\n\n\
        The scene (TOML) gives a shoebox room (dimensions, rt60 or absorption; omit it for free \
        field), the array (geometry file, position, yaw), sources (position or azimuth/elevation/distance \
        from the array; signal white, pink, clicks, tone, speech or a mono WAV file; active intervals; \
        level) and noise (point fans, diffuse noise, sensor noise, target SNR). The image-source method \
        with fractional-delay taps renders it. The truth JSON gives each source's direction in the \
        array frame, distance and active intervals (as heard at the array centre). Same scene and seed, \
        same bytes. See testdata/scene.toml."
    )]
    Simulate(SimulateArgs),
    #[command(
        about = "Score detections against a truth (a simulation's or your own)",
        long_about = "Score detections against a truth (a simulation's or your own).\n\n\
        RESULT is the output of `ssl analyze` in any format. Per source and overall: mean and median \
        angular error of detections in frames inside the source's active intervals, the share of those \
        frames with a detection within 10 degrees, the share of source events (active intervals) \
        detected, and false detections per minute outside the active intervals (each extended by a \
        reverberation tail).\n\n\
        Many recordings: give folders of results (as `ssl analyze --out-dir` writes them) or several \
        results, and --truth a folder. Each recording (as the rows name it) is scored against the \
        truth at its relative path, NAME.truth.json or NAME.truth.csv (the longest trailing part of \
        the recording's path that has one); one line per recording, then every detection, frame, \
        event and background second pooled. Recordings without a truth are listed, not scored.",
        after_help = "Examples:\n  \
        ssl evaluate --truth testdata/example.truth.json r.csv\n  \
        ssl analyze ARCHIVE -g array.toml --out-dir results/ && ssl evaluate --truth ARCHIVE results/\n  \
        cat results/*/*.ndjson | ssl evaluate --truth ARCHIVE -"
    )]
    Evaluate(EvaluateArgs),
    #[command(
        about = "Draw results as one SVG: directions against time and a sky map",
        long_about = "Draw results as one SVG: directions against time and a sky map.\n\n\
        RESULT is the output of `ssl analyze` in any format (detections, or --events CSV; `-` reads \
        standard input). Each file gets a row of three panels: azimuth against time, elevation \
        against time, and a sky map (azimuth against elevation), one mark per detection coloured by \
        tracked source (else by score), events as bars. With --truth, the true directions and active \
        intervals are drawn in black and the figures of `ssl evaluate` head the row. Large results \
        are binned: at most 20,000 marks per panel (one per cell of 1/1200 of the duration by 1 deg, \
        the cells doubled until fewer). The same input gives the same bytes.",
        after_help = "Examples:\n  \
        ssl analyze testdata/example.wav -g testdata/prism.toml -f json --events -o r.json\n  \
        ssl plot r.json -o r.svg\n  \
        ssl plot r.json --truth testdata/example.truth.json -o r.svg"
    )]
    Plot(PlotArgs),
    /// Print a shell completion script (bash, zsh, fish, elvish or powershell)
    #[command(after_help = "Examples:\n  \
        ssl completions bash > ~/.local/share/bash-completion/completions/ssl\n  \
        ssl completions zsh > ~/.zfunc/_ssl\n  \
        ssl completions fish > ~/.config/fish/completions/ssl.fish")]
    Completions(CompletionsArgs),
}

#[derive(Debug, Args)]
pub struct CompletionsArgs {
    /// The shell
    #[arg(value_enum, value_name = "SHELL")]
    pub shell: clap_complete::Shell,
}

#[derive(Debug, Clone, Args)]
pub struct AnalyzeArgs {
    /// WAV (8/16/24/32-bit PCM or 32-bit float) or FLAC recordings, or directories (searched recursively for --glob); `-` reads standard input
    #[arg(required_unless_present = "files_from", value_name = "PATH")]
    pub files: Vec<String>,

    /// Also analyse the paths in this file, one per line (`-`: standard input)
    #[arg(long, value_name = "LIST", help_heading = "Many files")]
    pub files_from: Option<PathBuf>,

    /// Which files of a directory to analyse (repeatable; matched against the path under the directory, ignoring case) [default: *.wav, *.flac]
    #[arg(long, value_name = "PATTERN", help_heading = "Many files")]
    pub glob: Vec<String>,

    /// One result per input in this directory, at the input's path relative to the directory it was found in (or as --files-from gives it), with the format's extension; each written atomically; a summary ends the run (DIR/batch.json with --format json)
    #[arg(
        long,
        value_name = "DIR",
        conflicts_with = "output",
        help_heading = "Many files"
    )]
    pub out_dir: Option<PathBuf>,

    /// With --out-dir: skip an input whose result is complete and was made from the same input (size and modification time), parameters, geometry and version; redo every other
    #[arg(long, requires = "out_dir", help_heading = "Many files")]
    pub resume: bool,

    /// With --out-dir: analyse only the K-th of N shares of the inputs (dealt by size, about equal audio each), for N runs on several machines writing to one DIR; each share's summary is DIR/batch.K-of-N.json
    #[arg(long, value_name = "K/N", requires = "out_dir", value_parser = shard, help_heading = "Many files")]
    pub shard: Option<Shard>,

    /// Array geometry (TOML: [[mic]] tables with position = [x, y, z] in metres)
    #[arg(short, long, value_name = "TOML")]
    pub geometry: PathBuf,

    /// Output format
    #[arg(short, long, default_value = "csv", value_parser = choice::<Format>())]
    pub format: Format,

    /// Write to this file (atomically: complete or not at all) instead of standard output
    #[arg(short, long, value_name = "FILE")]
    pub output: Option<PathBuf>,

    /// What is found and how (one section per stage).
    #[command(flatten)]
    pub config: Config,

    /// Write events instead of detections: one row per stretch of activity of one tracked source (JSON: both, in `detections` and `events`)
    #[arg(long, conflicts_with_all = ["no_track", "every_frame"], help_heading = "Output")]
    pub events: bool,

    /// Write sources instead of detections: one record per tracked source of each file, with the time its events cover and its mean direction (JSON: detections, events and sources)
    #[arg(long, conflicts_with_all = ["no_track", "every_frame", "events"], help_heading = "Output")]
    pub sources: bool,

    /// Threads to analyse with (0: all cores); the output is the same for any number
    #[arg(help_heading = "Run", short = 'j', long, default_value_t = 0, value_name = "N", value_parser = clap::value_parser!(u16).range(0..=MAX_THREADS as i64))]
    pub threads: u16,

    /// After each file, print on stderr the time each stage took (read, spectra, noise, weighting, correlation, background, peaks, search, direction, steered, patterns, tracking, output), per frame and as a share; with several threads, the stages after the noise estimate add up the threads' time
    #[arg(long, help_heading = "Run", hide_short_help = true)]
    pub timings: bool,

    /// No progress bar and no warnings (errors are still reported)
    #[arg(short, long, help_heading = "Run")]
    pub quiet: bool,

    /// Silence one kind of warning (repeatable); the others are still said
    #[arg(
        long = "no-warn",
        value_name = "KIND",
        value_enum,
        help_heading = "Run"
    )]
    pub no_warn: Vec<WarningKind>,
}

/// A kind of warning `ssl analyze` gives, for `--no-warn`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum WarningKind {
    /// The geometry file's (a wide aperture, coarse units)
    Geometry,
    /// A folder with no recording to analyse, or one that cannot be read
    Inputs,
    /// A file given twice
    Repeat,
    /// A recording's channels all constant (digital silence)
    Silence,
    /// A microphone constant in some frames (dead or disconnected)
    DeadMic,
    /// Something about a recording's file itself (sizes wrapped past 4 GiB)
    Input,
    /// The array's largest delay only a few samples at the recording's rate
    CoarseDelays,
    /// A --band of few frequency bins
    NarrowBand,
    /// Delays longer than the geometry allows
    BeyondGeometry,
    /// Hardly any frame with a detection
    FewDetections,
    /// The consistency search at its budget in some frames
    SearchBudget,
    /// Detections but no source confirmed
    Unconfirmed,
    /// A batch's housekeeping (temporaries of killed batches removed)
    Batch,
}

impl WarningKind {
    /// The kind of a recording's warning.
    pub fn of(w: &crate::stream::Warning) -> Self {
        use crate::stream::Warning;
        match w {
            Warning::Silence => WarningKind::Silence,
            Warning::DeadMic { .. } => WarningKind::DeadMic,
            Warning::Input(_) => WarningKind::Input,
            Warning::CoarseDelays { .. } => WarningKind::CoarseDelays,
            Warning::NarrowBand { .. } => WarningKind::NarrowBand,
            Warning::BeyondGeometry { .. } => WarningKind::BeyondGeometry,
            Warning::FewDetections { .. } => WarningKind::FewDetections,
            Warning::SearchBudget { .. } => WarningKind::SearchBudget,
        }
    }
}

/// The most threads `--threads` takes: more than the cores of any machine this runs on;
/// each thread costs memory and start-up time, and thousands only fail to start.
pub const MAX_THREADS: u16 = 1024;

#[derive(Debug, Args)]
pub struct CheckArgs {
    /// WAV or FLAC recording (`-` for standard input)
    #[arg(value_name = "WAV")]
    pub recording: String,

    /// Array geometry file (TOML)
    #[arg(short, long, value_name = "TOML")]
    pub geometry: PathBuf,

    /// Report format
    #[arg(short, long, value_enum, default_value_t = CheckFormat::Text)]
    pub format: CheckFormat,

    /// A sound in the recording comes from this direction (azimuth/elevation in degrees, e.g. 30/10), starting T seconds in when @T is given (30/10@2.5): it settles channel orders that the array's symmetry hides (mirror images, rotations). Repeat it for several sounds; give the time when the recording has sounds from many directions, as claps around a regular array
    #[arg(long, value_name = "AZ/EL[@T]", value_parser = expected, allow_hyphen_values = true)]
    pub expect: Vec<crate::check::Expected>,
}

/// `ssl check --format`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum CheckFormat {
    /// Lines for people
    Text,
    /// One JSON document
    Json,
}

#[derive(Debug, Args)]
pub struct GeometryArgs {
    /// Array geometry file (TOML)
    #[arg(value_name = "TOML")]
    pub geometry: PathBuf,

    /// Sample rate for the lag table (Hz)
    #[arg(short, long, default_value_t = 48000, value_parser = clap::value_parser!(u32).range(1000..=768000))]
    pub rate: u32,

    /// Speed of sound in m/s [default: the geometry's, else 343]
    #[arg(short = 'c', long, value_name = "M/S", value_parser = crate::geometry::speed_of_sound_flag)]
    pub speed_of_sound: Option<f64>,
}

#[derive(Debug, Args)]
pub struct SimulateArgs {
    /// Scene file (TOML)
    #[arg(value_name = "SCENE")]
    pub scene: PathBuf,

    /// Output WAV file
    #[arg(short, long, value_name = "WAV")]
    pub output: PathBuf,

    /// Truth JSON [default: the output's name with .truth.json]
    #[arg(long, value_name = "JSON")]
    pub truth: Option<PathBuf>,
}

#[derive(Debug, Args)]
pub struct PlotArgs {
    /// Results of `ssl analyze` (CSV, JSON or NDJSON): files, `-` (standard input: one result or several concatenated), or folders of results (as --out-dir writes them)
    #[arg(required = true, value_name = "RESULT")]
    pub results: Vec<PathBuf>,

    /// Write the SVG here (atomically) instead of standard output
    #[arg(short, long, value_name = "SVG")]
    pub output: Option<PathBuf>,

    /// The truth, as `ssl evaluate --truth` takes it (what `ssl simulate` writes, or a hand-written JSON, CSV or label file): draw the true directions and score the result
    #[arg(long, value_name = "TRUTH")]
    pub truth: Option<PathBuf>,

    /// Draw only this file of the result (as the result names it)
    #[arg(long, value_name = "NAME")]
    pub file: Option<String>,

    #[command(flatten)]
    pub score: ScoreArgs,
}

/// How `ssl evaluate` and `ssl plot --truth` score: the same flags, the same rules.
#[derive(Debug, Args)]
pub struct ScoreArgs {
    /// Seconds after each active interval during which detections are not false [default: one analysis frame, plus half the room's RT60 when the truth knows it]
    #[arg(long, value_name = "S", value_parser = non_negative)]
    pub tail: Option<f32>,

    /// What an error measures: the 3-D angle, the azimuth (about a planar array's normal), or the angle to a linear array's axis [default: what the array observes, from --geometry or a JSON result's metadata; 3d when neither tells]
    #[arg(long, value_enum)]
    pub metric: Option<MetricArg>,

    /// The array's geometry file, for what it observes (a JSON result carries it already)
    #[arg(long, short = 'g', value_name = "TOML")]
    pub geometry: Option<PathBuf>,
}

#[derive(Debug, Args)]
pub struct EvaluateArgs {
    /// The truth: what `ssl simulate` writes, or a hand-written JSON, CSV (azimuths alone, moving sources, header names and separators as labs write them) or label file from Audacity, Praat or ELAN (docs/interface.md, "Ground truth of a measured setup"); or a folder holding each recording's truth as NAME.truth.json or NAME.truth.csv at the recording's relative path (the archive itself, when truths sit beside recordings): each recording is scored against its own, then all pooled
    #[arg(long, value_name = "FILE|DIR")]
    pub truth: PathBuf,

    /// Detections from `ssl analyze` (CSV, JSON or NDJSON): files, `-` (one result or several concatenated), or folders of results (as --out-dir writes them)
    #[arg(required = true, value_name = "RESULT")]
    pub results: Vec<PathBuf>,

    #[command(flatten)]
    pub score: ScoreArgs,

    /// Print the report as JSON
    #[arg(long)]
    pub json: bool,
}

/// `--metric`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum MetricArg {
    /// The angle between the directions
    #[value(name = "3d")]
    ThreeD,
    /// The azimuth: the angle between their projections onto the array's plane (the horizontal without a planar geometry)
    Azimuth,
    /// The difference of their angles to a linear array's axis
    Axis,
}

impl MetricArg {
    /// Its name on the command line.
    pub fn name(self) -> &'static str {
        match self {
            MetricArg::ThreeD => "3d",
            MetricArg::Azimuth => "azimuth",
            MetricArg::Axis => "axis",
        }
    }
}

impl AnalyzeArgs {
    /// Whether a warning of this kind is said (not `--quiet`, not `--no-warn` it).
    pub fn warns(&self, kind: WarningKind) -> bool {
        !self.quiet && !self.no_warn.contains(&kind)
    }

    /// What the output holds.
    pub fn records(&self) -> crate::record::Records {
        use crate::record::Records;
        if self.sources {
            Records::Sources
        } else if self.events {
            Records::Events
        } else {
            Records::Detections
        }
    }
}
