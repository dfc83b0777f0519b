//! Every sample in the file is analysed, or the user is told: truncated files to their
//! last complete sample frame, sizes that wrapped at 4 GiB, RF64/BW64, pipes and
//! devices with placeholder lengths, odd headers handled or refused, other audio
//! formats named with the command that converts them.

use crate::support;

use ssl::stream::{SampleSource, WavStream};
use std::io::Cursor;
use std::path::Path;
use std::process::Command;
use support::*;

/// Where the samples of a hound-written WAV start.
fn data_start(bytes: &[u8]) -> usize {
    bytes.windows(4).position(|w| w == b"data").unwrap() + 8
}

/// The `fmt ` chunk body of a hound-written WAV.
fn fmt_of(bytes: &[u8]) -> Vec<u8> {
    let at = bytes.windows(4).position(|w| w == b"fmt ").unwrap();
    let len = u32::from_le_bytes(bytes[at + 4..at + 8].try_into().unwrap()) as usize;
    bytes[at + 8..at + 8 + len].to_vec()
}

/// `ssl analyze` as JSON: the detections' frames, the file entry, and the exit code.
fn analyze(input: &str, geo: &Path) -> (Vec<u64>, serde_json::Value, Option<i32>, String) {
    let out = run(&["analyze", input, "-g", s(geo), "-f", "json"]);
    let doc: serde_json::Value = if out.stdout.is_empty() {
        serde_json::Value::Null
    } else {
        serde_json::from_slice(&out.stdout).unwrap()
    };
    let frames = doc["detections"]
        .as_array()
        .map(|d| d.iter().map(|r| r["frame"].as_u64().unwrap()).collect())
        .unwrap_or_default();
    (
        frames,
        doc["files"][0].clone(),
        out.status.code(),
        stderr(&out),
    )
}

#[test]
fn a_truncated_file_is_analysed_to_its_last_complete_sample_frame() {
    let (dir, wav, geo) = recording(1.2);
    let bytes = std::fs::read(&wav).unwrap();
    let header = data_start(&bytes);
    // Cut mid-way through a sample frame, 50,000 frames and a bit in.
    let kept_frames = 50_000;
    let cut = write(
        dir.path(),
        "cut.wav",
        &bytes[..header + kept_frames * 16 + 5],
    );
    let (_, entry, code, err) = analyze(s(&cut), &geo);
    assert_eq!(code, Some(1));
    assert!(
        err.contains("truncated") && err.contains("ends after 50000"),
        "{err}"
    );
    // Every complete analysis frame of those samples was analysed: (50000 - 1024) / 512 + 1.
    assert_eq!(
        entry["frames"],
        (kept_frames as u64 - 1024) / 512 + 1,
        "{entry}"
    );
}

#[test]
fn rf64_and_bw64_are_read_like_wav() {
    let (dir, wav, geo) = recording(1.2);
    let bytes = std::fs::read(&wav).unwrap();
    let (want, whole, code, err) = analyze(s(&wav), &geo);
    assert_eq!(code, Some(0), "{err}");
    let fmt = fmt_of(&bytes);
    let data = &bytes[data_start(&bytes)..];
    for tag in [b"RF64", b"BW64"] {
        // RF64: the 32-bit sizes are 0xFFFFFFFF and the real ones are in a ds64 chunk.
        let mut v = Vec::new();
        v.extend_from_slice(tag);
        v.extend_from_slice(&u32::MAX.to_le_bytes());
        v.extend_from_slice(b"WAVE");
        v.extend_from_slice(b"ds64");
        v.extend_from_slice(&28u32.to_le_bytes());
        v.extend_from_slice(
            &((v.len() + 28 + 8 + fmt.len() + 8 + data.len()) as u64).to_le_bytes(),
        );
        v.extend_from_slice(&(data.len() as u64).to_le_bytes());
        v.extend_from_slice(&((data.len() / 16) as u64).to_le_bytes());
        v.extend_from_slice(&0u32.to_le_bytes());
        v.extend_from_slice(b"fmt ");
        v.extend_from_slice(&(fmt.len() as u32).to_le_bytes());
        v.extend_from_slice(&fmt);
        v.extend_from_slice(b"data");
        v.extend_from_slice(&u32::MAX.to_le_bytes());
        v.extend_from_slice(data);
        let path = write(dir.path(), "big.wav", &v);
        let (got, entry, code, err) = analyze(s(&path), &geo);
        assert_eq!(code, Some(0), "{err}");
        assert_eq!(got, want, "{}", String::from_utf8_lossy(tag));
        assert_eq!(entry["frames"], whole["frames"], "{entry}");
    }
}

