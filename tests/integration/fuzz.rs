//! Fuzzing on stable Rust (cargo-fuzz needs nightly): a seeded mutator over the corpus
//! in testdata/fuzz (written by its make_corpus.py; every case of issue 31 a file can
//! carry is there) feeds the WAV reader, the geometry and scene parsers, the result
//! reader and the truth reader, in process, each for a bounded time:
//! `SSL_FUZZ_SECONDS` per target (2 in `cargo test`; CI runs longer), `SSL_FUZZ_SEED`
//! for another sequence of mutants. A panic, a non-finite number in an output, a
//! recording read differently from a file and from a stream, or an input that takes
//! over 5 s fails the test and saves the input under the temporary folder.
//!
//! The differential test runs the binary on every WAV of the corpus, and on mutants,
//! from the file and through a pipe: the same status, rows and messages.

use crate::support;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use ssl::localize::Output;
use ssl::stream::{AudioStream, WavStream};
use ssl::{Config, Geometry, Localizer};
use std::io::Cursor;
use std::panic::AssertUnwindSafe;
use std::path::PathBuf;
use std::time::{Duration, Instant};
use support::*;

fn budget() -> Duration {
    let s = std::env::var("SSL_FUZZ_SECONDS")
        .ok()
        .and_then(|v| v.parse::<f64>().ok())
        .unwrap_or(2.0);
    Duration::from_secs_f64(s.max(0.0))
}

fn seed() -> u64 {
    std::env::var("SSL_FUZZ_SEED")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(31)
}

fn corpus_dir(kind: &str) -> PathBuf {
    testdata("fuzz").join(kind)
}

/// The files of one corpus folder (not its subfolders), by name.
fn corpus(kind: &str) -> Vec<(String, Vec<u8>)> {
    let mut files: Vec<(String, Vec<u8>)> = std::fs::read_dir(corpus_dir(kind))
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.path().is_file())
        .map(|e| {
            (
                e.file_name().to_string_lossy().into_owned(),
                std::fs::read(e.path()).unwrap(),
            )
        })
        .collect();
    files.sort();
    assert!(files.len() >= 5, "the {kind} corpus is in testdata/fuzz");
    files
}

/// Numbers a mutant may put in place of another in a text input.
const EXTREMES: &[&str] = &[
    "1e300",
    "-1e300",
    "1e-300",
    "-0",
    "0",
    "nan",
    "inf",
    "-inf",
    "18446744073709551616",
    "-1",
    "1e9",
    "3.4e38",
    "65536",
    "4294967295",
    "0.0000001",
];

/// Values a mutant may write over four bytes of a binary input.
const WORDS: &[u32] = &[
    0,
    1,
    2,
    0x7FFF_FFFF,
    0x8000_0000,
    0xFFFF_FFFF,
    0xFFFE,
    1024,
    768_000,
    44,
    3,
];

struct Mutator {
    rng: ChaCha8Rng,
}

