//! From a frame's delays to its detection: eq. (13) through the solver of the frame's
//! set of live microphones (made once per set), the residual gate, and the detection's
//! time, angles and margin over the threshold. The consistency search and the steered
//! response both end here.

use super::beyond::steered::Steering;
use super::layout::Layout;
use super::outcome::Detection;
use super::paper::direction::DirectionSolver;
use super::paper::pairs::pair_count;
use super::paper::search::Solution;
use super::state::FrameState;
use super::uncertainty::{uncertainty_deg, unvouched_cone_deg};
use crate::geometry::angles_deg;
use std::collections::HashMap;

/// What the direction stage makes of a consistent set.
pub(crate) enum Direction {
    Found(Detection),
    /// No single source explains the delays (the residual gate).
    Gated,
    /// The system gives no direction.
    None,
}

/// The direction solver for the frame's set of live microphones (made once per set).
pub(crate) fn solver<'a>(
    solvers: &'a mut HashMap<u64, Option<DirectionSolver>>,
    setup: &Layout,
    state: &FrameState,
) -> Option<&'a DirectionSolver> {
    let mask = state.live.iter().fold(0u64, |acc, &m| acc | (1u64 << m));
    solvers
        .entry(mask)
        .or_insert_with(|| DirectionSolver::new(&setup.geometry, mask, setup.rate, setup.speed))
        .as_ref()
}

pub(crate) fn direction(
    solvers: &mut HashMap<u64, Option<DirectionSolver>>,
    setup: &Layout,
    state: &FrameState,
    index: u64,
    solution: &Solution,
) -> Direction {
    let Some(solver) = solver(solvers, setup, state) else {
        return Direction::None;
    };
    let Some(u) = solver.solve(&solution.lags) else {
        return Direction::None;
    };
    let residual = solver.residual_m(&solution.lags, &u);
    if let Some(gate) = setup.params.room.gate_us() {
        if residual / setup.speed * 1e6 > gate {
            return Direction::Gated;
        }
    }
    let uncertainty = uncertainty_deg(solver, &u, Some(residual), setup.speed);
    Direction::Found(detection(
        setup,
        state,
        index,
        u,
        solution.score,
        uncertainty,
    ))
}

/// The detection of direction `u` with `score` in frame `index`.
pub(crate) fn detection(
    setup: &Layout,
    state: &FrameState,
    index: u64,
    u: nalgebra::Vector3<f64>,
    score: f64,
    uncertainty_deg: f64,
) -> Detection {
    let (azimuth_deg, elevation_deg) = angles_deg(&u);
    let threshold = state.threshold * pair_count(state.live.len()) as f64;
    let margin = if threshold > 0.0 {
        score / threshold
    } else {
        f64::INFINITY
    };
    // Every frame's direction, kept whatever it scores: far under the threshold a frame
    // peaks at a reflection or the noise as often as at a source.
    let uncertainty_deg = if setup.params.steered == Steering::EveryFrame {
        unvouched_cone_deg(uncertainty_deg, margin)
    } else {
        uncertainty_deg
    };
    Detection {
        frame: index,
        time_s: (index as f64 * setup.hop as f64 + setup.n as f64 / 2.0) / setup.rate,
        azimuth_deg,
        elevation_deg,
        direction: u,
        score,
        mics: state.live.len(),
        margin,
        peak_margin: margin,
        uncertainty_deg,
        rider: false,
        span_s: 0.0,
        accumulated: false,
    }
}
