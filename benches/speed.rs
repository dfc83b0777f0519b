//! Speed and memory of `ssl analyze` against the FFT floor, on sparse and on busy audio,
//! on one core and on two: `cargo bench --bench speed > docs/speed.md` (about five
//! minutes; the page is this program's output, whole).
//!
//! Three scenes are rendered by `ssl simulate` (tests/support/scenes.rs): sparse bursts
//! from one direction in free field on the paper's prism, a reverberant four-talker
//! meeting on the prism, and two talkers at once on 32 microphones. For each, in
//! [`ROUNDS`] rounds, it runs the `ssl` binary at the defaults on one thread and on two,
//! with `--no-track` and with `--paper`, each between two measurements of the FFT floor
//! (the forward and inverse real FFTs of 1024 a hop needs for that many microphones, with
//! realfft, as many as the recording has hops), so that a run and its floor see the same
//! machine load; it reports each run's ratio to the mean of its two floors (the median of
//! the rounds, and their range), the shortest times, peak resident memory (VmHWM) and the stages of one
//! `--timings` run. The sparse recording repeated ten times shows that memory does not
//! grow with the length.

#[path = "../tests/support/mod.rs"]
mod support;

use realfft::num_complex::Complex32;
use realfft::RealFftPlanner;
use std::error::Error;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;
use support::harness::{binary, run_measured};
use support::scenes::{bursts_toml, meeting_toml, two_talkers_toml};

/// Rounds of every measurement; the page gives the median ratio and the shortest times.
const ROUNDS: usize = 7;

type Result<T> = std::result::Result<T, Box<dyn Error>>;

/// A recording to time, with how it was made.
struct Scene {
    name: &'static str,
    about: String,
    wav: PathBuf,
    geometry: PathBuf,
    mics: usize,
    seconds: f64,
}

/// One scene's figures.
struct Figures {
    frames: u64,
    /// The shortest floor measured.
    floor_s: f64,
    runs: Vec<Run>,
    timings: String,
}

fn s(p: &Path) -> &str {
    p.to_str().expect("a UTF-8 temporary path")
}

fn main() -> Result<()> {
    let dir = tempfile::tempdir()?;
    let exe = binary();
    let prism = dir.path().join("prism");
    let sphere = dir.path().join("sphere");
    for (folder, mics) in [
        (&prism, support::prism()),
        (&sphere, support::sphere_lattice(32, 0.25)),
    ] {
        std::fs::create_dir_all(folder)?;
        std::fs::write(folder.join("array.toml"), support::geometry_toml(&mics, ""))?;
        support::copy_speech(folder)?;
    }
    let (meeting, meeting_s) = meeting_toml(48000, 5);
    let specs = [
        (
            "sparse",
            "60 s of white-noise bursts, 0.5 s every 3 s, from one direction in free field, on the prism (8 mics)".to_string(),
            &prism,
            8,
            bursts_toml(48000, 60.0, 3),
            60.0,
        ),
        (
            "busy",
            format!("{meeting_s:.1} s of a meeting: four talkers taking twelve turns, some overlapping, in a reverberant room (RT60 0.35 s) with a fan, on the prism (8 mics)"),
            &prism,
            8,
            meeting,
            meeting_s,
        ),
        (
            "32 mics",
            "15 s of two talkers at once, three times, in the same room, on 32 mics over a 0.25 m sphere".to_string(),
            &sphere,
            32,
            two_talkers_toml(48000, 4),
            15.0,
        ),
    ];
    let mut scenes = Vec::new();
    for (name, about, folder, mics, toml, seconds) in specs {
        let file = name.replace(' ', "_");
        let scene = folder.join(format!("{file}.toml"));
        std::fs::write(&scene, toml)?;
        let wav = folder.join(format!("{file}.wav"));
        run_measured(exe, &["simulate", s(&scene), "-o", s(&wav)])?;
        scenes.push(Scene {
            name,
            about,
            wav,
            geometry: folder.join("array.toml"),
            mics,
            seconds,
        });
    }

    let figures: Vec<Figures> = scenes.iter().map(measure).collect::<Result<_>>()?;

    // Memory against length: the sparse recording, and ten of it end to end.
    let long = dir.path().join("prism").join("sparse_x10.wav");
    repeat(&scenes[0].wav, &long, 10)?;
    let mut memory = Vec::new();
    for wav in [&scenes[0].wav, &long] {
        let (wall, peak) = run_measured(
            exe,
            &[
                "analyze",
                s(wav),
                "-g",
                s(&scenes[0].geometry),
                "-j",
                "1",
                "-q",
                "-o",
                "/dev/null",
            ],
        )?;
        memory.push((wall, peak));
    }

    print_page(&scenes, &figures, &memory);
    Ok(())
}

