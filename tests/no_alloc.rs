//! Analysing a recording does not allocate per frame or per block: plans and buffers are
//! made once. A counting global allocator watches a one-thread run over several blocks
//! after a warm-up. (With several threads, rayon boxes one job per block.)

mod support;

use ssl::geometry::unit_from_angles;
use ssl::method::Dereverb;
use ssl::sim::freefield::{render, Place, Scene, Source};
use ssl::sim::signals::Signal;
use ssl::{Analysis, Params};
use std::alloc::{GlobalAlloc, Layout, System};
use std::ops::ControlFlow;
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
fn analysing_frames_does_not_allocate() {
    let g = support::prism_geometry();
    let scene = Scene {
        sample_rate: 48000,
        duration_s: 5.0,
        mics: g.positions(),
        speed_of_sound: 343.0,
        sources: vec![Source {
            place: Place::Direction(unit_from_angles(50.0, -10.0)),
            signal: Signal::WhiteNoise,
            start_s: 0.3,
            end_s: 4.7,
            level: 0.05,
        }],
        sensor_noise: 0.005,
        seed: 1,
    };
    let ch = render(&scene);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    // As `ssl analyze` runs with its tracker: the steered response, a second source a
    // frame and candidates too; and with the diffuse part removed (on for planar arrays).
    for dereverb in [Dereverb::Auto, Dereverb::On] {
        let params = {
            let mut p = support::tracked_params();
            p.room.dereverb = dereverb;
            p
        };
        count_allocations(&pool, &ch, &g, &params);
    }
}

/// Analyses `ch` and checks that no frame after the first block allocates.
fn count_allocations(
    pool: &rayon::ThreadPool,
    ch: &[Vec<f32>],
    g: &ssl::Geometry,
    params: &Params,
) {
    let (frames, counts) = pool.install(|| {
        let channels = ch.iter().map(|c| &c[..]).collect();
        let analysis = Analysis::from_channels("t", channels, 48000, g, params).unwrap();
        // Allocations counted when the sink sees each frame (frames arrive a block at a
        // time, after the block is analysed and the next one read).
        let mut counts = Vec::with_capacity(1000);
        let mut detections = 0;
        let (summary, result) = analysis.run(|_, d| {
            detections += d.len();
            counts.push((ALLOCATIONS.load(Ordering::Relaxed), detections));
            ControlFlow::Continue(())
        });
        result.unwrap();
        (summary.stats.frames as usize, counts)
    });
    assert_eq!(frames, counts.len());
    // From the second block on (the first block's detections have built the direction
    // solver for the live set), nothing allocates.
    let (start, found) = counts[128];
    let (end, total) = *counts.last().unwrap();
    assert!(
        frames > 3 * 128,
        "{frames} frames: several blocks are measured"
    );
    assert!(
        found > 10 && total - found > 100,
        "the measured frames include detections"
    );
    assert_eq!(
        end - start,
        0,
        "allocations while analysing frames 128 to {frames}"
    );
}
