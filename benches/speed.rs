//! Whole-run speed and memory of `ssl analyze` against the FFT floor, on an 8-channel
//! 48 kHz recording with N = 1024.
//!
//! `cargo bench --bench speed -- [SECONDS] [KEEP.wav]` (default 600; 3600 for
//! the one-hour memory check; with KEEP.wav the recording is written there, or reused if
//! that file already exists, to repeat a measurement without rewriting it). It:
//! 1. writes a 16-bit recording of SECONDS to a temporary file, streaming a 10 s block
//!    of sources and fan noise repeatedly (the recording never sits in memory);
//! 2. runs the `ssl` binary on it (built by `cargo bench`) on one thread and
//!    on all cores, and reports wall time, x real time and peak resident memory (VmHWM,
//!    polled from /proc);
//! 3. runs the same analysis in this process on one thread with stage timing (and again
//!    with `--min-score 0`, where no correlation can be skipped), and measures the FFT
//!    floor in the same run: only the 8 forward and 28 inverse real FFTs per frame,
//!    with the same library and sizes, on the same data sizes;
//! 4. prints the stages as microseconds per frame and as a ratio to the floor.

#[path = "../tests/support/mod.rs"]
mod support;

use realfft::num_complex::Complex32;
use realfft::RealFftPlanner;
use ssl::method::direction::unit_from_angles;
use ssl::method::StageTimes;
use ssl::sim::freefield::{render, Place, Scene, Source};
use ssl::sim::signals::Signal;
use ssl::{Analysis, DetectionRecord, Format, Geometry, Params, RunMetadata};
use std::error::Error;
use std::io::Write;
use std::ops::ControlFlow;
use std::time::{Duration, Instant};
use support::harness::{args, binary, cores, run_measured, seconds_arg};