impl Mutator {
    /// One to four mutations of `input` (in text: numbers, lines and fields; in binary:
    /// bits, bytes, words, ranges), with splices from the rest of the corpus.
    fn mutate(&mut self, input: &[u8], corpus: &[(String, Vec<u8>)], text: bool) -> Vec<u8> {
        let mut out = input.to_vec();
        for _ in 0..self.rng.random_range(1..=4) {
            let len = out.len();
            let at = |rng: &mut ChaCha8Rng| {
                if len == 0 {
                    0
                } else {
                    rng.random_range(0..len)
                }
            };
            match self.rng.random_range(0..if text { 11 } else { 8 }) {
                0 if len > 0 => {
                    let i = at(&mut self.rng);
                    out[i] ^= 1 << self.rng.random_range(0..8);
                }
                1 if len > 0 => {
                    let i = at(&mut self.rng);
                    out[i] = [0u8, 1, 0x7F, 0x80, 0xFF][self.rng.random_range(0..5)];
                }
                2 if len >= 4 => {
                    let i = self.rng.random_range(0..=len - 4);
                    let w = WORDS[self.rng.random_range(0..WORDS.len())];
                    out[i..i + 4].copy_from_slice(&w.to_le_bytes());
                }
                3 => out.truncate(at(&mut self.rng)),
                4 if len > 1 => {
                    let a = at(&mut self.rng);
                    let b = (a + self.rng.random_range(1..=64)).min(len);
                    out.drain(a..b);
                }
                5 if len > 1 => {
                    let a = at(&mut self.rng);
                    let b = (a + self.rng.random_range(1..=256)).min(len);
                    let piece = out[a..b].to_vec();
                    let i = at(&mut self.rng);
                    out.splice(i..i, piece);
                }
                6 => {
                    let n = self.rng.random_range(1..=16);
                    let i = at(&mut self.rng);
                    let bytes: Vec<u8> = (0..n).map(|_| self.rng.random()).collect();
                    out.splice(i..i, bytes);
                }
                7 => {
                    let other = &corpus[self.rng.random_range(0..corpus.len())].1;
                    let from = if other.is_empty() {
                        0
                    } else {
                        self.rng.random_range(0..other.len())
                    };
                    let i = at(&mut self.rng);
                    out.truncate(i);
                    out.extend_from_slice(&other[from..]);
                }
                8 => {
                    // A number replaced by an extreme.
                    let s = String::from_utf8_lossy(&out).into_owned();
                    let starts: Vec<usize> = s
                        .char_indices()
                        .filter(|(i, c)| {
                            c.is_ascii_digit()
                                && (*i == 0 || !s.as_bytes()[i - 1].is_ascii_alphanumeric())
                        })
                        .map(|(i, _)| i)
                        .collect();
                    if let Some(&i) = starts.get(self.rng.random_range(0..starts.len().max(1))) {
                        let end = s[i..]
                            .find(|c: char| !(c.is_ascii_alphanumeric() || c == '.' || c == '-'))
                            .map_or(s.len(), |k| i + k);
                        let with = EXTREMES[self.rng.random_range(0..EXTREMES.len())];
                        out = format!("{}{with}{}", &s[..i], &s[end..]).into_bytes();
                    }
                }
                9 => {
                    // A line duplicated, many times.
                    let s = String::from_utf8_lossy(&out).into_owned();
                    let lines: Vec<&str> = s.lines().collect();
                    if !lines.is_empty() {
                        let k = self.rng.random_range(0..lines.len());
                        let times = [1, 2, 50][self.rng.random_range(0..3)];
                        let mut new: Vec<&str> = lines[..=k].to_vec();
                        new.extend(std::iter::repeat_n(lines[k], times));
                        new.extend(&lines[k + 1..]);
                        out = (new.join("\n") + "\n").into_bytes();
                    }
                }
                10 => {
                    // A line deleted.
                    let s = String::from_utf8_lossy(&out).into_owned();
                    let lines: Vec<&str> = s.lines().collect();
                    if !lines.is_empty() {
                        let k = self.rng.random_range(0..lines.len());
                        let new: Vec<&str> = lines
                            .iter()
                            .enumerate()
                            .filter(|(i, _)| *i != k)
                            .map(|(_, l)| *l)
                            .collect();
                        out = (new.join("\n") + "\n").into_bytes();
                    }
                }
                _ => {}
            }
        }
        out
    }
}

/// Runs `check` on `bytes`: a panic or more than 5 s fails, with the input saved.
fn guarded(target: &str, name: &str, bytes: &[u8], check: &dyn Fn(&[u8])) {
    let start = Instant::now();
    let result = std::panic::catch_unwind(AssertUnwindSafe(|| check(bytes)));
    let slow = start.elapsed() > Duration::from_secs(5);
    if result.is_err() || slow {
        let hash = bytes.iter().fold(0xcbf29ce484222325u64, |h, &b| {
            (h ^ b as u64).wrapping_mul(0x100000001b3)
        });
        let path = std::env::temp_dir().join(format!("ssl-fuzz-{target}-{hash:016x}"));
        std::fs::write(&path, bytes).unwrap();
        panic!(
            "fuzz {target}: {name} {} (the input is saved as {})",
            if slow { "took over 5 s" } else { "panicked" },
            path.display()
        );
    }
}

/// Every seed of the corpus, then mutants until the budget is spent.
fn fuzz(target: &str, kind: &str, text: bool, check: &dyn Fn(&[u8])) {
    let seeds = corpus(kind);
    for (name, bytes) in &seeds {
        guarded(target, name, bytes, check);
    }
    let mut m = Mutator {
        rng: ChaCha8Rng::seed_from_u64(seed() ^ target.len() as u64),
    };
    let deadline = Instant::now() + budget();
    let mut count = 0;
    while Instant::now() < deadline {
        let base = &seeds[m.rng.random_range(0..seeds.len())].1;
        let input = m.mutate(base, &seeds, text);
        guarded(target, &format!("mutant {count}"), &input, check);
        count += 1;
    }
    eprintln!("fuzz {target}: {} seeds and {count} mutants", seeds.len());
}