#[test]
fn a_size_that_wrapped_past_4_gib_is_read_to_the_end_of_a_regular_file() {
    // The header says 1,000 bytes of data, but the file holds 4 GiB + 1,000 bytes more
    // (the 32-bit size wrapped). WavStream is told the file's size, as for a real file;
    // the reader gives 2,000 sample frames and then ends, as if the file were cut there.
    let (_dir, wav, _) = recording(1.2);
    let bytes = std::fs::read(&wav).unwrap();
    let fmt = fmt_of(&bytes);
    let data = &bytes[data_start(&bytes)..][..32_000];
    let mut v = raw_wav(b"RIFF", &fmt, data, Some(1_000));
    let header = v.len() - data.len();
    v.truncate(header + data.len());
    let size = (header + 1_000) as u64 + (1u64 << 32);
    let mut stream =
        WavStream::from_reader("big.wav", Box::new(Cursor::new(v)), Some(size)).unwrap();
    assert_eq!(stream.format.frames, Some((size - header as u64) / 16));
    assert!(
        stream.notes()[0].contains("wrapped past 4 GiB"),
        "{:?}",
        stream.notes()
    );
    let mut out = vec![0.0f32; 8 * 4096];
    let mut read = 0;
    let error = loop {
        match stream.read(&mut out) {
            Ok(0) => break None,
            Ok(n) => read += n,
            Err(e) => break Some(e),
        }
    };
    assert_eq!(
        read, 2_000,
        "every frame past the header's 1,000 bytes was read"
    );
    assert!(error.unwrap().to_string().contains("truncated"));
}

#[test]
fn a_named_pipe_or_dev_stdin_with_placeholder_lengths_is_read_like_dash() {
    let (dir, wav, geo) = recording(1.2);
    let (want, whole, _, _) = analyze(s(&wav), &geo);
    // The header's sizes set to the placeholder 0xFFFFFFFF, as sox writes into a pipe.
    let mut bytes = std::fs::read(&wav).unwrap();
    bytes[4..8].copy_from_slice(&u32::MAX.to_le_bytes());
    let at = bytes.windows(4).position(|w| w == b"data").unwrap();
    bytes[at + 4..at + 8].copy_from_slice(&u32::MAX.to_le_bytes());
    let fifo = dir.path().join("pipe.wav");
    assert!(Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .unwrap()
        .success());
    let feed = bytes.clone();
    let fifo_path = fifo.clone();
    let writer = std::thread::spawn(move || std::fs::write(&fifo_path, feed).unwrap());
    let (got, entry, code, err) = analyze(s(&fifo), &geo);
    writer.join().unwrap();
    assert_eq!(code, Some(0), "{err}");
    assert_eq!(got, want);
    assert_eq!(entry["frames"], whole["frames"]);
    // /dev/stdin, a device.
    let out = run_with_stdin(
        &["analyze", "/dev/stdin", "-g", s(&geo), "-f", "json"],
        bytes,
    );
    assert!(out.status.success(), "{}", stderr(&out));
    let doc: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(doc["files"][0]["frames"], whole["frames"]);
}

