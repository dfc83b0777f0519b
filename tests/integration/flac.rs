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
        let wav = white_noise_wav(dir.path(), name, encoding);
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

/// 0.6 s of white noise from azimuth 30, elevation 10 on the prism at 48 kHz.
fn white_noise_wav(dir: &Path, name: &str, encoding: Encoding) -> PathBuf {
    let sc = scene(
        prism(),
        48000,
        &[(30.0, 10.0, ssl::sim::signals::Signal::WhiteNoise)],
        0.6,
        0.005,
        1,
    );
    render_wav(dir, name, &sc, encoding)
}

/// A short FLAC of the prism scene at 48 kHz, its bytes, and the prism's geometry.
fn short_flac(dir: &Path) -> (Vec<u8>, PathBuf) {
    let wav = white_noise_wav(dir, "rec.wav", Encoding::Int16);
    let flac = as_flac(&wav);
    let geometry = write(dir, "prism.toml", geometry_toml(&prism(), ""));
    (std::fs::read(flac).unwrap(), geometry)
}

#[test]
fn a_flac_behind_an_id3_tag_is_read_as_flac() {
    let dir = tempdir();
    let (bytes, geometry) = short_flac(dir.path());
    // An ID3v2.4 tag of 20 bytes of frames (a syncsafe size), then the FLAC.
    let mut tagged = b"ID3\x04\x00\x00\x00\x00\x00\x14".to_vec();
    tagged.extend_from_slice(&[0u8; 20]);
    tagged.extend_from_slice(&bytes);
    let plain = write(dir.path(), "plain.flac", &bytes);
    let with_tag = write(dir.path(), "tagged.flac", &tagged);
    let rows = |p: &Path| {
        let o = run(&["analyze", s(p), "-g", s(&geometry)]);
        assert!(o.status.success(), "{}", stderr(&o));
        String::from_utf8(o.stdout).unwrap().replace(s(p), "F")
    };
    assert_eq!(rows(&with_tag), rows(&plain));
    // An ID3 tag before something else is still named for what it is.
    let mut mp3 = b"ID3\x04\x00\x00\x00\x00\x00\x02\x00\x00".to_vec();
    mp3.extend_from_slice(&[0xFF, 0xFB, 0x90, 0x00]);
    let mp3 = write(dir.path(), "x.mp3", &mp3);
    let o = run(&["analyze", s(&mp3), "-g", s(&geometry)]);
    assert!(stderr(&o).contains("an MP3 file"), "{}", stderr(&o));
}

#[test]
fn a_flac_whose_stream_header_and_frames_disagree_on_the_rate_is_refused() {
    let dir = tempdir();
    let (mut bytes, geometry) = short_flac(dir.path());
    // STREAMINFO's 20-bit rate, bytes 10-12 of its body (after `fLaC` and the block's
    // 4-byte header): 44100 Hz, while every frame says 48000 Hz.
    let rate = 44_100u32;
    let body = 8;
    bytes[body + 10] = (rate >> 12) as u8;
    bytes[body + 11] = (rate >> 4) as u8;
    bytes[body + 12] = (bytes[body + 12] & 0x0F) | ((rate & 0x0F) << 4) as u8;
    let bad = write(dir.path(), "bad.flac", &bytes);
    let o = run(&["analyze", s(&bad), "-g", s(&geometry)]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("the stream header says 44100 Hz but its frames say 48000 Hz"),
        "{}",
        stderr(&o)
    );
}