/// The floor, the runs and the stage times of one scene.
fn measure(scene: &Scene) -> Result<Figures> {
    let exe = binary();
    let frames = ((scene.seconds * 48000.0 - 1024.0) / 512.0).floor() as u64 + 1;
    let options: [(&str, &[&str], usize); 4] = [
        ("defaults", &[], 1),
        ("defaults", &[], 2),
        ("--no-track", &["--no-track"], 1),
        ("--paper", &["--paper"], 1),
    ];
    let mut floors = Vec::new();
    let mut walls = vec![Vec::new(); options.len()];
    let mut ratios = vec![Vec::new(); options.len()];
    let mut peaks = vec![0.0f64; options.len()];
    for _ in 0..ROUNDS {
        let mut before = floor_seconds(scene.mics, frames)?;
        floors.push(before);
        for (i, (_, extra, threads)) in options.iter().enumerate() {
            let threads = threads.to_string();
            let (wall, peak) = run_measured(exe, &analyze_args(scene, &threads, extra))?;
            let after = floor_seconds(scene.mics, frames)?;
            floors.push(after);
            walls[i].push(wall);
            ratios[i].push(wall / (0.5 * (before + after)));
            peaks[i] = peaks[i].max(peak);
            before = after;
        }
    }
    let out = Command::new(exe)
        .args(analyze_args(scene, "1", &["--timings"]))
        .output()?;
    if !out.status.success() {
        return Err(format!("ssl analyze --timings failed on {}", scene.name).into());
    }
    Ok(Figures {
        frames,
        floor_s: best(&floors),
        runs: walls
            .iter()
            .zip(ratios)
            .zip(peaks)
            .map(|((walls, mut ratios), peak)| {
                ratios.sort_by(f64::total_cmp);
                Run {
                    wall: best(walls),
                    ratio: ratios[ratios.len() / 2],
                    range: (ratios[0], ratios[ratios.len() - 1]),
                    peak_mb: peak,
                }
            })
            .collect(),
        timings: String::from_utf8(out.stderr)?,
    })
}

/// One configuration's figures over the rounds.
struct Run {
    /// The shortest wall time (seconds).
    wall: f64,
    /// The median of the rounds' ratios of the wall time to the mean of the floors
    /// measured just before and just after it, and the lowest and highest of them.
    ratio: f64,
    range: (f64, f64),
    peak_mb: f64,
}

/// `ssl analyze` of `scene` on `threads` threads, the output discarded, with `extra`.
fn analyze_args<'a>(scene: &'a Scene, threads: &'a str, extra: &[&'a str]) -> Vec<&'a str> {
    let mut args = vec![
        "analyze",
        s(&scene.wav),
        "-g",
        s(&scene.geometry),
        "-q",
        "-o",
        "/dev/null",
        "-j",
        threads,
    ];
    args.extend_from_slice(extra);
    args
}

/// The shortest of some times: what the machine gives when nothing else slows it.
fn best(v: &[f64]) -> f64 {
    v.iter().copied().fold(f64::INFINITY, f64::min)
}

/// The FFT floor of `frames` hops of `mics` microphones: `mics` forward and
/// `mics (mics - 1) / 2` inverse real FFTs of 1024 each (realfft), in seconds.
fn floor_seconds(mics: usize, frames: u64) -> Result<f64> {
    let mut planner = RealFftPlanner::<f32>::new();
    let forward = planner.plan_fft_forward(1024);
    let inverse = planner.plan_fft_inverse(1024);
    let mut input: Vec<f32> = (0..1024)
        .map(|i| ((i * 7919) % 1000) as f32 * 1e-3 - 0.5)
        .collect();
    let mut spectrum = forward.make_output_vec();
    let mut scratch = forward.make_scratch_vec();
    let mut cross = vec![Complex32::new(0.5, 0.1); 513];
    let mut out = vec![0.0f32; 1024];
    let mut inverse_scratch = inverse.make_scratch_vec();
    let pairs = mics * (mics - 1) / 2;
    let start = Instant::now();
    for _ in 0..frames {
        for _ in 0..mics {
            forward.process_with_scratch(&mut input, &mut spectrum, &mut scratch)?;
        }
        for _ in 0..pairs {
            cross[0].im = 0.0;
            cross[512].im = 0.0;
            inverse.process_with_scratch(&mut cross, &mut out, &mut inverse_scratch)?;
        }
    }
    std::hint::black_box(&out);
    Ok(start.elapsed().as_secs_f64())
}

/// Writes `times` copies of the WAV file `from`, end to end, to `to`.
fn repeat(from: &Path, to: &Path, times: usize) -> Result<()> {
    let mut reader = hound::WavReader::open(from)?;
    let samples: Vec<i16> = reader
        .samples::<i16>()
        .collect::<std::result::Result<_, _>>()?;
    let mut writer = hound::WavWriter::create(to, reader.spec())?;
    for _ in 0..times {
        for &v in &samples {
            writer.write_sample(v)?;
        }
    }
    writer.finalize()?;
    Ok(())
}