/// What a recording gives: its records, or the error that ended it.
fn outputs<S: ssl::stream::SampleSource>(
    localizer: &Localizer,
    source: S,
) -> (Vec<Output>, String) {
    let recording = match localizer.from_source(source) {
        Ok(r) => r,
        Err(e) => return (Vec::new(), e.to_string()),
    };
    let mut found = Vec::new();
    let (_, result) = recording.run(|o| {
        found.push(o);
        Ok(())
    });
    for o in &found {
        match o {
            Output::Row(r) => assert!(r.non_finite().is_none(), "{r:?}"),
            Output::Event(e) => assert!(e.non_finite().is_none(), "{e:?}"),
            _ => {}
        }
    }
    (
        found,
        result.err().map(|e| e.to_string()).unwrap_or_default(),
    )
}

#[test]
fn fuzz_the_wav_reader_from_a_file_and_from_a_stream() {
    let pair = Geometry::from_file(&corpus_dir("geometry").join("pair.toml")).unwrap();
    let localizer = Localizer::new(pair, &Config::default()).unwrap();
    fuzz("wav", "wav", false, &|bytes: &[u8]| {
        let open = |size: Option<u64>| {
            WavStream::from_reader("in", Box::new(Cursor::new(bytes.to_vec())), size)
        };
        let (file, stream) = match (open(Some(bytes.len() as u64)), open(None)) {
            (Ok(f), Ok(s)) => (outputs(&localizer, f), outputs(&localizer, s)),
            (Err(f), Err(s)) => {
                assert_eq!(f.to_string(), s.to_string());
                return;
            }
            (f, s) => panic!(
                "a file: {:?}; a stream: {:?}",
                f.err().map(|e| e.to_string()),
                s.err().map(|e| e.to_string())
            ),
        };
        // A header's placeholder length reads a file to its end, and a stream too.
        assert_eq!(file, stream, "the same bytes from a file and from a stream");
    });
}

#[test]
fn fuzz_the_flac_reader_from_a_file_and_from_a_stream() {
    let pair = Geometry::from_file(&corpus_dir("geometry").join("pair.toml")).unwrap();
    let localizer = Localizer::new(pair, &Config::default()).unwrap();
    fuzz("flac", "flac", false, &|bytes: &[u8]| {
        let open = |size: Option<u64>| {
            AudioStream::from_reader("in", Box::new(Cursor::new(bytes.to_vec())), size)
        };
        match (open(Some(bytes.len() as u64)), open(None)) {
            (Ok(f), Ok(s)) => {
                // A live stream hands on each block as it comes: the same records.
                assert_eq!(outputs(&localizer, f), outputs(&localizer, s));
            }
            (Err(f), Err(s)) => assert_eq!(f.to_string(), s.to_string()),
            (f, s) => panic!(
                "a file: {:?}; a stream: {:?}",
                f.err().map(|e| e.to_string()),
                s.err().map(|e| e.to_string())
            ),
        }
    });
}

#[test]
fn fuzz_the_geometry_parser() {
    let options = Config::default();
    let noise: Vec<Vec<f32>> = (0..8)
        .map(|c| {
            let mut rng = ChaCha8Rng::seed_from_u64(c);
            (0..3200).map(|_| rng.random_range(-0.3..0.3)).collect()
        })
        .collect();
    fuzz("geometry", "geometry", true, &|bytes: &[u8]| {
        let Ok(g) = Geometry::from_toml_str(&String::from_utf8_lossy(bytes)) else {
            return;
        };
        let mics = g.mics.len();
        let Ok(localizer) = Localizer::new(g, &options) else {
            return;
        };
        if mics <= noise.len() {
            let channels: Vec<&[f32]> = noise[..mics].iter().map(|c| &c[..]).collect();
            if let Ok(recording) = localizer.from_channels("noise", channels, 16000) {
                let (_, result) = recording.run(|o| {
                    if let Output::Row(r) = &o {
                        assert!(r.non_finite().is_none(), "{r:?}");
                    }
                    Ok(())
                });
                let _ = result;
            }
        }
    });
}

