//! What a scene may ask for: every number checked before anything is rendered, and the
//! rendering's cost estimated up front, so that no scene can make `ssl simulate` panic,
//! hang for hours or run out of memory. Each refusal names the limit.

use super::room::image_count;
use super::scene::{SceneFile, SignalKind};
use super::SceneError;
use crate::text::{shown3, BriefNumber};

/// The longest scene (seconds).
pub(crate) const MAX_DURATION_S: f64 = 3600.0;
/// Samples of all channels together a scene may hold: 87 s of 8 channels at 48 kHz, 17
/// minutes of 2 channels at 16 kHz. The simulator keeps the whole recording, and the
/// FFT convolutions of whole sources, in memory: up to about 80 bytes per sample and
/// channel (2.7 GB measured for a reverberant scene with a fan and diffuse noise at this
/// limit).
pub(crate) const MAX_CHANNEL_SAMPLES: f64 = (1u64 << 25) as f64;
/// Sources in one scene.
pub const MAX_SOURCES: usize = 1000;
/// The farthest a source or fan may be from the array (metres).
pub const MAX_DISTANCE_M: f64 = 1000.0;
/// The largest room dimension (metres).
pub(crate) const MAX_ROOM_M: f64 = 1000.0;
/// Image sources one scene may render, over all responses (about a minute of work).
pub(crate) const MAX_IMAGES: f64 = 2e9;

/// Samples one scene may convolve, over all microphones: every active interval of every
/// source and every fan, each with the length of its responses added (a convolution
/// costs its input plus its response). About a minute of work on one core (100 ns a
/// sample measured, with 1000 and 3000 free-field fans); shared with [`MAX_IMAGES`].
pub(crate) const MAX_CONVOLVED_SAMPLES: f64 = 6e8;

/// The fastest a moving source turns (degrees per second, either way): one turn a
/// second. Its responses are rendered every degree, so a second of it costs 360 of them.
pub(crate) const MAX_TURN_DEG_S: f64 = 360.0;
/// The speed of sound accepted (m/s): the geometry's range, one for every input.
pub(crate) const SPEED_RANGE: (f64, f64) = crate::geometry::SPEED_OF_SOUND_RANGE;

macro_rules! require {
    ($ok:expr, $($arg:tt)*) => {
        let ok: bool = $ok;
        if !ok {
            fail!(SceneError::Invalid, $($arg)*);
        }
    };
}

/// A noise component's weight: within 100 dB of the others (10^(-1e9/20) is 0, which
/// left nothing to scale and wrote NaN).
fn weight_ok(db: f64) -> bool {
    (-100.0..=100.0).contains(&db)
}

fn finite3(p: &[f64; 3]) -> bool {
    p.iter().all(|v| v.is_finite())
}

