//! The command line: `ssl analyze` and `ssl geometry`. `main.rs` only calls [`main`].

use crate::correlation::{Interpolation, Window, MAX_PEAKS};
use crate::direction::pair_index;
use crate::geometry::Geometry;
use crate::output::{self, DetectionWriter, Format};
use crate::pipeline::{default_frame_size, Params, DEFAULT_TOLERANCE};
use crate::session::FileAnalysis;
use anyhow::{Context, Result};
use clap::{Args, Parser, Subcommand};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::{self, IsTerminal, Write};
use std::path::{Path, PathBuf};

/// Find where sounds come from in multichannel microphone-array recordings.
#[derive(Debug, Parser)]
#[command(
    name = "ssl",
    version,
    about = "Find where sounds come from in multichannel microphone-array recordings",
    long_about = "Find where sounds come from in multichannel microphone-array recordings.\n\n\
        ssl implements the time-delay method of Valin, Michaud, Rouat and Letourneau (IROS 2003): \
        weighted PHAT cross-correlation of every microphone pair, a consistency-checked search over \
        the M highest peaks of each, and a far-field least-squares direction. It writes timestamped \
        directions (azimuth, elevation, unit vector) as CSV, JSON or NDJSON.",
    after_help = "Example: ssl analyze testdata/example.wav --geometry testdata/prism.toml"
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    #[command(
        about = "Localize sound sources in WAV recordings",
        long_about = "Localize sound sources in WAV recordings.\n\n\
        Writes one record per detected source per analysis frame (frames of N samples, hop N/2): \
        time_s (frame centre), azimuth_deg, elevation_deg, x, y, z (unit vector from the array centre), \
        score (summed weighted correlation of the chosen delays, at most 1 per microphone pair), then \
        file, frame and mics. Frames with no consistent set of delays give no record. Files are analysed \
        in argument order; a file that fails is reported on stderr and the others still run (exit status 1).\n\n\
        Exit status: 0 success, 1 a file or the geometry could not be analysed, 2 a usage error."
    )]
    Analyze(AnalyzeArgs),
    /// Show what ssl understood of an array geometry file
    Geometry(GeometryArgs),
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
        about = "Score detections against a simulation's truth",
        long_about = "Score detections against a simulation's truth.\n\n\
        RESULT is the output of `ssl analyze` in any format. Per source and overall: mean and median \
        angular error of detections in frames inside the source's active intervals, the share of those \
        frames with a detection within 10 degrees, the share of source events (active intervals) \
        detected, and false detections per minute outside the active intervals (each extended by a \
        reverberation tail)."
    )]
    Evaluate(EvaluateArgs),
}

#[derive(Debug, Args)]
pub struct AnalyzeArgs {
    /// WAV recordings (8/16/24/32-bit PCM or 32-bit float); `-` reads standard input
    #[arg(required = true, value_name = "FILE")]
    pub files: Vec<String>,

    /// Array geometry (TOML: [[mic]] tables with position = [x, y, z] in metres)
    #[allow(rustdoc::broken_intra_doc_links)] // the text is the help, not a link
    #[arg(short, long, value_name = "TOML")]
    pub geometry: PathBuf,

    /// Output format
    #[arg(short, long, value_enum, default_value_t = Format::Csv)]
    pub format: Format,

    /// Write to this file (atomically: complete or not at all) instead of standard output
    #[arg(short, long, value_name = "FILE")]
    pub output: Option<PathBuf>,

    /// Frame size N in samples [default: about 21 ms: 1024 at 44.1/48 kHz, 256 at 16 kHz]
    #[arg(short = 'n', long, value_name = "N")]
    pub frame_size: Option<usize>,

    /// Noise over-subtraction alpha of the spectral weighting (paper eq. 4)
    #[arg(long, default_value_t = 0.4, value_parser = unit_interval)]
    pub alpha: f32,

    /// Exponent gamma that favours high-SNR bins (paper eq. 5)
    #[arg(long, default_value_t = 0.3, value_parser = unit_interval)]
    pub gamma: f32,

    /// Plain PHAT: skip the spectral weighting (w_e = 1), for comparison
    #[arg(long)]
    pub no_weighting: bool,