fn main() -> Result<(), Box<dyn Error>> {
    let seconds = seconds_arg(600.0)?;
    let dir = tempfile::tempdir()?;
    let keep = args().get(1).map(std::path::PathBuf::from);
    let wav = keep.clone().unwrap_or_else(|| dir.path().join("speed.wav"));
    let geo = support::testdata("prism.toml");
    if keep.is_none() || !wav.exists() {
        write_recording(&wav, seconds)?;
    } else {
        let reader = hound::WavReader::open(&wav)?;
        let spec = reader.spec();
        if reader.duration() != (seconds * 48000.0) as u32 || spec.channels != 8 {
            return Err(format!(
                "{} is not a {seconds} s recording of this benchmark: delete it or give another path",
                wav.display()
            )
            .into());
        }
    }
    let frames = ((seconds * 48000.0 - 1024.0) / 512.0).floor() + 1.0;

    // The binary, end to end.
    let exe = binary();
    let cores = cores();
    let mut runs = Vec::new();
    for threads in [1, cores] {
        let threads_arg = threads.to_string();
        let (wall, peak_mb) = run_measured(
            exe,
            &[
                "analyze",
                wav.to_str().unwrap(),
                "-g",
                geo.to_str().unwrap(),
                "-o",
                "/dev/null",
                "--threads",
                &threads_arg,
            ],
        )?;
        runs.push((threads, wall, peak_mb));
    }

    // The same analysis in-process with stage timing; and with --min-score 0, where no
    // correlation can be skipped (every frame needs all 28).
    let g = Geometry::from_file(&geo)?;
    // (This process runs nothing else on rayon's global pool: make it one thread.)
    rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build_global()?;
    // Detections are written as CSV (to a sink that discards the bytes), timed apart.
    let timed_run = |params: &Params| -> Result<(f64, StageTimes, Duration), Box<dyn Error>> {
        let mut analysis = Analysis::open(wav.to_str().unwrap(), &g, params)?;
        analysis.enable_stage_timing();
        let mut csv = Format::Csv.exporter(std::io::sink(), ssl::record::Records::Detections);
        csv.begin(&RunMetadata::new(&g, "prism.toml", params))?;
        let mut output = Duration::ZERO;
        let t = Instant::now();
        let (summary, result) = analysis.run(|_, detection| {
            for d in detection {
                let t = Instant::now();
                let record = DetectionRecord::new("speed.wav", d).expect("finite");
                csv.detection(&record).expect("a sink takes everything");
                output += t.elapsed();
            }
            ControlFlow::Continue(())
        });
        result?;
        Ok((
            t.elapsed().as_secs_f64(),
            summary.stage_times.unwrap_or_default(),
            output,
        ))
    };
    let (in_process, st, output) = timed_run(&Params::default())?;
    let (all_pairs, _, _) = timed_run(&{
        let mut p = Params::default();
        p.min_score_per_pair = 0.0;
        p.threshold_sigmas = None;
        p
    })?;

    // The FFT floor: 8 forward + 28 inverse real FFTs of 1024 per frame, and the transforms as ssl does them when it skips none: 4 forward and
    // 14 inverse complex FFTs of 1024, each carrying two channels or two pairs.
    let mut planner = RealFftPlanner::<f32>::new();
    let fwd = planner.plan_fft_forward(1024);
    let inv = planner.plan_fft_inverse(1024);
    let mut complex_planner = rustfft::FftPlanner::<f32>::new();
    let cfwd = complex_planner.plan_fft_forward(1024);
    let cinv = complex_planner.plan_fft_inverse(1024);
    let mut input = vec![0.1f32; 1024];
    let mut spec = fwd.make_output_vec();
    let mut scratch = fwd.make_scratch_vec();
    let mut out = vec![0.0f32; 1024];
    let mut iscratch = inv.make_scratch_vec();
    let mut cross = vec![Complex32::new(0.5, 0.1); 513];
    let mut packed = vec![Complex32::new(0.5, 0.1); 1024];
    let mut cscratch = vec![
        Complex32::default();
        cinv.get_inplace_scratch_len()
            .max(cfwd.get_inplace_scratch_len())
    ];
    let sample = (frames as usize).min(20000);
    let (mut floor, mut packed_floor) = (Duration::ZERO, Duration::ZERO);
    // Interleaved in rounds, so that both see the same machine load.
    for _ in 0..10 {
        let t = Instant::now();
        for _ in 0..sample / 10 {
            for _ in 0..8 {
                fwd.process_with_scratch(&mut input, &mut spec, &mut scratch)?;
            }
            for _ in 0..28 {
                cross[0].im = 0.0;
                cross[512].im = 0.0;
                inv.process_with_scratch(&mut cross, &mut out, &mut iscratch)?;
            }
        }
        floor += t.elapsed();
        let t = Instant::now();
        for _ in 0..sample / 10 {
            for _ in 0..4 {
                cfwd.process_with_scratch(&mut packed, &mut cscratch);
            }
            for _ in 0..14 {
                cinv.process_with_scratch(&mut packed, &mut cscratch);
            }
        }
        packed_floor += t.elapsed();
    }
    let per_frame = |d: Duration| d.as_secs_f64() / (sample / 10 * 10) as f64;
    let floor_per_frame = per_frame(floor);
    let packed_per_frame = per_frame(packed_floor);

    let us = |d: Duration| d.as_secs_f64() / frames * 1e6;
    let floor_us = floor_per_frame * 1e6;
    println!("recording: {seconds:.0} s, 8 channels, 48 kHz, 16-bit, {frames:.0} frames of 1024");
    for (threads, wall, peak_mb) in &runs {
        println!(
            "ssl analyze --threads {threads}: {wall:.2} s wall, {:.0}x real time, peak memory {peak_mb:.1} MB",
            seconds / wall,
        );
    }
    let pipeline_us = in_process / frames * 1e6;
    println!(
        "FFT floor (8 real forward + 28 real inverse FFTs of 1024, realfft): {floor_us:.1} us per frame ({:.0}x real time)",
        512.0 / 48000.0 / floor_per_frame
    );
    println!(
        "transforms as ssl does them (4 forward + 14 inverse complex FFTs of 1024, two channels or pairs each): {:.1} us per frame",
        packed_per_frame * 1e6
    );
    println!(
        "pipeline in-process, 1 thread: {pipeline_us:.1} us per frame = {:.2}x the FFT floor ({:.2}x the transforms as ssl does them)",
        pipeline_us / floor_us,
        pipeline_us / (packed_per_frame * 1e6)
    );
    let pairs = st.correlated_pairs + st.skipped_pairs;
    println!(
        "pair correlations computed: {:.1} per frame of {:.1} ({:.0}% proven unnecessary by the weights' ceiling)",
        st.correlated_pairs as f64 / frames,
        pairs as f64 / frames,
        100.0 * st.skipped_pairs as f64 / pairs.max(1) as f64
    );
    let all_us = all_pairs / frames * 1e6;
    println!(
        "with --min-score 0 (all 28 correlations in every frame): {all_us:.1} us per frame = {:.2}x the FFT floor ({:.2}x the transforms as ssl does them)\n",
        all_us / floor_us,
        all_us / (packed_per_frame * 1e6)
    );
    println!("| stage | us per frame | x floor |");
    println!("|---|---|---|");
    let timed =
        st.spectra + st.weighting + st.correlation + st.peaks + st.search + st.direction + output;
    let read = Duration::from_secs_f64((in_process - timed.as_secs_f64()).max(0.0));
    for (name, d) in [
        ("read, convert, frame (the rest)", read),
        ("forward FFTs + power", st.spectra),
        ("weighting + whitening", st.weighting),
        ("cross-spectra + inverse FFTs", st.correlation),
        ("peaks", st.peaks),
        ("search", st.search),
        ("direction", st.direction),
        ("output (CSV)", output),
    ] {
        println!("| {name} | {:.1} | {:.2} |", us(d), us(d) / floor_us);
    }
    std::io::stdout().flush()?;
    Ok(())
}