/// Checks every number of the scene that does not need the geometry.
pub(crate) fn check_scene(scene: &SceneFile) -> Result<(), SceneError> {
    let fs = scene.sample_rate as f64;
    require!(
        (1000..=768_000).contains(&scene.sample_rate),
        "sample_rate must be between 1000 and 768000 Hz, got {}",
        scene.sample_rate
    );
    require!(
        scene.duration.is_finite() && scene.duration > 0.0 && scene.duration <= MAX_DURATION_S,
        "duration must be between 0 and {MAX_DURATION_S} seconds, got {}",
        BriefNumber(scene.duration)
    );
    require!(
        (scene.duration * fs).round() >= 1.0,
        "duration {} s is less than one sample at {} Hz",
        scene.duration,
        scene.sample_rate
    );
    let c = scene.speed_of_sound.unwrap_or(343.0);
    require!(
        c.is_finite() && (SPEED_RANGE.0..=SPEED_RANGE.1).contains(&c),
        "speed_of_sound must be between {} and {} m/s, got {}",
        SPEED_RANGE.0,
        SPEED_RANGE.1,
        BriefNumber(c)
    );
    if let Some(room) = &scene.room {
        require!(
            room.dimensions
                .iter()
                .all(|d| d.is_finite() && *d > 0.0 && *d <= MAX_ROOM_M),
            "room dimensions must be between 0 and {MAX_ROOM_M} m, got {}",
            shown3(&room.dimensions)
        );
    }
    require!(
        finite3(&scene.array.position) && scene.array.yaw_deg.is_finite(),
        "the array's position and yaw_deg must be finite numbers"
    );
    require!(
        scene.source.len() <= MAX_SOURCES,
        "{} sources; at most {MAX_SOURCES} are supported",
        scene.source.len()
    );
    for (i, s) in scene.source.iter().enumerate() {
        let what = format!("source {}", i + 1);
        let numbers = [
            s.azimuth_deg,
            s.elevation_deg,
            s.distance,
            s.rate,
            s.frequency,
            s.turn_deg_per_s,
        ];
        require!(
            s.position.is_none_or(|p| finite3(&p))
                && numbers.iter().flatten().all(|v| v.is_finite()),
            "{what}: every number must be finite"
        );
        require!(
            s.level_db.is_finite() && (-200.0..=40.0).contains(&s.level_db),
            "{what}: level_db must be between -200 and 40 dBFS, got {}",
            BriefNumber(s.level_db)
        );
        if let Some(d) = s.distance {
            require!(
                d > 0.0 && d <= MAX_DISTANCE_M,
                "{what}: distance must be between 0 and {MAX_DISTANCE_M} m, got {}",
                BriefNumber(d)
            );
        }
        if let Some(turn) = s.turn_deg_per_s {
            require!(
                s.position.is_none() && s.azimuth_deg.is_some() && s.distance.is_some(),
                "{what}: turn_deg_per_s moves a source given by azimuth_deg and distance (not position)"
            );
            require!(
                turn.abs() <= MAX_TURN_DEG_S,
                "{what}: turn_deg_per_s must be at most {MAX_TURN_DEG_S} deg/s either way, got {}",
                BriefNumber(turn)
            );
        }
        if s.signal == SignalKind::Clicks {
            let rate = s.rate.unwrap_or(10.0);
            require!(
                rate > 0.0 && rate <= 1000.0,
                "{what}: rate must be between 0 and 1000 clicks per second, got {}",
                BriefNumber(rate)
            );
        }
        if s.signal == SignalKind::Tone {
            let f = s.frequency.unwrap_or(1000.0);
            require!(
                f > 0.0 && f < fs / 2.0,
                "{what}: frequency must be between 0 and {} Hz (half the sample rate), got {}",
                fs / 2.0,
                BriefNumber(f)
            );
        }
    }
    if let Some(noise) = &scene.noise {
        require!(
            noise.snr_db.is_finite() && (-100.0..=100.0).contains(&noise.snr_db),
            "[noise] snr_db must be between -100 and 100 dB, got {}",
            BriefNumber(noise.snr_db)
        );
        require!(
            noise
                .sensor_db
                .is_none_or(|d| d.is_finite() && (-200.0..=40.0).contains(&d)),
            "[noise] sensor_db must be between -200 and 40 dBFS, got {}",
            BriefNumber(noise.sensor_db.unwrap_or(f64::NAN))
        );
        require!(
            noise
                .fan
                .iter()
                .all(|f| finite3(&f.position) && weight_ok(f.weight_db))
                && noise
                    .diffuse
                    .as_ref()
                    .is_none_or(|d| weight_ok(d.weight_db)),
            "[noise] positions must be finite numbers, and weight_db between -100 and 100 dB"
        );
    }
    Ok(())
}

/// The cost of rendering: the memory of the recording, and the image sources of every
/// response (source or fan to microphone).
pub(crate) fn check_cost(
    scene: &SceneFile,
    mics: usize,
    room_volume: Option<f64>,
    reach_m: f64,
    speed_of_sound: f64,
) -> Result<(), SceneError> {
    let fs = scene.sample_rate as f64;
    let samples = scene.duration * fs * mics as f64;
    require!(
        samples <= MAX_CHANNEL_SAMPLES,
        "{mics} channels of {} s at {} Hz is {samples:.3e} samples; at most {MAX_CHANNEL_SAMPLES:.3e} are rendered (the simulator holds the recording in memory): shorten the scene",
        scene.duration,
        scene.sample_rate
    );
    // Convolutions: each active interval (or turning block) of a source, and each fan
    // over the whole scene, through responses as long as sound takes to reach and decay.
    let response = reach_m / speed_of_sound * fs;
    let whole = [[0.0, scene.duration]];
    let (mut input, mut pieces, mut positions) = (0.0, 0.0, 0.0);
    for s in &scene.source {
        let intervals = s.active.as_deref().unwrap_or(&whole);
        input += intervals
            .iter()
            .map(|[a, b]| (b - a).max(0.0) * fs)
            .sum::<f64>();
        // A moving source needs a response per position (see `render`).
        let at = super::source::positions(s, scene.duration, fs);
        positions += at as f64;
        pieces += intervals.len().max(at) as f64;
    }
    let fans = scene.noise.as_ref().map_or(0, |n| n.fan.len()) as f64;
    let convolved =
        mics as f64 * (input + fans * scene.duration * fs + (pieces + 2.0 * fans) * response);
    // Image sources, in a room: for every response.
    let images = room_volume.map_or(0.0, |volume| {
        image_count(reach_m, volume) * mics as f64 * (positions + fans)
    });
    // Each bound alone is about a minute of work; together they share it.
    let work = images / MAX_IMAGES + convolved / MAX_CONVOLVED_SAMPLES;
    require!(
        work <= 1.0,
        "rendering needs about {images:.1e} image sources and convolves about {convolved:.1e} samples ({pieces} active intervals or moving blocks and {fans} fans, through responses of {:.2} s, at {mics} microphones): about {:.0} minutes of work, and at most one is done ({MAX_IMAGES:.0e} image sources, or {MAX_CONVOLVED_SAMPLES:.0e} samples): fewer intervals or fans, a shorter rt60, a larger room or a shorter scene",
        response / fs,
        work.ceil()
    );
    Ok(())
}