    /// Peaks M kept in each pair's cross-correlation
    #[arg(short = 'm', long, default_value_t = 8, value_parser = clap::value_parser!(u16).range(1..=MAX_PEAKS as i64))]
    pub peaks: u16,

    /// Consistency tolerance in samples: how far a pair's peak may be from the delay the reference pairs imply
    #[arg(short, long, default_value_t = DEFAULT_TOLERANCE, value_parser = non_negative)]
    pub tolerance: f32,

    /// Speed of sound in m/s [default: the geometry's, else 343]
    #[arg(short = 'c', long, value_name = "M/S", value_parser = positive)]
    pub speed_of_sound: Option<f64>,

    /// Drop detections whose score is below this [default: 0.5 per microphone pair, 14 for 8 mics]
    #[arg(long, value_name = "SCORE", allow_negative_numbers = true, value_parser = parse_f64)]
    pub min_score: Option<f64>,

    /// Analysis window
    #[arg(long, value_enum, default_value_t = Window::Hann)]
    pub window: Window,

    /// Sub-sample refinement of correlation peaks
    #[arg(long, value_enum, default_value_t = Interpolation::Parabolic)]
    pub interpolation: Interpolation,

    /// Threads to analyse with (0: all cores); the output is the same for any number
    #[arg(short = 'j', long, default_value_t = 0, value_name = "N")]
    pub threads: usize,

    /// No progress bar and no warnings (errors are still reported)
    #[arg(short, long)]
    pub quiet: bool,
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
    #[arg(short = 'c', long, value_name = "M/S", value_parser = positive)]
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
pub struct EvaluateArgs {
    /// Truth JSON written by `ssl simulate`
    #[arg(long, value_name = "JSON")]
    pub truth: PathBuf,

    /// Detections from `ssl analyze` (CSV, JSON or NDJSON)
    #[arg(value_name = "RESULT")]
    pub result: PathBuf,

    /// Seconds after each active interval during which detections are not false [default: half the room's RT60, 0 in free field]
    #[arg(long, value_name = "S", value_parser = non_negative)]
    pub tail: Option<f32>,

    /// Print the report as JSON
    #[arg(long)]
    pub json: bool,
}

fn parse_f64(s: &str) -> std::result::Result<f64, String> {
    let v: f64 = s.parse().map_err(|_| format!("`{s}` is not a number"))?;
    if !v.is_finite() {
        return Err(format!("`{s}` is not a finite number"));
    }
    Ok(v)
}

fn unit_interval(s: &str) -> std::result::Result<f32, String> {
    let v = parse_f64(s)?;
    if !(0.0..=1.0).contains(&v) {
        return Err(format!("{v} is outside 0..=1"));
    }
    Ok(v as f32)
}

fn non_negative(s: &str) -> std::result::Result<f32, String> {
    let v = parse_f64(s)?;
    if v < 0.0 {
        return Err(format!("{v} is negative"));
    }
    Ok(v as f32)
}

fn positive(s: &str) -> std::result::Result<f64, String> {
    let v = parse_f64(s)?;
    if v <= 0.0 {
        return Err(format!("{v} is not positive"));
    }
    Ok(v)
}

impl AnalyzeArgs {
    pub fn params(&self) -> Params {
        Params {
            frame_size: self.frame_size,
            alpha: self.alpha,
            gamma: self.gamma,
            weighting: !self.no_weighting,
            peaks: self.peaks as usize,
            tolerance: self.tolerance,
            speed_of_sound: self.speed_of_sound,
            min_score: self.min_score,
            window: self.window,
            interpolation: self.interpolation,
            ..Params::default()
        }
    }
}

/// Runs the command line and returns the process exit status: 0 success, 1 a data
/// error (bad or failed input), 2 a usage error.
pub fn main() -> i32 {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => {
            let code = e.exit_code();
            let _ = e.print();
            return code;
        }
    };
    let result = match cli.command {
        Command::Analyze(args) => rayon::ThreadPoolBuilder::new()
            .num_threads(args.threads)
            .build()
            .map_err(anyhow::Error::from)
            .and_then(|pool| pool.install(|| analyze(&args))),
        Command::Geometry(args) => geometry(&args).map(|()| true),
        Command::Simulate(args) => simulate(&args).map(|()| true),
        Command::Evaluate(args) => evaluate(&args).map(|()| true),
    };
    match result {
        Ok(true) => 0,
        Ok(false) => 1,
        Err(e) if is_broken_pipe(&e) => 0,
        Err(e) => {
            eprintln!("ssl: error: {}", one_line(&e));
            1
        }
    }
}