#[test]
fn fuzz_the_scene_parser_and_cheap_scenes() {
    let dir = corpus_dir("scene");
    fuzz("scene", "scene", true, &|bytes: &[u8]| {
        let Ok(scene) = toml::from_str::<ssl::sim::SceneFile>(&String::from_utf8_lossy(bytes))
        else {
            return;
        };
        // Render only what costs little: the scene checks themselves are the target, and a
        // file source only when it names a regular file (not a device that blocks).
        let samples = scene.duration * scene.sample_rate as f64;
        let cheap = samples.is_finite()
            && samples <= 8000.0
            && scene.source.len() <= 4
            && scene.noise.as_ref().is_none_or(|n| n.fan.len() <= 2)
            && scene.room.as_ref().is_none_or(|r| {
                // A compact room: a long narrow one rings long whatever its rt60.
                let d = r.dimensions;
                let (lo, hi) = (d[0].min(d[1]).min(d[2]), d[0].max(d[1]).max(d[2]));
                r.rt60.is_some_and(|t| t <= 0.2)
                    && r.absorption.is_none()
                    && hi <= 8.0
                    && hi <= 4.0 * lo
            })
            && scene.source.iter().all(|s| {
                s.active.as_ref().is_none_or(|a| a.len() <= 200)
                    && s.file.as_ref().is_none_or(|f| dir.join(f).is_file())
            });
        if !cheap {
            return;
        }
        if let Ok(sim) = ssl::sim::simulate(&scene, &dir) {
            assert!(sim.channels.iter().flatten().all(|v| v.is_finite()));
        }
    });
}

#[test]
fn fuzz_the_result_reader_and_the_plot() {
    fuzz("result", "result", true, &|bytes: &[u8]| {
        let Ok(data) = ssl::plot::read_plot_data(bytes) else {
            return;
        };
        for f in &data.files {
            assert!(f.detections.iter().all(|r| r.non_finite().is_none()));
            assert!(f.events.iter().all(|e| e.non_finite().is_none()));
        }
        if data.files.len() <= 4 && data.files.iter().all(|f| f.detections.len() < 5000) {
            let _ = ssl::plot::plot(&data, None, None);
        }
    });
}

#[test]
fn fuzz_the_truth_reader_and_the_scores() {
    let rows = ssl::record::read_detections(&corpus_dir("result").join("rows.csv")).unwrap();
    fuzz("truth", "truth", true, &|bytes: &[u8]| {
        let Ok(truth) = ssl::Truth::from_json(&String::from_utf8_lossy(bytes)) else {
            return;
        };
        if let Ok(r) = ssl::evaluate::evaluate(&truth, &rows, 0.0) {
            let finite = |v: Option<f64>| v.is_none_or(f64::is_finite);
            assert!(
                [
                    r.mean_error_deg,
                    r.median_error_deg,
                    r.frame_detection_rate,
                    r.event_detection_rate,
                    r.false_per_minute,
                    Some(r.background_s),
                ]
                .into_iter()
                .all(finite),
                "{r:?}"
            );
            assert!(r
                .sources
                .iter()
                .all(|s| finite(s.mean_error_deg) && finite(s.median_error_deg)));
        }
    });
}

#[test]
fn the_binary_reads_the_corpus_the_same_from_a_file_and_a_pipe() {
    let geometry = corpus_dir("geometry").join("pair.toml");
    let dir = tempdir();
    let mut inputs: Vec<PathBuf> = corpus("wav")
        .into_iter()
        .map(|(name, _)| corpus_dir("wav").join(name))
        .collect();
    // And mutants of the plain recording.
    let seeds = corpus("wav");
    let mut m = Mutator {
        rng: ChaCha8Rng::seed_from_u64(seed()),
    };
    let plain = std::fs::read(corpus_dir("wav").join("pcm16.wav")).unwrap();
    for k in 0..30 {
        let p = dir.path().join(format!("mutant{k}.wav"));
        std::fs::write(&p, m.mutate(&plain, &seeds, false)).unwrap();
        inputs.push(p);
    }
    for path in &inputs {
        let [file, pipe] = analyze_file_and_pipe(
            path,
            &["-g", s(&geometry), "--format", "ndjson", "--no-track"],
        );
        assert_eq!(file, pipe, "{}: a file and a pipe differ", path.display());
        assert!(
            !file.2.contains("panicked"),
            "{}: {}",
            path.display(),
            file.2
        );
    }
}