fn print_page(scenes: &[Scene], figures: &[Figures], memory: &[(f64, f64)]) {
    let cores = support::harness::cores();
    println!("# Speed and memory\n");
    println!(
        "Made by `cargo bench --bench speed > docs/speed.md` (benches/speed.rs) on a machine with {cores} cores. \
         The machine is a shared virtual machine: other work on it slows the same command by 10-30% from \
         run to run on a quiet day and more on a busy one, and its FFTs themselves vary from day to day, so \
         the figures to compare are the ratios to the FFT floor: in each of {ROUNDS} rounds every run comes \
         between two measurements of its floor and is divided by their mean, so that both see the same \
         load, and the page gives the median of the rounds' ratios in bold, their lowest and highest in \
         brackets. Absolute times are \
         the shortest of the rounds (what the machine gives when nothing else slows it), this machine's on \
         that day. A run is the `ssl` \
         binary end to end (`ssl analyze REC.wav -g ARRAY.toml -q -o /dev/null -j N [options]`): starting, \
         reading the 16-bit WAV file, writing CSV.\n"
    );
    println!(
        "**The FFT floor** of a recording is the work of its FFTs alone: per hop of 512 samples, one forward \
         real FFT of 1024 per microphone and one inverse per pair (8 and 28 for the prism, 32 and 496 for 32 \
         microphones), with realfft, the library ssl uses. ssl does less than that where it can: two \
         channels or two pairs per complex FFT, and no correlation in a frame whose weights prove it cannot \
         hold a detection.\n"
    );
    println!("## The scenes\n");
    for scene in scenes {
        println!("- **{}**: {}.", scene.name, scene.about);
    }
    println!("\n## Against the floor\n");
    println!("| scene | floor | defaults, 1 thread | defaults, 2 threads | `--no-track`, 1 thread | `--paper`, 1 thread | peak memory |");
    println!("|---|---|---|---|---|---|---|");
    for (scene, f) in scenes.iter().zip(figures) {
        let cell = |run: &Run| {
            format!(
                "**{:.2}x** the floor ({:.2}-{:.2}); {:.2} s: {:.0}x real time",
                run.ratio,
                run.range.0,
                run.range.1,
                run.wall,
                scene.seconds / run.wall,
            )
        };
        let peak = f.runs.iter().map(|r| r.peak_mb).fold(0.0, f64::max);
        println!(
            "| {} | {:.2} s ({:.0} us a hop, {:.0}x real time) | {} | {} | {} | {} | {peak:.1} MB |",
            scene.name,
            f.floor_s,
            1e6 * f.floor_s / f.frames as f64,
            scene.seconds / f.floor_s,
            cell(&f.runs[0]),
            cell(&f.runs[1]),
            cell(&f.runs[2]),
            cell(&f.runs[3]),
        );
    }
    println!(
        "\nOn two threads the floor is shared too: the two-thread cells give the wall time against the \
         one-thread floor, so 0.5x there is as fast as two cores doing only FFTs.\n"
    );
    println!("## Memory against length\n");
    println!(
        "The sparse recording (60 s) and the same ten times over (600 s), defaults, one thread: {:.1} MB and \
         {:.1} MB peak resident memory ({:.2} s and {:.2} s). Audio is read a block of 128 frames at a time \
         and every output format is streamed, so memory does not grow with the length; `tests/no_alloc.rs` \
         checks that analysing a frame allocates nothing.\n",
        memory[0].1, memory[1].1, memory[0].0, memory[1].0
    );
    println!("## Where the time goes\n");
    println!(
        "`ssl analyze --timings` on one thread, after the rounds above (timing itself costs about 1 us a \
         frame). Stages: `read` (decoding and framing), `spectra` (forward FFTs, mean power), `noise` (the \
         noise estimate, in frame order), `weighting` (eq. 4-5 and whitening), `correlation` (cross-spectra \
         and inverse FFTs), `background` (the coherent background subtracted), `peaks` (averaging over the \
         frame's span and the M peaks), `search` (eq. 8), `direction` (eq. 13), `steered` (the steered \
         response: a direction the search missed, further sources), `patterns` (each talker's learned \
         pattern removed before a second look), `tracking`, `output`. The floor column is the stage's time \
         against the whole recording's floor.\n"
    );
    for (scene, f) in scenes.iter().zip(figures) {
        println!("### {}\n", scene.name);
        println!("| stage | seconds | share | us per frame | x floor |");
        println!("|---|---|---|---|---|");
        for line in f.timings.lines().skip(2) {
            let fields: Vec<&str> = line.split_whitespace().collect();
            if fields.len() != 4 {
                continue;
            }
            let seconds: f64 = fields[1].parse().unwrap_or(0.0);
            println!(
                "| {} | {} | {} | {} | {:.2} |",
                fields[0],
                fields[1],
                fields[2],
                fields[3],
                seconds / f.floor_s
            );
        }
        // The heading's figures without the temporary path: "(N frames, ...)".
        let heading = f.timings.lines().next().unwrap_or("");
        let summary = heading
            .split_once("stage times (")
            .map_or(heading, |(_, rest)| rest.trim_end_matches(')'));
        println!("\nThat run: {summary}.\n");
    }
}