/// An error chain as one line.
fn one_line(e: &anyhow::Error) -> String {
    format!("{e:#}").replace('\n', " ")
}

fn is_broken_pipe(e: &anyhow::Error) -> bool {
    e.chain().any(|c| {
        c.downcast_ref::<io::Error>().is_some_and(|io| io.kind() == io::ErrorKind::BrokenPipe)
            || c.downcast_ref::<csv::Error>().is_some_and(|c| matches!(c.kind(), csv::ErrorKind::Io(io) if io.kind() == io::ErrorKind::BrokenPipe))
            || c.downcast_ref::<serde_json::Error>().is_some_and(|j| j.io_error_kind() == Some(io::ErrorKind::BrokenPipe))
    })
}

fn warn(quiet: bool, msg: &str) {
    if !quiet {
        eprintln!("ssl: warning: {msg}");
    }
}

/// Where detections go: standard output, or a temporary file renamed into place at the end.
enum Sink {
    Stdout(io::BufWriter<io::Stdout>),
    /// A temporary file and the path it is renamed onto when the run completes.
    File(io::BufWriter<tempfile::NamedTempFile>, PathBuf),
    /// A device or pipe given as `-o` (`/dev/null`, a FIFO): written directly.
    Direct(io::BufWriter<std::fs::File>),
}

impl Write for Sink {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        match self {
            Sink::Stdout(w) => w.write(buf),
            Sink::File(w, _) => w.write(buf),
            Sink::Direct(w) => w.write(buf),
        }
    }
    fn flush(&mut self) -> io::Result<()> {
        match self {
            Sink::Stdout(w) => w.flush(),
            Sink::File(w, _) => w.flush(),
            Sink::Direct(w) => w.flush(),
        }
    }
}

/// How an output path is written.
enum OutputTarget {
    /// A regular file or a new path: a temporary file beside it, renamed onto it when
    /// complete (a failed run leaves the old file, or nothing).
    Atomic(tempfile::NamedTempFile, PathBuf),
    /// Something that is not a regular file (`/dev/null`, a named pipe, a terminal):
    /// renaming over it would replace it, so it is written in place.
    Direct(std::fs::File),
}

/// Opens `path` for output (symlinks are followed, so the link stays a link).
fn open_output(path: &Path) -> Result<OutputTarget> {
    let is_link = std::fs::symlink_metadata(path).is_ok_and(|m| m.file_type().is_symlink());
    let target = if is_link {
        std::fs::canonicalize(path)
            .with_context(|| format!("{}: cannot follow the link", path.display()))?
    } else {
        path.to_path_buf()
    };
    match std::fs::metadata(&target) {
        Ok(m) if m.is_dir() => anyhow::bail!("{}: is a directory", path.display()),
        Ok(m) if !m.is_file() => {
            let file = std::fs::OpenOptions::new()
                .write(true)
                .open(&target)
                .with_context(|| format!("{}: cannot open for writing", path.display()))?;
            Ok(OutputTarget::Direct(file))
        }
        _ => Ok(OutputTarget::Atomic(temp_beside(&target)?, target)),
    }
}

