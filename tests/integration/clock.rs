//! `--clock`: wall-clock times from a Broadcast WAV `bext` time reference, on rows and
//! events, in every format, from a file and a pipe; without the flag the chunk changes
//! nothing; without a time reference, `--clock` is one clear error.

use crate::support;

use support::*;

/// `wav` with a `bext` chunk (date, and `samples` from midnight) before its format chunk.
fn with_bext(wav: &[u8], date: &str, samples: u64) -> Vec<u8> {
    let mut body = vec![0u8; 602];
    body[..11].copy_from_slice(b"lab session");
    body[320..330].copy_from_slice(date.as_bytes());
    body[330..338].copy_from_slice(b"14:03:05");
    body[338..342].copy_from_slice(&(samples as u32).to_le_bytes());
    body[342..346].copy_from_slice(&((samples >> 32) as u32).to_le_bytes());
    let mut out = wav[..12].to_vec();
    out.extend_from_slice(b"bext");
    out.extend_from_slice(&(body.len() as u32).to_le_bytes());
    out.extend_from_slice(&body);
    out.extend_from_slice(&wav[12..]);
    let riff = (out.len() - 8) as u32;
    out[4..8].copy_from_slice(&riff.to_le_bytes());
    out
}

/// `HH:MM:SS.ffffff` of `micros` microseconds after midnight.
fn time_of_day(micros: u64) -> String {
    let s = micros / 1_000_000;
    format!(
        "{:02}:{:02}:{:02}.{:06}",
        s / 3600,
        s / 60 % 60,
        s % 60,
        micros % 1_000_000
    )
}

#[test]
fn rows_and_events_carry_the_recorders_clock() {
    let (dir, wav, geometry) = recording(1.0);
    let plain = std::fs::read(&wav).unwrap();
    // 14:03:05.25 at 48 kHz.
    let start_us: u64 = 50_585_250_000;
    let bwf = write(
        dir.path(),
        "bwf.wav",
        with_bext(&plain, "2026-05-04", start_us * 48 / 1000),
    );
    let analyze = |input: &std::path::Path, extra: &[&str]| {
        let mut args = vec!["analyze", s(input), "-g", s(&geometry)];
        args.extend_from_slice(extra);
        let out = run(&args);
        assert!(out.status.success(), "{}", stderr(&out));
        String::from_utf8(out.stdout).unwrap()
    };
    // Without --clock the chunk changes nothing.
    assert_eq!(
        analyze(&bwf, &[]).replace(s(&bwf), "F"),
        analyze(&wav, &[]).replace(s(&wav), "F")
    );
    let text = analyze(&bwf, &["--clock"]);
    assert!(text
        .lines()
        .next()
        .unwrap()
        .ends_with(",uncertainty_deg,clock"));
    let rows = ssl::record::parse_detections(&text).unwrap();
    assert!(rows.len() > 30);
    for r in &rows {
        let micros = start_us + (r.time_s * 1e6).round() as u64;
        assert_eq!(
            r.clock.as_deref().unwrap(),
            format!("2026-05-04T{}", time_of_day(micros))
        );
    }
    // Events, in NDJSON; and the same from a pipe.
    let events = analyze(&bwf, &["--clock", "--events", "--format", "ndjson"]);
    let first: serde_json::Value = serde_json::from_str(events.lines().next().unwrap()).unwrap();
    let start_s = first["start_s"].as_f64().unwrap();
    let micros = start_us + (start_s * 1e6).round() as u64;
    assert_eq!(
        first["start_clock"],
        format!("2026-05-04T{}", time_of_day(micros))
    );
    assert!(first["end_clock"].as_str().unwrap() > first["start_clock"].as_str().unwrap());
    let piped = run_with_stdin(
        &["analyze", "-", "-g", s(&geometry), "--clock"],
        std::fs::read(&bwf).unwrap(),
    );
    assert_eq!(
        String::from_utf8(piped.stdout)
            .unwrap()
            .replace("<stdin>", "F"),
        text.replace(s(&bwf), "F")
    );
    // JSON: the field on every row, and the parameter recorded.
    let doc: serde_json::Value =
        serde_json::from_str(&analyze(&bwf, &["--clock", "--format", "json"])).unwrap();
    assert_eq!(doc["parameters"]["clock"], true);
    assert!(doc["detections"][0]["clock"].is_string());
}

#[test]
fn clock_without_a_time_reference_is_one_clear_error() {
    let (dir, wav, geometry) = recording(0.3);
    let undated = write(
        dir.path(),
        "undated.wav",
        with_bext(&std::fs::read(&wav).unwrap(), "          ", 48000),
    );
    for (input, says) in [
        (&wav, "no Broadcast WAV bext chunk"),
        (&undated, "not a date"),
    ] {
        let out = run(&["analyze", s(input), "-g", s(&geometry), "--clock"]);
        assert_eq!(out.status.code(), Some(1));
        let e = stderr(&out);
        assert!(e.contains(s(input)) && e.contains(says), "{e}");
        assert_eq!(e.trim().lines().count(), 1, "{e}");
        assert!(
            out.stdout.is_empty() || parse_csv(&String::from_utf8(out.stdout).unwrap()).is_empty()
        );
    }
}

#[test]
fn a_time_reference_past_a_day_is_not_a_time_and_two_bext_chunks_are_refused() {
    let (dir, wav, geometry) = recording(0.3);
    let plain = std::fs::read(&wav).unwrap();
    let far = write(
        dir.path(),
        "far.wav",
        with_bext(&plain, "2026-05-04", u64::MAX),
    );
    let out = run(&["analyze", s(&far), "-g", s(&geometry), "--clock"]);
    assert_eq!(out.status.code(), Some(1));
    let e = stderr(&out);
    assert!(e.contains("is not a time"), "{e}");
    assert!(!e.contains("-95"), "{e}");
    // Without --clock the recording is analysed as any other.
    let out = run(&["analyze", s(&far), "-g", s(&geometry)]);
    assert!(out.status.success(), "{}", stderr(&out));
    let twice = write(
        dir.path(),
        "twice.wav",
        with_bext(&with_bext(&plain, "2026-05-04", 48000), "2026-05-05", 96000),
    );
    let out = run(&["analyze", s(&twice), "-g", s(&geometry), "--clock"]);
    assert_ne!(out.status.code(), Some(0));
    assert!(stderr(&out).contains("two bext chunks"), "{}", stderr(&out));
}
