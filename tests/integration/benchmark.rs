//! A reduced accuracy benchmark for CI: the paper's Table I conditions with 4 horizontal
//! angles instead of 8, and 20 s of background alone. Bounds are loose enough to be
//! stable and tight enough to catch a real regression; the full run is
//! `cargo bench --bench accuracy` (results in docs/accuracy.md).

use crate::support;

use ssl::sim::scene::SignalKind;
use ssl::Params;
use support::bench::{azimuths, Bench, Lab, Pooled, SIGNALS, TABLE_I};

#[test]
fn table_i_rows_stay_accurate_and_background_stays_quiet() {
    let bench = Bench::new().unwrap();
    let lab = Lab::default();
    let params = Params::default();
    let az = azimuths(4);
    for (row, &(d, el, paper)) in TABLE_I.iter().enumerate() {
        let mut pooled = Pooled::default();
        for (k, &sig) in SIGNALS.iter().enumerate() {
            let scene = bench.scene(&lab, sig, d, el, &az, 900 + (row * 10 + k) as u64);
            let (wav, truth) = bench.record(&scene, &format!("ci-{row}-{k}")).unwrap();
            pooled.add(&bench.score(&wav, &truth, &params).unwrap());
        }
        eprintln!("{d} m, {el} deg: {} (paper {paper} deg)", pooled.cell());
        assert!(
            pooled.mean_error() < 4.0,
            "{d} m, {el} deg: mean error {}",
            pooled.mean_error()
        );
        assert!(
            pooled.event_rate() >= 0.9,
            "{d} m, {el} deg: events {}",
            pooled.event_rate()
        );
        assert!(
            pooled.frame_rate() >= 0.2,
            "{d} m, {el} deg: frames {}",
            pooled.frame_rate()
        );
    }
    let mut quiet = bench.scene(&lab, SignalKind::Speech, 3.0, 0.0, &[30.0], 7);
    quiet.duration = 21.5;
    quiet.source[0].active = Some(vec![[20.5, 21.3]]);
    let (wav, truth) = bench.record(&quiet, "ci-background").unwrap();
    let r = bench.score(&wav, &truth, &params).unwrap();
    eprintln!(
        "background: {} false detections in {:.0} s",
        r.false_detections, r.background_s
    );
    assert!(r.background_s > 18.0);
    assert!(
        r.false_detections <= 1,
        "{} false detections in {:.0} s of background",
        r.false_detections,
        r.background_s
    );
    // And the one event at the end is found.
    assert_eq!(r.sources[0].events_detected, 1);
}
