//! The accuracy benchmark, in full. Prints the markdown of `docs/accuracy.md`:
//!
//! `cargo bench --bench accuracy > docs/accuracy.md`
//!
//! See `tests/support/bench.rs` for the scenes.

#[path = "../tests/support/mod.rs"]
mod support;

use ssl::evaluate::evaluate;
use ssl::method::Interpolation;
use ssl::plot::{plot, PlotData, PlotFile};
use ssl::sim::scene::SignalKind;
use ssl::track::TrackParams;
use ssl::{Params, Truth};
use std::path::PathBuf;
use std::time::Instant;
use support::bench::{azimuths, Bench, Lab, Pooled, SIGNALS, TABLE_I};

fn name(s: SignalKind) -> &'static str {
    match s {
        SignalKind::Speech => "speech-like",
        SignalKind::Clicks => "clicks",
        SignalKind::White => "noise",
        _ => "other",
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let started = Instant::now();
    let bench = Bench::new()?;
    let az = azimuths(8);
    let lab = Lab::default();
    // Optional: `paper`, or a tolerance and a residual gate in microseconds, to compare
    // with the defaults (docs/field.md).
    let args = support::harness::args();
    std::fs::create_dir_all(std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/plots"))?;
    let params = support::harness::params_from(&args);

    println!("# Accuracy benchmark\n");
    println!("Made by `cargo bench --bench accuracy > docs/accuracy.md` (scenes in `tests/support/bench.rs`).\n");
    println!("Array: the paper's 50 x 40 x 36 cm prism, 48 kHz. Room: 8 x 7 x 3 m, RT60 0.35 s (measured T20 of the simulated room), array centre 0.8 m above the floor. Noise: a pink-noise fan near the ceiling in a corner plus diffuse pink noise 6 dB weaker, together 10 dB below the source (for clicks: below the RMS during a click), and sensor noise at -70 dBFS. Each case is one signal type at 8 horizontal angles (one 0.8 s event each, 0.5 s apart, after 1 s of background). Speech-like: low-pass noise under a 4 Hz syllable envelope with pauses; clicks: 2 ms bursts, 8 per second; noise: white.\n");
    println!("Cells: mean angular error of the detections in frames inside the events (deg) / events detected within 10 deg / frames inside events detected within 10 deg. Default parameters throughout unless a row says otherwise.\n");
    println!("Real recorded speech, 16 and 8 kHz, seven small arrays, a fan next to the array and a reverberation-by-noise grid, each with the defaults, the fixed threshold and the paper's method side by side: [field.md](field.md) (`cargo bench --bench field`).\n");
    println!("Sources rather than frames, on real speech (`ssl analyze` with its tracker, the default): [tracking.md](tracking.md) (`cargo bench --bench tracking`). Meetings of four talkers on the prism and a 6.5 cm tetrahedron: every turn recalled, no false event, one track per talker; two talkers at once, over three draws of the scenes (other noise, the talkers turned): each found in 80-88% of the 0.1 s windows where both sound on the prism, its rows 0.2-0.5 deg off (66-74% on the tetrahedron, 1.9-6.3 deg; 58-74% on a 6-mic circle), each row's direction its track's mean around it; three at once: 67-74% on the prism; a talker turning at 15-60 deg/s, in free field and in the room: 0.2-2.0 deg from its trajectory on the prism and the tetrahedron, one track; background alone: no track. The rows below that say \"tracked\" are the Table I recordings through the tracker.\n");

    // Table I.
    let mut table: Vec<Vec<(PathBuf, Truth)>> = Vec::new();
    println!("## The paper's Table I conditions\n");
    println!("| distance, elevation | paper | ssl (all signals) | speech-like | clicks | noise |");
    println!("|---|---|---|---|---|---|");
    for (row, &(d, el, paper)) in TABLE_I.iter().enumerate() {
        let mut pooled = Pooled::default();
        let mut cells = Vec::new();
        let mut recs = Vec::new();
        for (k, &sig) in SIGNALS.iter().enumerate() {
            let scene = bench.scene(&lab, sig, d, el, &az, 100 + (row * 10 + k) as u64);
            let (wav, truth) = bench.record(&scene, &format!("t1-{row}-{k}"))?;
            let r = bench.score(&wav, &truth, &params)?;
            let mut p = Pooled::default();
            p.add(&r);
            pooled.add(&r);
            cells.push(p.cell());
            recs.push((wav, truth));
        }
        table.push(recs);
        println!(
            "| {d} m, {el:+} deg | {paper} deg | {} | {} |",
            pooled.cell(),
            cells.join(" | ")
        );
    }
    // One picture per condition (the speech-like recording), with the defaults only.
    if args.is_empty() {
        println!("\nThe speech-like recording of each condition, drawn by `ssl plot` with its truth (black lines and crosses: the true directions and active intervals; marks: detections, coloured by score):\n");
        for (row, &(d, el, _)) in TABLE_I.iter().enumerate() {
            let (wav, truth) = &table[row][0];
            let mut records = bench.records(wav, &params)?;
            let name = format!("Table I, {d} m, {el:+} deg, speech-like");
            records.iter_mut().for_each(|r| r.file = name.clone());
            let report = evaluate(truth, &records, truth.rt60_s().map_or(0.0, |t| t / 2.0))?;
            let data = PlotData {
                files: vec![PlotFile {
                    name: name.clone(),
                    detections: records,
                    events: Vec::new(),
                }],
                array: Some("the paper's prism (8 mics)".into()),
                threshold: None,
                geometry: None,
            };
            let svg = plot(&data, None, Some((truth, &report)))?;
            let file = format!("plots/table1-{row}.svg");
            std::fs::write(
                std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                    .join("docs")
                    .join(&file),
                svg,
            )?;
            println!("![{name}]({file})\n");
        }
    }

    // Background alone: a minute of the lab's noise, one event at the very end.
    let mut quiet = bench.scene(&lab, SignalKind::Speech, 3.0, 0.0, &[30.0], 7);
    quiet.duration = 61.5;
    quiet.source[0].active = Some(vec![[60.5, 61.3]]);
    let (noise_wav, noise_truth) = bench.record(&quiet, "background")?;
    let r = bench.score(&noise_wav, &noise_truth, &params)?;
    println!(
        "\nBackground alone (the same fan and diffuse noise, {:.0} s without a source): {} false detections, {:.2} per minute.\n",
        r.background_s,
        r.false_detections,
        r.false_per_minute.unwrap_or(0.0)
    );

    // Near field.
    println!("## Mean angular error against source distance (near field)\n");
    println!("Free field, white noise at elevation 0, sensor noise only (-70 dBFS, 44 dB below the source): the far-field model's own error, as in the paper's simulation.\n");
    println!("| distance | mean error | events detected | frames detected |");
    println!("|---|---|---|---|");
    let free = Lab {
        rt60: None,
        snr_db: 10.0,
        fan: false,
    };
    for (i, d) in [0.25, 0.35, 0.5, 0.75, 1.0, 1.5, 2.0, 3.0]
        .into_iter()
        .enumerate()
    {
        let scene = bench.scene(&free, SignalKind::White, d, 0.0, &az, 300 + i as u64);
        let (wav, truth) = bench.record(&scene, &format!("near-{i}"))?;
        let mut p = Pooled::default();
        p.add(&bench.score(&wav, &truth, &params)?);
        println!(
            "| {d} m | {:.2} deg | {:.0}% | {:.0}% |",
            p.mean_error(),
            100.0 * p.event_rate(),
            100.0 * p.frame_rate()
        );
    }

    // Sweeps at the first Table I position.
    let (d0, el0, _) = TABLE_I[0];
    println!("\n## Reverberation time (3 m, -7 deg; all three signals pooled)\n");
    println!("| RT60 | mean error / events / frames | background false detections per minute |");
    println!("|---|---|---|");
    for (i, rt60) in [0.2, 0.35, 0.5, 0.8].into_iter().enumerate() {
        let lab = Lab {
            rt60: Some(rt60),
            ..Lab::default()
        };
        let mut p = Pooled::default();
        for (k, &sig) in SIGNALS.iter().enumerate() {
            let scene = bench.scene(&lab, sig, d0, el0, &az, 400 + (i * 10 + k) as u64);
            let (wav, truth) = bench.record(&scene, &format!("rt-{i}-{k}"))?;
            p.add(&bench.score(&wav, &truth, &params)?);
        }
        println!("| {rt60} s | {} | {:.1} |", p.cell(), p.false_per_minute());
    }
    println!("\n## Signal-to-noise ratio (3 m, -7 deg, RT60 0.35 s; all three signals pooled)\n");
    println!("| SNR | mean error / events / frames | background false detections per minute |");
    println!("|---|---|---|");
    for (i, snr) in [20.0, 10.0, 5.0, 0.0].into_iter().enumerate() {
        let lab = Lab {
            snr_db: snr,
            ..Lab::default()
        };
        let mut p = Pooled::default();
        for (k, &sig) in SIGNALS.iter().enumerate() {
            let scene = bench.scene(&lab, sig, d0, el0, &az, 500 + (i * 10 + k) as u64);
            let (wav, truth) = bench.record(&scene, &format!("snr-{i}-{k}"))?;
            p.add(&bench.score(&wav, &truth, &params)?);
        }
        println!("| {snr} dB | {} | {:.1} |", p.cell(), p.false_per_minute());
    }

    // Ablations on the Table I recordings.
    println!("\n## What each part of the method buys (Table I recordings re-analysed)\n");
    print!("| variant |");
    for &(d, el, _) in &TABLE_I {
        print!(" {d} m, {el:+} deg |");
    }
    println!(" background false/min |");
    println!("|---|---|---|---|---|---|");
    let variants: Vec<(&str, Params)> = vec![
        ("full method (defaults)", params.clone()),
        ("plain PHAT (no spectral weighting)", {
            let mut p = params.clone();
            p.weighting.on = false;
            p
        }),
        ("single peak per pair (M = 1)", {
            let mut p = params.clone();
            p.peaks.count = 1;
            p
        }),
        ("integer lags (no interpolation)", {
            let mut p = params.clone();
            p.peaks.interpolation = Some(Interpolation::None);
            p
        }),
        ("tolerance 20 us", {
            let mut p = params.clone();
            p.tolerance = ssl::method::Tolerance::Us(20.0);
            p
        }),
        ("tolerance 80 us", {
            let mut p = params.clone();
            p.tolerance = ssl::method::Tolerance::Us(80.0);
            p
        }),
        ("no residual gate", {
            let mut p = params.clone();
            p.room.residual_gate_us = 0.0;
            p
        }),
        ("no background subtraction (--background-s 0)", {
            let mut p = params.clone();
            p.room.background_s = 0.0;
            p
        }),
        (
            "calibrated threshold, no reverberation (--reverb-level 0)",
            {
                let mut p = params.clone();
                p.weighting.reverb_level = Some(0.0);
                p
            },
        ),
        ("fixed threshold, no reverberation (--min-score 0.5)", {
            let mut p = params.clone();
            p.threshold = ssl::method::Threshold::Fixed { per_pair: 0.5 };
            p.weighting.reverb_level = Some(0.0);
            p
        }),
        ("no averaging over frames", {
            let mut p = params.clone();
            p.room.average_frames = 1;
            p
        }),
        (
            "the paper's method (2 samples, no gate, no averaging)",
            ssl::Config::paper().settings().expect("valid").method,
        ),
    ];
    // Each without the tracker, then the defaults through it as `ssl analyze` runs them.
    let mut variants: Vec<(&str, Params, Option<TrackParams>)> =
        variants.into_iter().map(|(l, p)| (l, p, None)).collect();
    variants.push((
        "tracked, as `ssl analyze` (candidates down to 0.4 of the threshold, riders to 0.3)",
        support::for_tracker(params.clone()),
        Some(TrackParams::default()),
    ));
    variants.push((
        "tracked, without candidates (--candidates 1)",
        {
            let mut p = support::for_tracker(params.clone());
            p.talkers.candidates = Some(1.0);
            p
        },
        Some(TrackParams::default()),
    ));
    variants.push((
        "tracked, without the steered response (consistent sets only)",
        {
            let mut p = support::for_tracker(params.clone());
            p.steered = ssl::method::Steering::Off;
            p.talkers.max_sources = 1;
            p
        },
        Some(TrackParams::default()),
    ));
    for (label, v, track) in &variants {
        print!("| {label} |");
        for recs in &table {
            let mut p = Pooled::default();
            for (wav, truth) in recs {
                p.add(&bench.score_tracked(wav, truth, v, track.clone())?);
            }
            print!(" {} |", p.cell());
        }
        let r = bench.score_tracked(&noise_wav, &noise_truth, v, track.clone())?;
        println!(" {:.1} |", r.false_per_minute.unwrap_or(0.0));
    }
    println!(
        "\nPer-signal columns of Table I, in order: {}.",
        SIGNALS.map(name).join(", ")
    );
    eprintln!(
        "benchmark finished in {:.0} s",
        started.elapsed().as_secs_f64()
    );
    Ok(())
}