/// `ssl analyze`. Returns whether every file succeeded.
fn analyze(args: &AnalyzeArgs) -> Result<bool> {
    let geometry = Geometry::from_file(&args.geometry)?;
    let geometry_path = args.geometry.display().to_string();
    for w in &geometry.warnings {
        warn(args.quiet, &format!("{geometry_path}: {w}"));
    }
    let params = args.params();
    let sink = match &args.output {
        None => Sink::Stdout(io::BufWriter::with_capacity(1 << 16, io::stdout())),
        Some(path) => match open_output(path)? {
            OutputTarget::Atomic(tmp, target) => {
                Sink::File(io::BufWriter::with_capacity(1 << 16, tmp), target)
            }
            OutputTarget::Direct(file) => Sink::Direct(io::BufWriter::with_capacity(1 << 16, file)),
        },
    };
    let live = matches!(sink, Sink::Stdout(_));
    let mut writer = DetectionWriter::new(args.format, sink);
    writer.line_flush = live && args.format == Format::Ndjson;
    writer.begin(&output::run_metadata(&geometry, &geometry_path, &params))?;

    let show_progress = !args.quiet && io::stderr().is_terminal();
    let mut all_ok = true;
    let mut files = Vec::new();
    for path in &args.files {
        let analysis = match FileAnalysis::open(path, &geometry, &params) {
            Ok(a) => a,
            Err(e) => {
                eprintln!("ssl: error: {}", one_line(&e));
                files.push(output::file_json(path, None, Some(&one_line(&e))));
                all_ok = false;
                continue;
            }
        };
        let bar = progress_bar(show_progress, path, analysis.total_frames());
        let name = analysis.name().to_string();
        let mut output_error: Option<anyhow::Error> = None;
        let (summary, result) = analysis.run(|index, det| {
            if index % 64 == 0 {
                bar.set_position(index);
            }
            if let Some(d) = det {
                if let Err(e) = writer.detection(&name, d) {
                    let stop = anyhow::anyhow!("output failed");
                    output_error = Some(e);
                    return Err(stop);
                }
            }
            Ok(())
        });
        bar.finish_and_clear();
        if let Some(e) = output_error {
            return Err(e.context(match &args.output {
                Some(p) => format!("{}: cannot write", p.display()),
                None => "cannot write to standard output".to_string(),
            }));
        }
        for w in &summary.warnings {
            warn(args.quiet, w);
        }
        let error = result.err().map(|e| one_line(&e));
        if let Some(e) = &error {
            eprintln!("ssl: error: {e}");
            all_ok = false;
        }
        files.push(output::file_json(path, Some(&summary), error.as_deref()));
    }
    let sink = writer.finish(&files)?;
    if let (Sink::File(w, target), Some(path)) = (sink, &args.output) {
        let tmp = w.into_inner().map_err(|e| e.into_error())?;
        tmp.persist(&target)
            .map_err(|e| e.error)
            .with_context(|| format!("{}: cannot write the output file", path.display()))?;
    }
    Ok(all_ok)
}

fn progress_bar(show: bool, name: &str, total: Option<u64>) -> ProgressBar {
    if !show {
        return ProgressBar::hidden();
    }
    let bar = match total {
        Some(t) => ProgressBar::with_draw_target(Some(t), ProgressDrawTarget::stderr()).with_style(
            ProgressStyle::with_template("{prefix} [{bar:30}] {pos}/{len} frames ({eta})")
                .expect("valid template")
                .progress_chars("=> "),
        ),
        None => ProgressBar::with_draw_target(None, ProgressDrawTarget::stderr()).with_style(
            ProgressStyle::with_template("{prefix} {spinner} {pos} frames")
                .expect("valid template"),
        ),
    };
    bar.set_prefix(name.to_string());
    bar
}

/// A temporary file beside `path`, to be renamed onto it when complete.
fn temp_beside(path: &Path) -> Result<tempfile::NamedTempFile> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    tempfile::Builder::new()
        .prefix(".ssl-")
        .suffix(".tmp")
        .tempfile_in(dir)
        .with_context(|| format!("{}: cannot create the output file", path.display()))
}

/// `ssl simulate`: render a scene to a WAV file and its truth, both atomically.
fn simulate(args: &SimulateArgs) -> Result<()> {
    use crate::scene::SampleFormat;
    use crate::synth::Encoding;
    let sim = crate::scene::simulate_file(&args.scene)?;
    let truth_path = args
        .truth
        .clone()
        .unwrap_or_else(|| args.output.with_extension("truth.json"));
    let encoding = match sim.format {
        SampleFormat::Int16 => Encoding::Int16,
        SampleFormat::Int24 => Encoding::Int24,
        SampleFormat::Int32 => Encoding::Int32,
        SampleFormat::Float32 => Encoding::Float32,
    };
    // A WAV writer must seek back to finish its header: only regular files will do.
    let OutputTarget::Atomic(wav, wav_path) = open_output(&args.output)? else {
        anyhow::bail!(
            "{}: the WAV output must be a regular file (not a device or pipe)",
            args.output.display()
        );
    };
    crate::synth::write_wav(wav.path(), &sim.channels, sim.sample_rate, encoding)?;
    let mut doc = sim.truth;
    doc["recording"] = serde_json::Value::from(args.output.display().to_string());
    let text = serde_json::to_string_pretty(&doc)? + "\n";
    let truth = open_output(&truth_path)?;
    wav.persist(&wav_path)
        .map_err(|e| e.error)
        .with_context(|| format!("{}: cannot write", args.output.display()))?;
    match truth {
        OutputTarget::Atomic(mut tmp, target) => {
            tmp.write_all(text.as_bytes())?;
            tmp.persist(&target)
                .map_err(|e| e.error)
                .with_context(|| format!("{}: cannot write", truth_path.display()))?;
        }
        OutputTarget::Direct(mut file) => file.write_all(text.as_bytes())?,
    }
    Ok(())
}

