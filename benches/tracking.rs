//! Sources, not frames: tracks and events on real speech, as `ssl analyze` makes them by
//! default (the detections through the tracker), scored by `ssl evaluate`'s tracking
//! report. Prints the markdown of docs/tracking.md:
//! `cargo bench --bench tracking > docs/tracking.md` (about three minutes).
//!
//! - Meetings: four talkers around the array (the three CMU ARCTIC clips of
//!   testdata/speech, each talker always saying the same one), twelve turns in round
//!   robin, each starting 0.3 s before the previous one ends (an overlap) or 0.2-0.6 s
//!   after it, in the paper's room (8 x 7 x 3 m) at RT60 0.35 and 0.5 s with its fan and
//!   diffuse noise 10 dB below the talkers.
//! - Two talkers at once, 30, 60 and 90 deg apart, for 2.8 s.
//! - A talker turning at 15, 30 and 60 deg/s, in free field and in the room.
//! - A minute of the room's noise alone, with the fan in its corner or 0.9 m from the
//!   array (RT60 0.2 s).
//!
//! `cargo bench --bench tracking -- seed=N rot=DEG` draws the scenes again with their
//! seeds offset by N and every talker turned by DEG about the array, to see how much
//! the figures owe to one draw; the method's and the tracker's arguments of
//! `support::harness` apply too (`cand=X`, `weak=N`, ...).

#[path = "../tests/support/mod.rs"]
mod support;

use nalgebra::Vector3;
use ssl::evaluate::{evaluate, TrackReport};
use ssl::sim::scene::{RoomSpec, SceneFile, SignalKind, SourceSpec};
use ssl::Geometry;
use std::error::Error;
use support::bench::{azimuth_error, speech_room};
use support::harness::analyse_scene;
use support::moving::{moving_talker, window_share};
use support::scenes::{meeting_turns, MEETING_AZIMUTHS};

use support::{circle, SPEECH as CLIPS};

struct Array {
    name: &'static str,
    mics: Vec<Vector3<f64>>,
    distance: f64,
    elevation: f64,
    rates: &'static [u32],
}

fn arrays() -> Vec<Array> {
    vec![
        Array {
            name: "prism (8 mics)",
            mics: support::prism(),
            distance: 2.0,
            elevation: -7.0,
            rates: &[48000, 16000],
        },
        Array {
            name: "circle (6 mics, r 4.63 cm)",
            mics: circle(6, 0.0463),
            distance: 1.5,
            elevation: 15.0,
            rates: &[16000],
        },
        Array {
            name: "tetrahedron (6.5 cm)",
            mics: support::tetrahedron(0.065),
            distance: 1.5,
            elevation: 15.0,
            rates: &[16000],
        },
    ]
}

/// A scene's report, its tracking part and its rows' mean azimuth error (deg).
type Scored = (ssl::evaluate::Report, TrackReport, Option<f64>);

/// Degrees every talker is turned by about the array (`rot=DEG`; 0 by default).
static ROTATION: std::sync::OnceLock<f64> = std::sync::OnceLock::new();

/// A talker: azimuth, and the intervals it speaks in.
fn talker(array: &Array, azimuth: f64, clip: usize, active: Vec<[f64; 2]>) -> SourceSpec {
    SourceSpec {
        position: None,
        azimuth_deg: Some(azimuth + ROTATION.get().copied().unwrap_or(0.0)),
        elevation_deg: Some(array.elevation),
        distance: Some(array.distance),
        signal: SignalKind::File,
        level_db: -26.0,
        active: Some(active),
        rate: None,
        frequency: None,
        file: Some(CLIPS[clip].0.into()),
        turn_deg_per_s: None,
    }
}

/// Four talkers taking twelve turns.
fn meeting(array: &Array, rate: u32, rt60: f64, seed: u64) -> SceneFile {
    let (active, end) = meeting_turns();
    let mut scene = speech_room(rate, end + 1.5, seed, rt60, false);
    scene.source = (0..MEETING_AZIMUTHS.len())
        .map(|i| {
            talker(
                array,
                MEETING_AZIMUTHS[i],
                i % CLIPS.len(),
                active[i].clone(),
            )
        })
        .collect();
    scene
}