#[test]
fn odd_headers_are_handled_or_refused_never_decoded_as_garbage() {
    let (dir, wav, geo) = recording(1.2);
    let bytes = std::fs::read(&wav).unwrap();
    let (want, _, _, _) = analyze(s(&wav), &geo);
    let data = &bytes[data_start(&bytes)..];
    // A second data chunk after the first: refused, after the first is analysed.
    let mut two = raw_wav(b"RIFF", &fmt_body(1, 8, 48000, 16), data, None);
    two.extend_from_slice(b"data");
    two.extend_from_slice(&16u32.to_le_bytes());
    two.extend_from_slice(&[0u8; 16]);
    let path = write(dir.path(), "two.wav", &two);
    let (got, _, code, err) = analyze(s(&path), &geo);
    assert_eq!(code, Some(1));
    assert!(err.contains("second data chunk"), "{err}");
    assert_eq!(got, want, "the first data chunk is analysed");
    // A block size that disagrees with the bits per sample: refused.
    let mut odd = fmt_body(1, 8, 48000, 16);
    odd[12..14].copy_from_slice(&24u16.to_le_bytes());
    let path = write(
        dir.path(),
        "odd.wav",
        raw_wav(b"RIFF", &odd, &[0u8; 48], None),
    );
    let (_, _, code, err) = analyze(s(&path), &geo);
    assert_eq!(code, Some(1));
    assert!(err.contains("block size 24 disagrees"), "{err}");
    // 12 valid bits in 16-bit containers (WAVE_FORMAT_EXTENSIBLE), left-justified: read
    // by the container, so the same samples with their low 4 bits cleared localize alike.
    let masked: Vec<u8> = data
        .chunks_exact(2)
        .flat_map(|b| (i16::from_le_bytes([b[0], b[1]]) & !0xF).to_le_bytes())
        .collect();
    let mut ext = fmt_body(0xFFFE, 8, 48000, 16);
    ext.extend_from_slice(&22u16.to_le_bytes());
    ext.extend_from_slice(&12u16.to_le_bytes());
    ext.extend_from_slice(&0u32.to_le_bytes());
    ext.extend_from_slice(&[
        1, 0, 0, 0, 0, 0, 0x10, 0, 0x80, 0, 0, 0xAA, 0, 0x38, 0x9B, 0x71,
    ]);
    let path = write(
        dir.path(),
        "twelve.wav",
        raw_wav(b"RIFF", &ext, &masked, None),
    );
    let (got, entry, code, err) = analyze(s(&path), &geo);
    assert_eq!(code, Some(0), "{err}");
    assert_eq!(entry["format"], "8 ch, 48000 Hz, 12-bit PCM");
    assert!(
        got.len() * 10 > want.len() * 9,
        "{} of {}",
        got.len(),
        want.len()
    );
    // 65,535 channels in a header of a few bytes: refused before anything is allocated.
    let path = write(
        dir.path(),
        "wide.wav",
        raw_wav(b"RIFF", &fmt_body(1, 65535, 48000, 16), &[0u8; 64], None),
    );
    let (_, _, code, err) = analyze(s(&path), &geo);
    assert_eq!(code, Some(1));
    assert!(err.contains("65535 channels; at most 1024"), "{err}");
}

#[test]
fn other_audio_formats_are_named_with_a_conversion() {
    let (dir, _, geo) = recording(1.2);
    let cases: [(&str, &[u8], &str); 6] = [
        (
            "w64",
            b"riff\x2e\x91\xcf\x11\xa5\xd6\x28\xdb\x04\xc1\x00\x00",
            "Wave64",
        ),
        ("mp3", b"ID3\x04\x00\x00\x00\x00\x00\x00\x00\x00", "MP3"),
        (
            "mp3",
            b"\xff\xfb\x90\x64\x00\x00\x00\x00\x00\x00\x00\x00",
            "MP3",
        ),
        ("aiff", b"FORM\x00\x00\x10\x00AIFFCOMM", "AIFF"),
        ("caf", b"caff\x00\x01\x00\x00desc", "CAF"),
        ("m4a", b"\x00\x00\x00\x20ftypM4A \x00\x00", "MP4"),
    ];
    for (ext, start, what) in cases {
        let mut bytes = start.to_vec();
        bytes.resize(64, 0);
        let path = write(dir.path(), &format!("in.{ext}"), bytes);
        let (_, _, code, err) = analyze(s(&path), &geo);
        assert_eq!(code, Some(1));
        assert!(
            err.contains(what) && err.contains(&format!("sox in.{ext} out.wav")),
            "{err}"
        );
    }
}