/// `ssl evaluate`: score a result against a truth file.
fn evaluate(args: &EvaluateArgs) -> Result<()> {
    use crate::evaluate::{evaluate, read_detections, Truth};
    let truth = Truth::from_file(&args.truth)?;
    let dets = read_detections(&args.result)?;
    let tail = args
        .tail
        .map_or(truth.rt60_s.map_or(0.0, |t| t / 2.0), f64::from);
    let report = evaluate(&truth, &dets, tail);
    let text = if args.json {
        serde_json::to_string_pretty(&report.json())? + "\n"
    } else {
        report.table()
    };
    let mut out = io::stdout().lock();
    out.write_all(text.as_bytes())?;
    out.flush()?;
    Ok(())
}

/// `ssl geometry`: what the tool understood of an array.
fn geometry(args: &GeometryArgs) -> Result<()> {
    let g = Geometry::from_file(&args.geometry)?;
    let path = args.geometry.display().to_string();
    for w in &g.warnings {
        eprintln!("ssl: warning: {path}: {w}");
    }
    let c = args.speed_of_sound.unwrap_or(g.speed_of_sound);
    let rate = args.rate as f64;
    let mut s = String::new();
    use std::fmt::Write as _;
    let _ = writeln!(
        s,
        "geometry:        {path}{}",
        g.name
            .as_ref()
            .map(|n| format!(" ({n})"))
            .unwrap_or_default()
    );
    let _ = writeln!(s, "microphones:     {}", g.mics.len());
    let _ = writeln!(s, "shape:           {}", g.shape.label());
    if let Some(note) = output::ambiguity_note(&g) {
        let _ = writeln!(s, "note:            {note}");
    }
    let (aperture, i, j) = g.aperture();
    let _ = writeln!(
        s,
        "aperture:        {aperture:.4} m (mics {} and {})",
        i + 1,
        j + 1
    );
    let _ = writeln!(
        s,
        "centre:          [{:.4}, {:.4}, {:.4}] m",
        g.centre.x + 0.0,
        g.centre.y + 0.0,
        g.centre.z + 0.0
    );
    let _ = writeln!(s, "speed of sound:  {c} m/s");
    let n = default_frame_size(args.rate);
    let _ = writeln!(
        s,
        "sample rate:     {} Hz (default frame size {n} = {:.1} ms)",
        args.rate,
        n as f64 * 1000.0 / rate
    );
    let _ = writeln!(s, "\n mic  channel         x         y         z");
    for (k, m) in g.mics.iter().enumerate() {
        let _ = writeln!(
            s,
            "{:>4}  {:>7}  {:>8.4}  {:>8.4}  {:>8.4}",
            k + 1,
            m.channel,
            m.position.x + 0.0,
            m.position.y + 0.0,
            m.position.z + 0.0
        );
    }
    let _ = writeln!(s, "\n pair   distance_m  max_lag_samples");
    let count = g.mics.len();
    for a in 0..count {
        for b in a + 1..count {
            debug_assert!(pair_index(a, b, count) < count * count);
            let _ = writeln!(
                s,
                "{:>2}-{:<2}  {:>10.4}  {:>15.2}",
                a + 1,
                b + 1,
                g.spacing(a, b),
                g.max_lag_samples(a, b, rate, c)
            );
        }
    }
    let mut out = io::stdout().lock();
    out.write_all(s.as_bytes())?;
    out.flush()?;
    Ok(())
}
