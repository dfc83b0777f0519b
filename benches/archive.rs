//! A lab's archive, end to end. Prints the markdown of docs/archive.md:
//! `cargo bench --bench archive > docs/archive.md` (about 15 minutes on two cores;
//! `-- HOURS` for another size, default 10).
//!
//! The archive: recordings of 80 s (the longest `ssl simulate` renders at 8 channels and 48 kHz), 8 channels at 48 kHz, 16-bit, in nested folders
//! (`siteS/dayDD/recNNNN.wav`), each with its truth beside it, and three files that
//! must fail (a truncated header, a text file named .wav, a 4-channel recording). The
//! recordings are eight distinct scenes rendered by `ssl simulate` (four of reverberant
//! speech taking turns, four of sparse noise bursts in free field), hard-linked under
//! every name: every recording is analysed in full, but the audio is read from the page
//! cache, so the figures are the analysis's, not a disk's (the page states the read
//! rate a disk must give).
//!
//! It runs the whole batch with `-j 1` and `-j CORES`, resumes the finished batch,
//! runs it as shares (`--shard K/N`, one process per core, as GNU parallel or a Slurm
//! array would), checks that every run writes the same results byte for byte, scores
//! the archive with `ssl evaluate --truth ARCHIVE RESULTS`, and projects what a
//! 100-node cluster would do with a year of recordings.

#[path = "../tests/support/mod.rs"]
mod support;

use std::error::Error;
use std::path::{Path, PathBuf};
use support::harness::{binary, cores, run_measured, run_measured_status, seconds_arg};
use support::scenes::{scene_toml, speech_scene_toml};
use support::{geometry_toml, prism, tetrahedron};

/// Seconds of each recording.
const RECORDING_S: f64 = 80.0;
/// Distinct scenes behind the names.
const SCENES: usize = 8;
/// Bytes per second of audio: 8 channels, 48 kHz, 16-bit.
const BYTES_PER_S: f64 = 8.0 * 48_000.0 * 2.0;

fn s(p: &Path) -> &str {
    p.to_str().expect("a UTF-8 path")
}

/// Results by their path under the output folder, with their bytes.
type Results = Vec<(PathBuf, Vec<u8>)>;

/// Every file under `dir` (but `.ssl/` and the summaries) with its bytes, in name order.
fn results(dir: &Path) -> Result<Results, Box<dyn Error>> {
    fn walk(d: &Path, out: &mut Vec<PathBuf>) -> std::io::Result<()> {
        for e in std::fs::read_dir(d)? {
            let p = e?.path();
            let name = p.file_name().unwrap_or_default().to_string_lossy();
            if p.is_dir() {
                if name != ".ssl" {
                    walk(&p, out)?;
                }
            } else if !name.starts_with("batch") {
                out.push(p);
            }
        }
        Ok(())
    }
    let mut paths = Vec::new();
    walk(dir, &mut paths)?;
    paths.sort();
    paths
        .into_iter()
        .map(|p| {
            let bytes = std::fs::read(&p)?;
            Ok((p.strip_prefix(dir).unwrap().to_path_buf(), bytes))
        })
        .collect()
}