/// Writes `seconds` of a 16-bit 8-channel recording by repeating a 10 s rendered block.
fn write_recording(path: &std::path::Path, seconds: f64) -> Result<(), Box<dyn Error>> {
    let mics = support::prism();
    let mut sources: Vec<Source> = (0..6)
        .map(|i| Source {
            place: Place::Direction(unit_from_angles(
                -150.0 + 60.0 * i as f64,
                -10.0 + 8.0 * i as f64,
            )),
            signal: if i % 2 == 0 {
                Signal::SpeechLike
            } else {
                Signal::WhiteNoise
            },
            start_s: 0.3 + 1.6 * i as f64,
            end_s: 1.3 + 1.6 * i as f64,
            level: 0.05,
        })
        .collect();
    sources.push(Source {
        place: Place::Direction(unit_from_angles(80.0, 40.0)),
        signal: Signal::PinkNoise,
        start_s: 0.0,
        end_s: 10.0,
        level: 0.015,
    });
    let block = render(&Scene {
        sample_rate: 48000,
        duration_s: 10.0,
        mics,
        speed_of_sound: 343.0,
        sources,
        sensor_noise: 0.001,
        seed: 9,
    });
    let spec = hound::WavSpec {
        channels: 8,
        sample_rate: 48000,
        bits_per_sample: 16,
        sample_format: hound::SampleFormat::Int,
    };
    let mut w = hound::WavWriter::create(path, spec)?;
    let total = (seconds * 48000.0) as usize;
    let len = block[0].len();
    for i in 0..total {
        for ch in &block {
            w.write_sample((ch[i % len] * 32768.0).round().clamp(-32768.0, 32767.0) as i16)?;
        }
    }
    w.finalize()?;
    Ok(())
}