/// The meeting in a small office instead: 5 x 4 x 2.7 m at RT60 0.5 s (its critical
/// distance about 0.6 m), the array 0.75 m up off the room's centre and turned 10 deg,
/// the fan in a corner near the ceiling, the talkers 1.5 m away.
fn office_meeting(array: &Array, rate: u32, seed: u64) -> SceneFile {
    let mut scene = meeting(array, rate, 0.5, seed);
    scene.room = Some(RoomSpec {
        dimensions: [5.0, 4.0, 2.7],
        rt60: Some(0.5),
        absorption: None,
    });
    scene.array.position = [2.3, 1.9, 0.75];
    scene.array.yaw_deg = 10.0;
    if let Some(noise) = scene.noise.as_mut() {
        noise.fan[0].position = [0.3, 0.4, 2.5];
    }
    for source in &mut scene.source {
        source.distance = Some(OFFICE_DISTANCE_M);
    }
    scene
}

/// How far the talkers of [`office_meeting`] are from the array (m).
const OFFICE_DISTANCE_M: f64 = 1.5;

/// Two talkers at once, `separation` degrees apart, for 2.8 s.
fn together(array: &Array, rate: u32, separation: f64, seed: u64) -> SceneFile {
    let mut scene = speech_room(rate, 5.0, seed, 0.35, false);
    scene.source = vec![
        talker(array, 20.0, 0, vec![[1.0, 3.8]]),
        talker(array, 20.0 - separation, 1, vec![[1.0, 3.8]]),
    ];
    scene
}

/// Three talkers at once, `separation` degrees apart, each saying its own sentence,
/// for 2.8 s.
fn three(array: &Array, rate: u32, separation: f64, seed: u64) -> SceneFile {
    let mut scene = together(array, rate, separation, seed);
    scene
        .source
        .push(talker(array, 20.0 + separation, 2, vec![[1.0, 3.8]]));
    scene
}

/// The first talker turning at `deg_per_s` from azimuth -60 deg in the paper's room
/// (RT60 0.35 s, fan and diffuse noise 10 dB below), from 1 s on.
fn turning(array: &Array, rate: u32, deg_per_s: f64, seed: u64) -> SceneFile {
    let mut scene = speech_room(rate, 1.0 + CLIPS[0].1 + 1.0, seed, 0.35, false);
    let mut source = talker(array, -60.0, 0, vec![[1.0, 1.0 + CLIPS[0].1]]);
    source.turn_deg_per_s = Some(deg_per_s);
    scene.source = vec![source];
    scene
}

/// A minute of noise alone (one talker at the very end, which the noise level needs).
fn background(array: &Array, rate: u32, near_fan: bool, seed: u64) -> SceneFile {
    let rt60 = if near_fan { 0.2 } else { 0.35 };
    let mut scene = speech_room(rate, 64.5, seed, rt60, near_fan);
    scene.source = vec![talker(array, 20.0, 1, vec![[61.0, 63.8]])];
    scene
}

fn pct(a: usize, b: usize) -> String {
    if b == 0 {
        "-".into()
    } else {
        format!("{:.0}%", 100.0 * a as f64 / b as f64)
    }
}

fn opt(v: Option<f64>, d: usize) -> String {
    v.map_or("-".into(), |x| format!("{x:.d$}"))
}

/// A meeting's cells from events recalled to the rows' azimuth error.
fn meeting_cells(report: &ssl::evaluate::Report, t: &TrackReport, azimuth: Option<f64>) -> String {
    format!(
        "{} ({}/{}) | {:.1} | {} | {} | {} / {} deg | {} deg",
        pct(t.events_recalled, t.true_events),
        t.events_recalled,
        t.true_events,
        t.false_events_per_minute,
        opt(t.tracks_per_source, 2),
        opt(t.min_purity.map(|p| 100.0 * p), 0) + "%",
        opt(report.mean_error_deg, 1),
        opt(t.event_error_deg, 1),
        opt(azimuth, 1),
    )
}

