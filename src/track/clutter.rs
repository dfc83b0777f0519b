//! Where clutter comes from: a map of the directions whose candidates the evidence
//! rejected, so that a fan's leaks, heard again and again from one place, stop
//! counting as a source's evidence (see [`evidence`](super::evidence)).
//!
//! The sphere is cut in cells of [`CELL_DEG`] of azimuth and elevation. Each cell
//! counts the looks with a detection of the candidates rejected there, each count
//! forgotten with a time constant of [`MEMORY_S`]. The rate of clutter at a direction is
//! the mean of its posterior given the count of its cell and its eight neighbours over
//! the time observed (at most the memory), from a prior at the rate the test starts
//! from (`r0`) worth [`PRIOR_S`] of observation: `(r0 PRIOR_S + count) / (PRIOR_S +
//! observed)`, and never less than `r0`. So a fan's leaks
//! raise it within seconds, while a knock's reverberant tail, a few looks once, barely
//! does (the count over the time observed alone read such a tail as three a second in
//! a recording's first second, and every later knock from that place was dropped).

use nalgebra::Vector3;

/// A cell's size (degrees of azimuth and of elevation): the candidates' gate.
pub(crate) const CELL_DEG: f64 = 5.0;

/// How long the map remembers (seconds): a fan switched off is forgotten in about this.
pub(crate) const MEMORY_S: f64 = 30.0;

/// The prior's weight (seconds of observation): for candidates under the threshold,
/// five seconds, so that a fan's leaks (a few looks a second) outweigh it within seconds.
pub(crate) const PRIOR_S: f64 = 5.0;

const AZIMUTHS: usize = (360.0 / CELL_DEG) as usize;
const ELEVATIONS: usize = (180.0 / CELL_DEG) as usize;

/// The map (about 20 kB).
pub struct Clutter {
    /// Per cell, the decayed count and the time it was last decayed to.
    cells: Vec<(f32, f32)>,
    /// The time of the first look observed.
    start_s: Option<f64>,
}

impl Default for Clutter {
    fn default() -> Self {
        Clutter {
            cells: vec![(0.0, 0.0); AZIMUTHS * ELEVATIONS],
            start_s: None,
        }
    }
}

fn cell(direction: &Vector3<f64>) -> (i64, i64) {
    let az = direction
        .y
        .atan2(direction.x)
        .to_degrees()
        .rem_euclid(360.0);
    let el = direction.z.clamp(-1.0, 1.0).asin().to_degrees() + 90.0;
    (
        (az / CELL_DEG).floor() as i64,
        ((el / CELL_DEG).floor() as i64).min(ELEVATIONS as i64 - 1),
    )
}

fn index(az: i64, el: i64) -> Option<usize> {
    (0..ELEVATIONS as i64)
        .contains(&el)
        .then(|| el as usize * AZIMUTHS + az.rem_euclid(AZIMUTHS as i64) as usize)
}

impl Clutter {
    /// Time passes: the first call sets when observation began.
    pub fn observe(&mut self, now_s: f64) {
        self.start_s.get_or_insert(now_s);
    }

    /// A candidate at `direction` was rejected at `now_s` after `looks` looks with a
    /// detection.
    pub fn learn(&mut self, direction: &Vector3<f64>, looks: u32, now_s: f64) {
        let (az, el) = cell(direction);
        if let Some(i) = index(az, el) {
            let (count, at) = self.cells[i];
            let decayed = count * (-(now_s as f32 - at) / MEMORY_S as f32).exp();
            self.cells[i] = (decayed + looks as f32, now_s as f32);
        }
    }

    /// The rate of clutter at `direction` (per second), at least `floor`.
    pub fn rate(&self, direction: &Vector3<f64>, now_s: f64, floor: f64) -> f64 {
        let (az, el) = cell(direction);
        let mut count = 0.0;
        for de in -1..=1 {
            for da in -1..=1 {
                if let Some(i) = index(az + da, el + de) {
                    let (c, at) = self.cells[i];
                    count += c as f64 * (-(now_s - at as f64) / MEMORY_S).exp().min(1.0);
                }
            }
        }
        let start = self.start_s.unwrap_or(now_s);
        let observed = MEMORY_S * (1.0 - (-(now_s - start).max(0.0) / MEMORY_S).exp());
        ((floor * PRIOR_S + count) / (PRIOR_S + observed)).max(floor)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::unit_from_angles;

    #[test]
    fn a_place_that_keeps_giving_clutter_has_its_rate_raised_and_others_keep_the_floor() {
        let mut map = Clutter::default();
        map.observe(0.0);
        let fan = unit_from_angles(40.0, 10.0);
        // Three looks with leaks a second, for a minute.
        for s in 0..60 {
            map.learn(&fan, 3, s as f64);
        }
        let rate = map.rate(&unit_from_angles(41.0, 11.0), 60.0, 0.2);
        assert!((2.0..3.0).contains(&rate), "{rate}");
        // A knock's tail, four looks once in the first second, raises it less than a
        // second of the fan's leaks.
        let mut once = Clutter::default();
        once.observe(0.0);
        once.learn(&fan, 4, 0.5);
        let tail = once.rate(&fan, 1.0, 0.2);
        assert!((0.2..1.0).contains(&tail), "{tail}");
        assert_eq!(map.rate(&unit_from_angles(-90.0, 0.0), 60.0, 0.2), 0.2);
        // Forgotten after a few memories.
        assert_eq!(map.rate(&fan, 250.0, 0.2), 0.2);
    }

    #[test]
    fn the_map_wraps_around_at_180_degrees() {
        let mut map = Clutter::default();
        map.learn(&unit_from_angles(179.0, 0.0), 50, 1.0);
        assert!(map.rate(&unit_from_angles(-179.0, 0.0), 1.0, 0.0) > 0.0);
    }
}
