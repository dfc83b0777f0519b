//! The block decoder against hound's reader, on files the simulator writes.

use super::*;
use crate::sim::{write_wav, Encoding};

/// Our block decoder against hound's per-sample reader, for every encoding hound
/// writes, over the full range including the extremes.
#[test]
fn decoder_matches_hound_for_every_encoding() {
    let dir = tempfile::tempdir().unwrap();
    let n = 5000;
    let ch: Vec<Vec<f32>> = (0..3)
        .map(|c| {
            (0..n)
                .map(|i| {
                    let x = ((i * 7919 + c * 104_729) % 20001) as f32 / 10000.0 - 1.0;
                    if i == 0 {
                        -1.0
                    } else if i == 1 {
                        0.999_99
                    } else {
                        x
                    }
                })
                .collect()
        })
        .collect();
    for (enc, bits) in [
        (Encoding::Int8, 8),
        (Encoding::Int16, 16),
        (Encoding::Int24, 24),
        (Encoding::Int32, 32),
        (Encoding::Float32, 32),
    ] {
        let path = dir.path().join(format!("{enc:?}.wav"));
        write_wav(&path, &ch, 16000, enc).unwrap();
        let mut hound_reader = hound::WavReader::open(&path).unwrap();
        let reference: Vec<f32> = if enc == Encoding::Float32 {
            hound_reader.samples::<f32>().map(|s| s.unwrap()).collect()
        } else {
            let scale = (1i64 << (bits - 1)) as f32;
            hound_reader
                .samples::<i32>()
                .map(|s| s.unwrap() as f32 / scale)
                .collect()
        };
        let mut ours = WavStream::open(path.to_str().unwrap()).unwrap();
        assert_eq!(ours.format.frames, Some(n as u64));
        let mut got = vec![0.0f32; 3 * n];
        // Odd block sizes exercise the block boundaries.
        let mut filled = 0;
        while filled < 3 * n {
            let k = ours
                .read(&mut got[filled..(filled + 3 * 333).min(3 * n)])
                .unwrap();
            assert!(k > 0);
            filled += 3 * k;
        }
        assert_eq!(ours.read(&mut got[..3]).unwrap(), 0);
        for (i, (a, b)) in got.iter().zip(&reference).enumerate() {
            assert!(
                (a - b).abs() <= 1e-7 * b.abs().max(1.0),
                "{enc:?} sample {i}: {a} vs {b}"
            );
        }
    }
}