fn main() -> Result<(), Box<dyn Error>> {
    let started = std::time::Instant::now();
    let dir = tempfile::tempdir()?;
    support::copy_speech(dir.path())?;
    let args = support::harness::args();
    let params = support::harness::params_from(&args);
    let track = Some(support::harness::track_from(&args));
    // `seed=N` draws every scene again with its seed offset by N (the noise and the
    // rooms' fine details change; the talkers and their sentences do not).
    let offset: u64 = args
        .iter()
        .find_map(|a| a.strip_prefix("seed="))
        .map_or(0, |v| v.parse().expect("seed takes a number"));
    // `rot=DEG` turns every talker by DEG about the array (other reflections).
    let rotation: f64 = args
        .iter()
        .find_map(|a| a.strip_prefix("rot="))
        .map_or(0.0, |v| v.parse().expect("rot takes degrees"));
    ROTATION.set(rotation).expect("set once");
    // `only=meetings|atonce|moving|turning|background` runs those scenes alone (the other
    // tables stay empty): a quicker look at what a change does there.
    let only = args.iter().find_map(|a| a.strip_prefix("only="));
    let runs = |section: &str| only.is_none_or(|o| o == section);
    let mut meetings = String::new();
    let mut office = String::new();
    let mut at_once = String::new();
    let mut quiet = String::new();
    let mut moving = String::new();
    let mut turning_rows = String::new();
    for (k, array) in arrays().iter().enumerate() {
        std::fs::write(
            dir.path().join("array.toml"),
            support::geometry_toml(&array.mics, ""),
        )?;
        let geometry = Geometry::from_file(&dir.path().join("array.toml"))?;
        // The report, its tracking part and the rows' mean azimuth error.
        let run = |scene: &SceneFile| -> Result<Scored, Box<dyn Error>> {
            let (records, truth) =
                analyse_scene(dir.path(), scene, &geometry, &params, track.clone())?;
            let report = evaluate(&truth, &records, truth.rt60_s().map_or(0.0, |t| t / 2.0))?;
            let tracking = report.tracking.clone().unwrap_or_else(|| empty(&report));
            let azimuth = azimuth_error(&records, &truth, None);
            Ok((report, tracking, azimuth))
        };
        for &rate in array.rates {
            for (j, rt60) in [0.35, 0.5]
                .into_iter()
                .enumerate()
                .filter(|_| runs("meetings"))
            {
                let seed = offset + 100 + 10 * k as u64 + j as u64 + rate as u64 / 16000;
                let (report, t, azimuth) = run(&meeting(array, rate, rt60, seed))?;
                meetings += &format!(
                    "| {} | {} kHz | {rt60} s | {} | {} / {} s |\n",
                    array.name,
                    rate / 1000,
                    meeting_cells(&report, &t, azimuth),
                    opt(t.onset_error_s, 2),
                    opt(t.offset_error_s, 2),
                );
            }
            if runs("meetings") {
                let seed = offset + 600 + 10 * k as u64 + rate as u64 / 16000;
                let (report, t, azimuth) = run(&office_meeting(array, rate, seed))?;
                office += &format!(
                    "| {} | {} kHz | {} |\n",
                    array.name,
                    rate / 1000,
                    meeting_cells(&report, &t, azimuth),
                );
            }
            let scenes = [(30.0, 2), (60.0, 2), (90.0, 2), (60.0, 3)];
            for (j, (separation, talkers)) in
                scenes.into_iter().enumerate().filter(|_| runs("atonce"))
            {
                let seed = offset + 200 + 10 * k as u64 + j as u64 + rate as u64 / 16000;
                let scene = if talkers == 2 {
                    together(array, rate, separation, seed)
                } else {
                    three(array, rate, separation, seed)
                };
                let (report, t, azimuth) = run(&scene)?;
                let each: Vec<String> = t.sources.iter().map(|s| format!("{}", s.rows)).collect();
                at_once += &format!(
                    "| {} | {} kHz | {talkers}, {separation} deg apart | {} | {} | {} | {} deg | {} deg |\n",
                    array.name,
                    rate / 1000,
                    pct(t.overlap_detected, t.overlap_pairs),
                    each.join(" / "),
                    t.tracks,
                    opt(report.mean_error_deg, 1),
                    opt(azimuth, 1),
                );
            }
            for (j, speed) in [15.0, 30.0, 60.0]
                .into_iter()
                .enumerate()
                .filter(|_| runs("moving"))
            {
                let seed = offset + 400 + 10 * k as u64 + j as u64 + rate as u64 / 16000;
                let m = moving_talker(&geometry, rate, array.elevation, speed, seed)?;
                moving += &format!(
                    "| {} | {} kHz | {speed} deg/s | {} | {} | {} deg | {:.0}% |\n",
                    array.name,
                    rate / 1000,
                    m.rows,
                    m.tracks,
                    opt(m.mean_error_deg, 1),
                    100.0 * m.windows,
                );
            }
            for (j, speed) in [15.0, 30.0, 60.0]
                .into_iter()
                .enumerate()
                .filter(|_| runs("turning"))
            {
                let seed = offset + 500 + 10 * k as u64 + j as u64 + rate as u64 / 16000;
                let scene = turning(array, rate, speed, seed);
                let (records, truth) =
                    analyse_scene(dir.path(), &scene, &geometry, &params, track.clone())?;
                let report = evaluate(&truth, &records, 0.175)?;
                let tracks = report.tracking.as_ref().map_or(0, |t| t.tracks);
                let times = records.iter().map(|r| r.time_s);
                let windows = window_share(times, 1.0, 1.0 + CLIPS[0].1);
                turning_rows += &format!(
                    "| {} | {} kHz | {speed} deg/s | {} | {} | {} deg | {:.0}% |\n",
                    array.name,
                    rate / 1000,
                    records.len(),
                    tracks,
                    opt(report.mean_error_deg, 1),
                    100.0 * windows,
                );
            }
            if !runs("background") {
                continue;
            }
            let mut cells = Vec::new();
            for (j, near) in [false, true].into_iter().enumerate() {
                let seed = offset + 300 + 10 * k as u64 + j as u64 + rate as u64 / 16000;
                let (_, t, _) = run(&background(array, rate, near, seed))?;
                // The talker at the end is one true event; anything else is false.
                cells.push(format!(
                    "{} tracks, {} false events",
                    t.tracks.saturating_sub(t.events_recalled),
                    t.false_events
                ));
            }
            quiet += &format!(
                "| {} | {} kHz | {} | {} |\n",
                array.name,
                rate / 1000,
                cells[0],
                cells[1]
            );
        }
    }
    println!("# Tracking benchmark\n");
    println!("Made by `cargo bench --bench tracking > docs/tracking.md` (scenes in `benches/tracking.rs`): real speech (the CMU ARCTIC sentences of `testdata/speech/`) in the paper's room (8 x 7 x 3 m, a fan near the ceiling and diffuse noise 10 dB below the talkers), analysed with the defaults and tracked as `ssl analyze` does, scored by `ssl evaluate` (`src/evaluate/tracks.rs` defines each figure). Talkers are 2 m from the prism at elevation -7 deg, 1.5 m from the small arrays at +15 deg.\n");
    println!("## Meetings\n");
    println!("Four talkers at azimuths -135, -40, 50 and 140 deg take twelve turns in round robin (each 2.8, 3.5 or 3.9 s: the first and the fourth say the same sentence), each turn starting 0.3 s before the previous one ends or 0.2-0.6 s after it. Cells: true events (turns) recalled by an event within 10 deg / false events per minute / tracks per talker / the lowest purity of a talker's dominant track / mean error of the rows / of the events / mean azimuth error of the rows (against the active talker nearest in azimuth: what a planar array measures well; its elevation is what the reflections from the floor and ceiling bias, see docs/field.md) / mean absolute onset / offset error of the events.\n");
    println!("| array | rate | RT60 | events recalled | false events per min | tracks per talker | lowest purity | mean error rows / events | azimuth error | onset / offset |");
    println!("|---|---|---|---|---|---|---|---|---|---|");
    print!("{meetings}");
    println!("\nThe same meetings in a small office: 5 x 4 x 2.7 m at RT60 0.5 s (its critical distance about 0.6 m), the array 0.75 m up near the room's centre and turned 10 deg, the fan in a corner near the ceiling, every talker {OFFICE_DISTANCE_M} m away (`office_meeting`). Cells as above.\n");
    println!("| array | rate | events recalled | false events per min | tracks per talker | lowest purity | mean error rows / events | azimuth error |");
    println!("|---|---|---|---|---|---|---|---|");
    print!("{office}");
    println!("\n## Two and three talkers at once\n");
    println!("Both talk for 2.8 s, at azimuth 20 deg and 30, 60 or 90 deg to its right, RT60 0.35 s; in the last row of each array a third talker, 60 deg to the left of the first, says a third sentence at the same time. A frame gives its dominant talker and, when it passes the threshold on its own, a second (from the correlations averaged over frames, or from the frame's own: `src/method/beyond/frame_sources.rs`; on the prism also from what is left of a longer average once the first talker's learned pattern is removed: `src/method/beyond/patterns.rs`); the tracker's candidates (down to 0.4 of the threshold) add the frames each talker dominates less; on the small arrays, beside a frame's detection, riders from the directions of single frequency bins add the other talker's (`src/method/beyond/votes.rs`). Cells: the share of (0.1 s window, talker) pairs with a row of that talker in the window / rows of each talker / tracks / mean error of the rows / their mean azimuth error (as in the meetings).\n");
    println!(
        "| array | rate | talkers | windows detected | rows per talker | tracks | mean error | azimuth error |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    print!("{at_once}");
    println!("\n## A talker moving\n");
    println!("The first sentence (3.9 s), its azimuth turning from -60 deg at 15, 30 or 60 deg/s, in free field with sensor noise 20 dB below, rendered sample by sample (`ssl::sim::freefield::Place::Moving`), analysed with the defaults whatever the benchmark's arguments. Cells: rows / tracks / mean angle of the rows to the talker's direction at their time / the share of the sentence's 0.1 s windows with a row.\n");
    println!("| array | rate | speed | rows | tracks | mean error | windows detected |");
    println!("|---|---|---|---|---|---|---|");
    print!("{moving}");
    println!("\nThe same sentence turning in the paper's room (RT60 0.35 s, its fan and diffuse noise 10 dB below; `turn_deg_per_s` in the scene), scored by `ssl evaluate` against the trajectory.\n");
    println!("| array | rate | speed | rows | tracks | mean error | windows detected |");
    println!("|---|---|---|---|---|---|---|");
    print!("{turning_rows}");
    println!("\n## Background alone\n");
    println!("A minute of the room's noise, then one sentence (which the noise level is set against): tracks other than the sentence's, and false events. The near fan is 0.9 m from the array in a drier room (RT60 0.2 s).\n");
    println!("| array | rate | fan in the corner | fan 0.9 m away |");
    println!("|---|---|---|---|");
    print!("{quiet}");
    eprintln!(
        "tracking benchmark finished in {:.0} s",
        started.elapsed().as_secs_f64()
    );
    Ok(())
}

/// The tracking report of a result without tracks (no detection at all).
fn empty(report: &ssl::evaluate::Report) -> TrackReport {
    TrackReport {
        sources: Vec::new(),
        tracks: 0,
        tracks_per_source: None,
        min_purity: None,
        true_events: report.sources.iter().map(|s| s.events).sum(),
        events_recalled: 0,
        events_from: "rows",
        events: 0,
        false_events: 0,
        false_events_per_minute: 0.0,
        event_error_deg: None,
        onset_error_s: None,
        offset_error_s: None,
        event_coverage: None,
        overlap_pairs: 0,
        overlap_detected: 0,
    }
}