fn main() -> Result<(), Box<dyn Error>> {
    let hours = seconds_arg(10.0)?;
    let exe = binary();
    let cores = cores();
    let dir = tempfile::tempdir()?;
    let root = dir.path();
    let path = |name: &str| root.join(name);

    // Eight distinct recordings and their truths.
    let scenes = path("scenes");
    std::fs::create_dir_all(&scenes)?;
    std::fs::write(scenes.join("array.toml"), geometry_toml(&prism(), ""))?;
    support::copy_speech(&scenes)?;
    for i in 0..SCENES {
        let toml = if i % 2 == 0 {
            // 6 dB below the scaling bench's talkers: some seeds' peaks clip at -26 dBFS.
            speech_scene_toml(48_000, RECORDING_S, false, 20 + i as u64)
                .replace("level_db = -26", "level_db = -32")
        } else {
            scene_toml(48_000, RECORDING_S, 20 + i as u64)
        };
        let scene = scenes.join(format!("s{i}.toml"));
        std::fs::write(&scene, toml)?;
        let wav = scenes.join(format!("s{i}.wav"));
        run_measured(exe, &["simulate", s(&scene), "-o", s(&wav)])?;
    }
    // The archive: names hard-linked to them, nested by site and day.
    let archive = path("archive");
    let files = (hours * 3600.0 / RECORDING_S).round().max(1.0) as usize;
    for i in 0..files {
        let folder = archive.join(format!("site{}/day{:02}", i % 3, (i / 3) % 12));
        std::fs::create_dir_all(&folder)?;
        let k = i % SCENES;
        for ext in ["wav", "truth.json"] {
            std::fs::hard_link(
                scenes.join(format!("s{k}.{ext}")),
                folder.join(format!("rec{i:04}.{ext}")),
            )?;
        }
    }
    // Three inputs that must fail.
    let wav = std::fs::read(scenes.join("s0.wav"))?;
    std::fs::write(archive.join("site0/day00/truncated.wav"), &wav[..30])?;
    std::fs::write(
        archive.join("site1/day01/notes.wav"),
        "field notes, not audio\n",
    )?;
    std::fs::write(
        scenes.join("tetra.toml"),
        geometry_toml(&tetrahedron(0.1), ""),
    )?;
    std::fs::write(
        scenes.join("four.toml"),
        scene_toml(48_000, 5.0, 1).replace("array.toml", "tetra.toml"),
    )?;
    run_measured(
        exe,
        &[
            "simulate",
            s(&scenes.join("four.toml")),
            "-o",
            s(&archive.join("site2/day02/four-channels.wav")),
        ],
    )?;
    let audio_s = files as f64 * RECORDING_S;
    let array = scenes.join("array.toml");

    let batch = |out: &Path, extra: &[&str]| {
        let mut args = vec![
            "analyze",
            s(&archive),
            "-g",
            s(&array),
            "--out-dir",
            s(out),
            "-f",
            "ndjson",
            "-q",
        ];
        args.extend_from_slice(extra);
        let (wall, peak, status) = run_measured_status(exe, &args)?;
        // Exit 1: the three failures on purpose.
        if status.code() != Some(1) {
            return Err(format!("ssl analyze {}: exit {status}", args.join(" ")).into());
        }
        Ok::<_, Box<dyn Error>>((wall, peak))
    };
    // Warm the page cache: every recording is read once before timing.
    for i in 0..SCENES {
        std::fs::read(scenes.join(format!("s{i}.wav")))?;
    }
    let one = path("one");
    let (wall1, peak1) = batch(&one, &["-j", "1"])?;
    let reference = results(&one)?;
    if reference.len() != files {
        return Err(format!("{} results for {files} recordings", reference.len()).into());
    }
    let all = path("all");
    let (wall_all, peak_all) = batch(&all, &["-j", &cores.to_string()])?;
    let (resume, _) = batch(&one, &["-j", "1", "--resume"])?;

    // Shares: one process per core, all at once, each with one thread.
    let shards = path("shards");
    let started = std::time::Instant::now();
    let handles: Vec<_> = (1..=cores)
        .map(|k| {
            let (exe, archive, array, shards) = (
                exe.to_path_buf(),
                archive.clone(),
                array.clone(),
                shards.clone(),
            );
            std::thread::spawn(move || {
                let share = format!("{k}/{cores}");
                run_measured_status(
                    &exe,
                    &[
                        "analyze",
                        s(&archive),
                        "-g",
                        s(&array),
                        "--out-dir",
                        s(&shards),
                        "-f",
                        "ndjson",
                        "-q",
                        "-j",
                        "1",
                        "--shard",
                        &share,
                    ],
                )
                .map(|(_, peak, _)| peak)
                .map_err(|e| e.to_string())
            })
        })
        .collect();
    let mut peak_share = 0.0f64;
    for h in handles {
        peak_share = peak_share.max(h.join().map_err(|_| "a share panicked")??);
    }
    let wall_shards = started.elapsed().as_secs_f64();
    for (name, d) in [("-j CORES", &all), ("the shares", &shards)] {
        if results(d)? != reference {
            return Err(format!("{name}: results differ from -j 1").into());
        }
    }

    // Scores of the whole archive against the truths beside the recordings.
    let o = std::process::Command::new(exe)
        .args(["evaluate", "--truth", s(&archive), s(&one), "--json"])
        .output()?;
    if !o.status.success() {
        return Err(String::from_utf8_lossy(&o.stderr).into_owned().into());
    }
    let scores: serde_json::Value = serde_json::from_slice(&o.stdout)?;
    let pooled = &scores["pooled"];

    let per_minute = |wall: f64| audio_s / 3600.0 / (wall / 60.0);
    let gib = audio_s * BYTES_PER_S / f64::powi(1024.0, 3);
    println!("# An archive, end to end\n");
    println!(
        "Made by `cargo bench --bench archive > docs/archive.md` (benches/archive.rs) on {cores} cores. \
         The archive: {files} recordings of {RECORDING_S:.0} s ({:.1} h, {gib:.1} GiB of 8-channel, 48 kHz, 16-bit WAV) \
         in nested folders (`siteS/dayDD/recNNNN.wav`), each with its truth beside it, and 3 inputs that must fail \
         (a truncated header, a text file named .wav, a 4-channel recording for the 8-microphone prism). \
         Behind the names are {SCENES} distinct scenes rendered by `ssl simulate`: half reverberant speech taking \
         turns in a room with a fan, half sparse noise bursts in free field. They are hard-linked under every name: \
         each recording is analysed in full, but read from the page cache, so the figures are the analysis's. \
         The machine is a shared virtual machine: the same command varies by 10-30% from run to run \
         (docs/speed.md), so compare the rows of one run rather than runs.\n",
        audio_s / 3600.0
    );
    println!("| run | wall time | hours of audio per minute | x real time | peak memory |");
    println!("|---|---|---|---|---|");
    let row = |name: &str, wall: f64, peak: f64| {
        println!(
            "| {name} | {wall:.1} s | {:.1} | {:.0}x | {peak:.1} MB |",
            per_minute(wall),
            audio_s / wall
        );
    };
    row("`ssl analyze ARCHIVE --out-dir R -j 1`", wall1, peak1);
    row(
        &format!("`ssl analyze ARCHIVE --out-dir R -j {cores}`"),
        wall_all,
        peak_all,
    );
    row(
        &format!(
            "{cores} shares at once (`--shard K/{cores} -j 1`), as parallel or Slurm run them"
        ),
        wall_shards,
        peak_share,
    );
    println!(
        "| resuming the finished batch (`--resume`: {files} skipped, 3 failed again) | {resume:.2} s | | | |\n"
    );
    println!(
        "All three runs wrote the same {files} results byte for byte, and each reported the 3 inputs that must fail \
         (exit status 1). Sharding scales {:.2}x on {cores} cores against one process with {cores} threads \
         ({:.2}x against one core). Memory is per process and does not grow with the archive: \
         each recording is streamed.\n",
        wall_all / wall_shards,
        wall1 / wall_shards,
    );
    let pct = |v: &serde_json::Value| {
        v.as_f64()
            .map_or("-".into(), |x| format!("{:.1}%", 100.0 * x))
    };
    println!(
        "`ssl evaluate --truth ARCHIVE R` scored {} recordings against their truths: {} detections, \
         mean error {:.2} deg, median {:.2} deg, frames detected {}, events detected {}, {:.1} false detections per minute.\n",
        pooled["recordings"],
        pooled["detections"],
        pooled["mean_error_deg"].as_f64().unwrap_or(f64::NAN),
        pooled["median_error_deg"].as_f64().unwrap_or(f64::NAN),
        pct(&pooled["frame_detection_rate"]),
        pct(&pooled["event_detection_rate"]),
        pooled["false_per_minute"].as_f64().unwrap_or(f64::NAN),
    );

    // A year on 100 nodes, from the shares' rate per core.
    let per_core = audio_s / wall_shards / cores as f64;
    let year_s = 365.0 * 86400.0;
    let nodes = 100.0;
    let node_cores = 32.0;
    let cluster = per_core * nodes * node_cores;
    let tib = year_s * BYTES_PER_S / f64::powi(1024.0, 4);
    println!("## A year of recordings on a 100-node cluster\n");
    println!(
        "One array recording all year (8 channels, 48 kHz, 16-bit) makes {tib:.1} TiB. At the shares' rate, \
         {per_core:.0}x real time per core, a 100-node Slurm cluster of {node_cores:.0}-core nodes \
         (`sbatch --array=1-3200 contrib/slurm/ssl-array.sh`, one share per core) analyses it in \
         {:.1} minutes, if its storage can feed it {:.0} GB/s ({:.0} MB/s per core). On the 2 cores of the \
         machine above, the same year takes {:.1} hours. Storage, not the analysis, is what a cluster runs \
         out of first: a disk array giving 2 GB/s would analyse the year in {:.1} hours, whatever the \
         number of nodes.\n",
        year_s / cluster / 60.0,
        cluster * BYTES_PER_S / 1e9,
        per_core * BYTES_PER_S / 1e6,
        year_s / (per_core * cores as f64) / 3600.0,
        year_s * BYTES_PER_S / 2e9 / 3600.0,
    );
    Ok(())
}
