//! Processing a frame does not allocate: plans and buffers are made once. A counting
//! global allocator watches `Analyzer::process` over many frames after a warm-up.

use ssl::geometry::PAPER_PRISM;
use ssl::synth::{self, Place, Scene, Signal, Source};
use ssl::{Analyzer, Geometry, Params};
use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

struct Counting;

static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

#[test]
fn processing_frames_does_not_allocate() {
    let g = Geometry::from_positions(&PAPER_PRISM).unwrap();
    let scene = Scene {
        sample_rate: 48000,
        duration_s: 1.0,
        mics: g.positions(),
        speed_of_sound: 343.0,
        sources: vec![Source {
            place: Place::Direction(ssl::direction::unit_from_angles(50.0, -10.0)),
            signal: Signal::WhiteNoise,
            start_s: 0.3,
            end_s: 0.7,
            level: 0.05,
        }],
        sensor_noise: 0.005,
        seed: 1,
    };
    let ch = synth::render(&scene);
    let mut analyzer = Analyzer::new(&g, 48000, &Params::default()).unwrap();
    let n = analyzer.frame_size();
    let frames: Vec<Vec<f32>> = (0..(48000 - n) / (n / 2))
        .map(|i| {
            ch.iter()
                .flat_map(|c| c[i * n / 2..i * n / 2 + n].iter().copied())
                .collect()
        })
        .collect();
    // Warm-up: the first detection builds the direction solver for the live set.
    let mut detections = 0;
    for (i, f) in frames.iter().enumerate().take(40) {
        detections += analyzer.process(i as u64, f).is_some() as usize;
    }
    assert!(detections > 0);
    let before = ALLOCATIONS.load(Ordering::Relaxed);
    let mut later = 0;
    for (i, f) in frames.iter().enumerate().skip(40) {
        later += analyzer.process(i as u64, f).is_some() as usize;
    }
    let after = ALLOCATIONS.load(Ordering::Relaxed);
    assert!(
        later > 10,
        "the measured frames include detections: {later}"
    );
    assert_eq!(
        after - before,
        0,
        "allocations while processing {} frames",
        frames.len() - 40
    );
}
