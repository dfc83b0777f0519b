//! FLAC input: a FLAC file gives the same rows as the WAV of the same samples, from a
//! file and from a pipe, at 16 and 24 bits; a damaged one is one clear error.

use crate::support;

use flacenc::component::BitRepr;
use flacenc::error::Verify;
use ssl::sim::Encoding;
use std::path::{Path, PathBuf};
use support::*;

/// The FLAC of interleaved integer `samples` (encoded by flacenc, an encoder independent
/// of the decoder under test).
fn flac_bytes(samples: &[i32], channels: usize, bits: usize, rate: usize) -> Vec<u8> {
    let config = flacenc::config::Encoder::default()
        .into_verified()
        .expect("default config");
    let source = flacenc::source::MemSource::from_samples(samples, channels, bits, rate);
    let stream =
        flacenc::encode_with_fixed_block_size(&config, source, config.block_size).expect("encodes");
    let mut sink = flacenc::bitsink::ByteSink::new();
    stream.write(&mut sink).expect("writes");
    sink.as_slice().to_vec()
}

/// `wav` (integer PCM) re-encoded as FLAC next to it.
fn as_flac(wav: &Path) -> PathBuf {
    let mut reader = hound::WavReader::open(wav).unwrap();
    let spec = reader.spec();
    let samples: Vec<i32> = reader.samples::<i32>().map(Result::unwrap).collect();
    let bytes = flac_bytes(
        &samples,
        spec.channels as usize,
        spec.bits_per_sample as usize,
        spec.sample_rate as usize,
    );
    let path = wav.with_extension("flac");
    std::fs::write(&path, bytes).unwrap();
    path
}

#[test]
fn flac_gives_the_rows_of_the_same_samples_in_wav() {
    for (encoding, name) in [
        (Encoding::Int16, "rec16.wav"),
        (Encoding::Int24, "rec24.wav"),
    ] {
        let dir = tempdir();
        let sc = scene(
            prism(),
            48000,
            &[(30.0, 10.0, ssl::sim::signals::Signal::WhiteNoise)],
            0.6,
            0.005,
            1,
        );
        let wav = render_wav(dir.path(), name, &sc, encoding);
        let flac = as_flac(&wav);
        let geometry = write(dir.path(), "prism.toml", geometry_toml(&prism(), ""));
        let analyze = |input: &Path| {
            let out = run(&["analyze", s(input), "-g", s(&geometry)]);
            assert!(out.status.success(), "{}", stderr(&out));
            String::from_utf8(out.stdout).unwrap()
        };
        let from_wav = analyze(&wav);
        let from_flac = analyze(&flac);
        assert!(parse_csv(&from_wav).len() > 30);
        assert_eq!(
            from_flac.replace(s(&flac), "F"),
            from_wav.replace(s(&wav), "F"),
            "{name}"
        );
        // From a pipe: the same rows.
        let piped = run_with_stdin(
            &["analyze", "-", "-g", s(&geometry)],
            std::fs::read(&flac).unwrap(),
        );
        assert!(piped.status.success(), "{}", stderr(&piped));
        assert_eq!(
            String::from_utf8(piped.stdout)
                .unwrap()
                .replace("<stdin>", "F"),
            from_wav.replace(s(&wav), "F")
        );
        // The JSON metadata names the format.
        let out = run(&["analyze", s(&flac), "-g", s(&geometry), "--format", "json"]);
        let doc: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        let format = doc["files"][0]["format"].as_str().unwrap().to_string();
        assert!(format.ends_with("-bit FLAC"), "{format}");
        // ssl check reads it too.
        let out = run(&["check", s(&flac), "-g", s(&geometry)]);
        assert!(matches!(out.status.code(), Some(0 | 1)), "{}", stderr(&out));
    }
}

#[test]
fn a_damaged_flac_is_one_clear_error_after_the_rows_before_it() {
    let (dir, wav, geometry) = recording(0.8);
    let flac = as_flac(&wav);
    let bytes = std::fs::read(&flac).unwrap();
    // Cut in the middle of the blocks, and garbled there.
    let cut = write(dir.path(), "cut.flac", &bytes[..bytes.len() * 2 / 3]);
    let mut garbled = bytes.clone();
    let at = garbled.len() / 2;
    garbled[at..at + 64].iter_mut().for_each(|b| *b ^= 0x5A);
    let garbled = write(dir.path(), "garbled.flac", &garbled);
    for path in [&cut, &garbled] {
        let out = run(&["analyze", s(path), "-g", s(&geometry)]);
        assert_eq!(out.status.code(), Some(1), "{}", stderr(&out));
        let e = stderr(&out);
        let errors: Vec<&str> = e.lines().filter(|l| l.contains("error")).collect();
        assert_eq!(errors.len(), 1, "{e}");
        assert!(
            errors[0].contains(s(path)) && errors[0].contains("FLAC") && errors[0].contains(" s)"),
            "{e}"
        );
        // The rows before the damage are written.
        assert!(!parse_csv(&String::from_utf8(out.stdout).unwrap()).is_empty());
    }
    // Only the stream header: no rows, one error.
    let head = write(dir.path(), "head.flac", &bytes[..4]);
    let out = run(&["analyze", s(&head), "-g", s(&geometry)]);
    assert_eq!(out.status.code(), Some(1));
    assert!(stderr(&out).contains("head.flac"), "{}", stderr(&out));
}
