//! The array placed in the scene's room: the microphones in room coordinates, the pose,
//! the impulse responses from a point to every microphone, and the convolution that
//! makes a dry signal what each microphone hears.

use super::room::{add_tap, Room, SINC_HALF_WIDTH};
use super::scene::SceneFile;
use super::SceneError;
use crate::geometry::Geometry;
use nalgebra::{Matrix3, Vector3};
use realfft::RealFftPlanner;
use std::path::Path;

/// The array in the room: the room, the microphones in room coordinates, the pose.
pub(super) struct Placed {
    pub(super) room: Option<Room>,
    pub(super) mics: Vec<Vector3<f64>>,
    pub(super) centre: Vector3<f64>,
    /// Array frame to room frame.
    pub(super) rotation: Matrix3<f64>,
    pub(super) fs: f64,
    pub(super) c: f64,
    /// How long reflections last after the direct sound (seconds).
    pub(super) tail_s: f64,
}

impl Placed {
    pub(super) fn new(scene: &SceneFile, dir: &Path) -> Result<Self, SceneError> {
        let geometry = Geometry::from_file(&dir.join(&scene.array.geometry))?;
        let room = match &scene.room {
            None => None,
            Some(r) => {
                let dims = Vector3::from(r.dimensions);
                Some(match (r.rt60, r.absorption) {
                    (Some(t), None) => Room::with_rt60(dims, t)?,
                    (None, Some(a)) => Room::with_absorption(dims, a)?,
                    _ => fail!(
                        SceneError::Invalid,
                        "[room] needs exactly one of `rt60` or `absorption`"
                    ),
                })
            }
        };
        let yaw = scene.array.yaw_deg.to_radians();
        #[rustfmt::skip]
        let rotation = Matrix3::new(
            yaw.cos(), -yaw.sin(), 0.0,
            yaw.sin(), yaw.cos(), 0.0,
            0.0, 0.0, 1.0,
        );
        let centre = Vector3::from(scene.array.position);
        let placed = Placed {
            mics: geometry
                .mics
                .iter()
                .map(|m| centre + rotation * (m.position - geometry.centre))
                .collect(),
            tail_s: room.map_or(0.0, |r| 1.2 * r.rt60()),
            room,
            centre,
            rotation,
            fs: scene.sample_rate as f64,
            c: scene.speed_of_sound.unwrap_or(343.0),
        };
        for (i, m) in placed.mics.iter().enumerate() {
            placed.check_inside(&format!("mic {}", i + 1), m)?;
        }
        Ok(placed)
    }

    pub(super) fn check_inside(&self, what: &str, p: &Vector3<f64>) -> Result<(), SceneError> {
        if let Some(room) = &self.room {
            if !room.contains(p) {
                fail!(
                    SceneError::Invalid,
                    "{what} at [{:.3}, {:.3}, {:.3}] is outside the room [0..{}, 0..{}, 0..{}]",
                    p.x,
                    p.y,
                    p.z,
                    room.dims.x,
                    room.dims.y,
                    room.dims.z
                );
            }
        }
        Ok(())
    }

    /// Impulse responses from `p` to every microphone (1/r gain, direct path included).
    pub(super) fn responses(&self, p: &Vector3<f64>) -> Vec<Vec<f64>> {
        let (fs, c) = (self.fs, self.c);
        let far = self.mics.iter().map(|m| (m - p).norm()).fold(0.0, f64::max);
        let len = ((far / c + self.tail_s) * fs) as usize + 2 * SINC_HALF_WIDTH + 1;
        self.mics
            .iter()
            .map(|m| match &self.room {
                Some(room) => room.impulse_response(p, m, fs, c, len),
                None => {
                    // Free field: the direct path only.
                    let mut h = vec![0.0; len];
                    let d = (m - p).norm();
                    add_tap(&mut h, d / c * fs, 1.0 / d.max(1e-3));
                    h
                }
            })
            .collect()
    }
}

/// Convolves `x` with each response by FFT; outputs have `x.len() + h.len() - 1` samples.
pub(super) fn convolve(x: &[f64], responses: &[Vec<f64>]) -> Vec<Vec<f64>> {
    let hlen = responses.iter().map(Vec::len).max().unwrap_or(1);
    let n = (x.len() + hlen).next_power_of_two();
    let mut planner = RealFftPlanner::<f64>::new();
    let fwd = planner.plan_fft_forward(n);
    let inv = planner.plan_fft_inverse(n);
    let mut buf = vec![0.0; n];
    buf[..x.len()].copy_from_slice(x);
    let mut xs = fwd.make_output_vec();
    fwd.process(&mut buf, &mut xs).expect("sizes match");
    responses
        .iter()
        .map(|h| {
            let mut hb = vec![0.0; n];
            hb[..h.len()].copy_from_slice(h);
            let mut hs = fwd.make_output_vec();
            fwd.process(&mut hb, &mut hs).expect("sizes match");
            for (a, b) in hs.iter_mut().zip(&xs) {
                *a = *a * b / n as f64;
            }
            inv.process(&mut hs, &mut hb).expect("sizes match");
            hb.truncate(x.len() + h.len() - 1);
            hb
        })
        .collect()
}
