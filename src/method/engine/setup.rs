//! What a run of the method needs that does not change during it: the frame layout
//! ([`Layout`], which every stage reads) and each stage's own plan, built by that stage
//! for this array and rate.

use crate::geometry::Geometry;
use crate::method::beyond::background;
use crate::method::beyond::dereverb::DiffuseCoherence;
use crate::method::beyond::threshold::{
    diffuse_coherence, steady_weight, ThresholdPlan, DIFFUSE_MARGIN, STEADY_FRAME,
};
use crate::method::beyond::votes::BinVotes;
use crate::method::layout::Layout;
use crate::method::params::{Params, ParamsError};
use std::ops::Deref;

/// The layout and the stages' plans (see the module).
#[derive(Debug, Clone)]
pub(crate) struct Setup {
    pub layout: Layout,
    /// The detection threshold's plan.
    pub threshold: ThresholdPlan,
    /// A frame whose weights' ceiling is under this may teach the coherent background.
    pub background_gate: f64,
    /// When the diffuse part is removed from the cross-spectra ([`Room::dereverb`](crate::method::Room::dereverb)
    /// for this array): every pair's diffuse coherence at every bin.
    pub dereverb: Option<DiffuseCoherence>,
    /// The bins' solvers when they vote ([`Talkers::bin_votes`](crate::method::Talkers::bin_votes) with a tracker, on an
    /// array small enough).
    pub votes: Option<BinVotes>,
}

impl Deref for Setup {
    type Target = Layout;

    fn deref(&self) -> &Layout {
        &self.layout
    }
}

impl Setup {
    pub fn new(
        geometry: &Geometry,
        sample_rate: u32,
        params: &Params,
    ) -> Result<Self, ParamsError> {
        let layout = Layout::new(geometry, sample_rate, params)?;
        let (n, rate, speed) = (layout.n, layout.rate, layout.speed);
        let params = &layout.params;
        let dereverb = params
            .room
            .dereverb
            .applies(&geometry.shape)
            .then(|| DiffuseCoherence::new(geometry, n, rate, speed));
        let votes = params
            .bin_votes_on()
            .then(|| BinVotes::new(geometry, n, rate, speed))
            .flatten();
        Ok(Setup {
            threshold: threshold_plan(&layout),
            background_gate: background::gate(params) * layout.band_share(),
            dereverb,
            votes,
            layout,
        })
    }
}

/// The detection threshold's plan for this layout: its floors for this array and rate.
fn threshold_plan(layout: &Layout) -> ThresholdPlan {
    let params = &layout.params;
    let w = steady_weight(
        params.weighting.alpha as f32,
        params.weighting.reverb_share(),
    );
    ThresholdPlan {
        diffuse_floor: DIFFUSE_MARGIN
            * diffuse_coherence(
                &layout.geometry,
                layout.n,
                layout.rate,
                layout.speed,
                layout.band,
            ),
        // E times the interpolation's overshoot (E of the band's bins).
        steady_ceiling: STEADY_FRAME
            * w
            * w
            * layout.band_share()
            * params.peaks.refinement().overshoot()
            * (1.0 + 1e-3),
        choice: params.threshold,
        n: layout.n,
    }
}
