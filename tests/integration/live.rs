//! Live input: when `ssl analyze -` reads a pipe fed in real time, each record of a
//! confirmed track leaves within 100 ms of the audio that completes its frame (after the
//! first 0.25 s, which primes the noise estimate) with `--smooth-s 0`, 53 ms of it
//! waiting for the five frames that average it, and within 200 ms more with the default
//! smoothing, which waits 0.2 s for the track's rows after it.

use crate::support;

use ssl::geometry::unit_from_angles;
use ssl::sim::freefield::{render, Place, Scene, Source};
use ssl::sim::signals::Signal;
use std::io::{BufRead, BufReader, Write};
use std::process::Stdio;
use std::time::{Duration, Instant};
use support::*;

#[test]
fn records_from_a_paced_pipe_leave_within_100_ms() {
    paced_pipe(&["--smooth-s", "0"], 0.1);
}

#[test]
fn smoothed_records_from_a_paced_pipe_leave_within_300_ms() {
    paced_pipe(&[], 0.3);
}

/// Feeds a recording through a pipe in real time to `ssl analyze -` with `args`, and
/// checks that every record leaves within `within_s` of the audio that completes its
/// frame.
fn paced_pipe(args: &[&str], within_s: f64) {
    let dir = tempdir();
    let geo = write(dir.path(), "prism.toml", geometry_toml(&prism(), ""));
    let rate = 48000usize;
    let channels = render(&Scene {
        sample_rate: rate as u32,
        duration_s: 3.0,
        mics: prism(),
        speed_of_sound: 343.0,
        sources: vec![Source {
            place: Place::Direction(unit_from_angles(60.0, 10.0)),
            signal: Signal::WhiteNoise,
            start_s: 0.8,
            end_s: 2.6,
            level: 0.05,
        }],
        sensor_noise: 0.002,
        seed: 8,
    });
    let pcm = pcm16(&channels);
    // A WAV header with the placeholder lengths a pipe carries.
    let mut header = raw_wav(
        b"RIFF",
        &fmt_body(1, 8, rate as u32, 16),
        &[],
        Some(u32::MAX),
    );
    header[4..8].copy_from_slice(&u32::MAX.to_le_bytes());
    let mut child = ssl()
        .args([
            "analyze",
            "-",
            "-g",
            geo.to_str().unwrap(),
            "-f",
            "ndjson",
            "-j",
            "1",
        ])
        .args(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut stdin = child.stdin.take().unwrap();
    let start = Instant::now();
    // The writer sends 10 ms of audio every 10 ms, in real time.
    let writer = std::thread::spawn(move || {
        stdin.write_all(&header).unwrap();
        let chunk = rate / 100 * 16;
        for (i, part) in pcm.chunks(chunk).enumerate() {
            let due = Duration::from_millis(10 * i as u64);
            if let Some(wait) = due.checked_sub(start.elapsed()) {
                std::thread::sleep(wait);
            }
            stdin.write_all(part).unwrap();
            stdin.flush().unwrap();
        }
    });
    let reader = BufReader::new(child.stdout.take().unwrap());
    let mut latencies = Vec::new();
    for line in reader.lines() {
        let arrived = start.elapsed().as_secs_f64();
        let record: serde_json::Value = serde_json::from_str(&line.unwrap()).unwrap();
        // The frame is complete when the 10 ms chunk with its last sample is written.
        let frame = record["frame"].as_u64().unwrap();
        let last_sample = frame as usize * 512 + 1023;
        let written = (last_sample / (rate / 100)) as f64 * 0.01;
        latencies.push((frame, arrived - written));
    }
    writer.join().unwrap();
    let out = child.wait_with_output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(latencies.len() > 100, "{} records", latencies.len());
    let worst = latencies
        .iter()
        .cloned()
        .fold((0, f64::MIN), |a, b| if b.1 > a.1 { b } else { a });
    eprintln!(
        "{} records, worst latency {:.1} ms (frame {})",
        latencies.len(),
        worst.1 * 1000.0,
        worst.0
    );
    assert!(
        worst.1 < within_s,
        "frame {} left {:.0} ms after its audio",
        worst.0,
        worst.1 * 1000.0
    );
}
