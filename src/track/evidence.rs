//! Whether a candidate is a source: Wald's sequential probability ratio test, counted
//! per look (see the [`track`](super) module; docs/method.md, "Sources from evidence").
//!
//! Two hypotheses about a candidate: *source* (a sound keeps coming from that
//! direction) and *clutter* (chance detections: background leaks, a talker's
//! reflections and strays). A *look* is the span one averaged correlation covers
//! ([`Room::average_frames`](crate::method::Room::average_frames) hops): detections
//! within one look share most of their data, so a look is one observation, counted
//! once, by its best detection.
//!
//! - A look with a detection adds `ln(f1(m) / f0(m)) + ln(P_D / (r x look))`: the
//!   ratio of its margin `m` (score over the frame's threshold) under the two
//!   hypotheses' laws, and of the chance that a source is heard in a look
//!   (`P_DETECT`) to the chance that clutter falls in the candidate's gate in one
//!   (`r`, a rate per second: the clutter map's rate).
//! - A look without one adds `ln(1 - P_D)`: a source would probably have been heard.
//! - A candidate is a source once its sum reaches `ln(N / F)`, `N` candidates an hour
//!   ([`CANDIDATES_PER_HOUR`]) of which at most `F` false
//!   ([`TrackParams::false_per_hour`](super::TrackParams::false_per_hour)); it is
//!   clutter once the sum falls to [`REJECT_NATS`].
//!
//! Margins follow Pareto laws from the candidates' floor `m0` (the share of the
//! threshold candidates are reported down to): `f(m) = a m0^a / m^(a + 1)`, exponent
//! `SOURCE_PARETO` for sources and `CLUTTER_PARETO` for clutter. Every constant
//! was measured on training draws (`benches/draws.py --seed 900`), none on the scenes
//! the method is scored on (docs/experiments.md, 2026-12-02).

/// The chance a source is heard in a look: the share of 64 ms looks of training speech
/// (prism, 48 kHz, RT60 0.3-0.8 s) with a detection within 10 deg of the talker.
pub(crate) const P_DETECT: f64 = 0.65;

/// The Pareto exponent of a source's margins (fitted by maximum likelihood on 4702
/// training detections of speech, claps and knocks, above the candidates' floor).
pub(crate) const SOURCE_PARETO: f64 = 1.6;

/// The Pareto exponent of clutter's margins (41 training detections more than 30 deg
/// from every source, background and rooms): clutter rarely stands far over the floor.
pub(crate) const CLUTTER_PARETO: f64 = 5.3;

/// Clutter over the threshold with no source active (per second, in a candidate's
/// gate): the training background (six minutes of fans near and far, diffuse noise and
/// a ceiling vent) gave none; taken as one in those 360 s.
pub const QUIET_RATE_PER_S: f64 = 1.0 / 360.0;

/// Clutter under the threshold (candidates) with no source active, before the
/// clutter map has learnt a place (per second, in a candidate's gate): a candidates'
/// gate filled as if a talker were beside it. A look with clutter more than 20 deg
/// from every talker saw 0.03-0.04 others a second in its gate on fresh scenes
/// (`benches/words.py --seed 500`), but 0.05 gave a fan beside the array and an
/// office's reflections false sources in `cargo bench --bench tracking` (clutter is
/// not spread evenly: it returns where it was); docs/experiments.md, 2026-12-05.
pub const CANDIDATE_RATE_PER_S: f64 = 0.2;

/// Clutter beside an active source (per second, in a candidate's gate): a talker's
/// reflections and strays, measured on the training rooms 30 deg and more from the
/// talkers while they spoke.
pub const BUSY_RATE_PER_S: f64 = 0.65;

/// Candidates started an hour, the `N` of the threshold `ln(N / F)`: 2500 measured on
/// the prism at 48 kHz in the training meetings, four times that for smaller arrays,
/// whose directions scatter more.
pub const CANDIDATES_PER_HOUR: f64 = 10_000.0;

/// A candidate whose evidence falls this low is clutter (nats): Wald's lower bound
/// `ln(beta)` for a 5% chance of dropping a source this way (a source heard again later
/// starts a new candidate).
pub const REJECT_NATS: f64 = -3.0;

/// A talking track heard within this long (seconds) makes the detections beside it
/// suspect: four looks, so that a talker missed in a look or two (a third of looks,
/// `P_DETECT`) still counts as talking; a loudspeaker in turn after a 0.5 s pause
/// does not.
pub const ACTIVE_S: f64 = 0.25;

/// How far a talking track's strays reach, in samples of delay error on the array
/// ([`Geometry::direction_spread_deg`](crate::geometry::Geometry::direction_spread_deg)):
/// a small array's strays are its delays a sample off (14-16 deg from the talker on a
/// 6.5 cm tetrahedron at 16 kHz, 13.4 deg a sample). A look in which a track this close
/// is heard tells nothing about a candidate beside it.
pub const REACH_SAMPLES: f64 = 1.6;

/// A candidate within reach of a talking track (or in its vertical plane) is a source
/// of its own, its evidence counted, when over the last [`ACTIVE_S`] it was heard at
/// least this many times and [`OWN_RATIO`] times as often as the track: a talker's
/// strays are rarer than his own detections.
pub const OWN_HITS: usize = 5;

/// See [`OWN_HITS`] (`benches/together.py`: a track confirmed between two talkers 33
/// deg apart on a 5.7 cm tetrahedron muted both; 2 let a low voice's strays 21 deg off
/// make a false event on `benches/voices.py`).
pub const OWN_RATIO: f64 = 3.0;

/// The widest reach (degrees).
pub const MAX_REACH_DEG: f64 = 30.0;

/// The Pareto exponent of an accumulated look's margins from a source
/// ([`Detection::accumulated`](crate::method::Detection::accumulated): the longer
/// average's best direction in a frame that gave nothing, its margin over that average's
/// threshold, from its own floor): fitted by maximum likelihood on the 896 accumulated
/// looks within 10 deg of a talker in training scenes (`benches/words.py`, seed 900 all
/// families, seeds 4300 and 7100 the hard rooms). Flatter than a frame's
/// ([`SOURCE_PARETO`]): added up over a word, a faint talker stands well over the floor.
pub(crate) const LOOK_SOURCE_PARETO: f64 = 0.93;

/// The Pareto exponent of an accumulated look's margins from clutter: the 41 accumulated
/// looks of the same scenes more than 10 deg from every talker (21 elsewhere, 20 in a
/// talker's vertical plane, his floor or ceiling image). Far heavier-tailed than a
/// frame's clutter ([`CLUTTER_PARETO`]): what stands out of a longer average is a
/// sound, if not the one sought.
pub(crate) const LOOK_CLUTTER_PARETO: f64 = 2.46;

/// Accumulated looks from clutter with no source active (per second, in a candidate's
/// gate): the 41 of the training scenes came in 488 s of talk (0.084 a second over the
/// whole sphere, taken as if all in one gate), and in none of the 30 minutes of
/// background of `benches/draws.py --seed 100` (the accumulated look skips a frame
/// with nothing above the noise estimate). Frames' candidates fall in a gate at
/// [`CANDIDATE_RATE_PER_S`], raised by the clutter map where they keep coming from (a
/// fan's leaks); this rate is not: the map learns the frames' clutter, which the
/// accumulated look does not hear, and raised at a faint talker's place by his own
/// dropped words it cost 6 of the 384 words of the four draws the law was chosen on
/// (docs/experiments.md, 2026-12-08).
pub const LOOK_RATE_PER_S: f64 = 0.084;

/// The evidence test's parameters for one recording.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Evidence {
    /// The span of one look (seconds).
    pub look_s: f64,
    /// The candidates' floor `m0`: margins are reported down to it.
    pub floor: f64,
    /// The accumulated look's floor: its margins are reported down to it.
    pub look_floor: f64,
    /// The confirmation threshold `ln(N / F)` (nats).
    pub confirm_nats: f64,
}

impl Evidence {
    /// For looks of `look_s` seconds, margins down to `floor` (the accumulated look's
    /// down to `look_floor`) and at most `false_per_hour` false sources an hour.
    pub fn new(look_s: f64, floor: f64, look_floor: f64, false_per_hour: f64) -> Self {
        Evidence {
            look_s: look_s.max(1e-6),
            floor: floor.clamp(1e-3, 1.0),
            look_floor: look_floor.clamp(1e-3, 1.0),
            confirm_nats: (CANDIDATES_PER_HOUR / false_per_hour).ln().max(0.0),
        }
    }

    /// The look a time falls in.
    pub fn look(&self, time_s: f64) -> i64 {
        (time_s / self.look_s).floor() as i64
    }

    /// The log ratio of margin `m` under the source and clutter laws (nats):
    /// `ln(a1 / a0) + (a0 - a1) ln(m / m0)`. Margins under the floor count as at it.
    pub fn margin_nats(&self, m: f64) -> f64 {
        pareto_nats(m, self.floor, SOURCE_PARETO, CLUTTER_PARETO)
    }

    /// A look with its best detection at margin `m`, clutter falling in the gate at
    /// `rate` per second (nats).
    pub fn hit_nats(&self, m: f64, rate: f64) -> f64 {
        self.margin_nats(m) + self.rate_nats(rate)
    }

    /// A look whose detection is an accumulated look's at margin `m`, weighed by the
    /// accumulated looks' own law from their own floor ([`LOOK_SOURCE_PARETO`],
    /// [`LOOK_CLUTTER_PARETO`]), clutter falling in the gate at `rate` per second (nats).
    pub fn look_nats(&self, m: f64, rate: f64) -> f64 {
        pareto_nats(m, self.look_floor, LOOK_SOURCE_PARETO, LOOK_CLUTTER_PARETO)
            + self.rate_nats(rate)
    }

    /// The chance a source is heard in a look against that of clutter falling in the
    /// gate at `rate` per second: `ln(P_D / (rate x look))` (nats).
    fn rate_nats(&self, rate: f64) -> f64 {
        (P_DETECT / (rate.max(1e-9) * self.look_s)).ln()
    }

    /// A look without a detection (nats).
    pub fn miss_nats(&self) -> f64 {
        (1.0 - P_DETECT).ln()
    }
}

/// The log ratio of margin `m` under Pareto laws from floor `m0` with exponent `a1` for
/// sources and `a0` for clutter (nats): `ln(a1 / a0) + (a0 - a1) ln(m / m0)`, margins
/// under the floor counted as at it.
fn pareto_nats(m: f64, m0: f64, a1: f64, a0: f64) -> f64 {
    let m = if m.is_finite() { m } else { 1e6 };
    (a1 / a0).ln() + (a0 - a1) * (m.max(m0) / m0).ln()
}

/// A candidate's running test: the looks counted so far, and the best detection of the
/// look still open.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Test {
    /// The evidence of the looks closed so far (nats).
    pub nats: f64,
    /// The last look counted or open.
    look: i64,
    /// The open look's best detection (nats), if it has one.
    open: Option<f64>,
    /// The open look tells nothing (a track was heard beside it): it counts 0.
    mute: bool,
    /// The looks closed with a detection.
    pub hit_looks: u32,
}

impl Test {
    /// A test whose first look is `look`.
    pub fn new(look: i64) -> Self {
        Test {
            nats: 0.0,
            look,
            open: None,
            mute: false,
            hit_looks: 0,
        }
    }

    /// Closes the looks before `look`: the open one by its best detection (or as a
    /// miss), those in between as misses, or as nothing when `muted` (a track was
    /// heard beside the candidate meanwhile).
    pub fn close_to(&mut self, look: i64, e: &Evidence, muted: bool) {
        while self.look < look {
            if !self.mute {
                self.nats += self.open.unwrap_or_else(|| e.miss_nats());
            }
            self.hit_looks += u32::from(self.open.is_some());
            self.look += 1;
            self.open = None;
            self.mute = muted;
            if self.nats <= REJECT_NATS {
                return;
            }
        }
    }

    /// A detection worth `nats` in look `look` (at or after the last; looks before it
    /// are closed first, those between as misses), or `None` when it tells nothing,
    /// which mutes its look.
    pub fn hit(&mut self, look: i64, nats: Option<f64>, e: &Evidence) {
        self.close_to(look, e, false);
        match nats {
            Some(nats) => self.open = Some(self.open.map_or(nats, |o: f64| o.max(nats))),
            None => self.mute = true,
        }
    }

    /// Marks the open look as telling nothing.
    pub fn mute(&mut self) {
        self.mute = true;
    }

    /// The evidence with the open look counted (nats).
    pub fn total(&self) -> f64 {
        self.nats
            + if self.mute {
                0.0
            } else {
                self.open.unwrap_or(0.0)
            }
    }

    /// Whether the evidence has fallen to [`REJECT_NATS`].
    pub fn rejected(&self) -> bool {
        self.nats <= REJECT_NATS
    }
}

/// The mean length of a burst of sound from one place (seconds): a word of 0.2-0.5 s
/// (see [`Bursts`]).
pub const BURST_S: f64 = 0.35;

/// The mean silence of a source between its bursts (seconds): a talker's pauses between
/// words and phrases (0.15-0.7 s in the words of `benches/words.py`, 0.3-0.8 s between
/// the turns of `benches/voices.py`; see [`Bursts`]). A longer silence is evidence
/// against a source there, at one nat per `PAUSE_S`. It was 3 s (a word every few
/// seconds); the hard rooms' words found, summed over four draws: 330 at 3 s, 334 at 1
/// s, 338 at 0.7 s, 342 at 0.5 s (with a candidate confirmed over its bursts while
/// another talks only once heard alone, [`Bursts::confirms`]; docs/experiments.md,
/// 2026-12-07, eighth session).
pub const PAUSE_S: f64 = 0.5;

/// The least log odds that a source known at a place sounds now for a candidate there
/// to be it (nats): a source heard before is not confirmed anew by one stray (at 0, a
/// fan beside the array confirmed once gave 15 false events in the tracking bench).
pub const ON_NATS: f64 = 2.0;

/// [`ON_NATS`] while another source talks (heard within [`ACTIVE_S`]): its reflections
/// and strays land everywhere, and a silent talker's place, which needs only
/// [`ON_NATS`] to sound again, gathered them: on small arrays, events of 3-5 detections
/// at a silent talker's place 80-100 deg from the one talking (`benches/voices.py`;
/// docs/experiments.md, 2026-12-06).
pub const ON_BUSY_NATS: f64 = 4.0;

/// A candidate's evidence as a source that sounds in bursts: a talker says a word,
/// falls silent, says another from the same place. [`Test`] takes a source as heard
/// in `P_DETECT` of the looks from its first detection on, so a silent look counts
/// against it and a faint talker's word of a few looks is rejected before it adds up;
/// the next word from the same place starts again from nothing.
///
/// Here the source is a two-state chain over the looks: *on* (heard in `P_DETECT` of
/// them, as in [`Test`]) or *off* (nothing but clutter, as under the clutter
/// hypothesis), a burst lasting [`BURST_S`] on average and a silence [`PAUSE_S`].
/// The likelihood ratio against clutter is the forward sum over both states' paths:
/// a silent look costs a source that has fallen silent nothing, and each new burst
/// costs the chance that it starts in that look (`ln(look / PAUSE_S)`, about -2.1 nats
/// at 64 ms looks), so a place that gives a detection now and then, as clutter does,
/// gains little, while words that each give a few looks add up. The ratio is still a
/// martingale under clutter, so Wald's bound on false sources holds as for [`Test`].
/// A confirmed track keeps its state through its silences, and a candidate that starts
/// where it was heard starts from it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bursts {
    /// Log ratio of the looks closed so far with the source on in the open look,
    /// before that look's own evidence (nats).
    on: f64,
    /// The same with the source off (nats).
    off: f64,
    /// The open look.
    look: i64,
    /// The open look's best detection (nats), if it has one.
    open: Option<f64>,
    /// The open look tells nothing.
    mute: bool,
}

fn log_sum_exp(a: f64, b: f64) -> f64 {
    let m = a.max(b);
    if m == f64::NEG_INFINITY {
        m
    } else {
        m + ((a - m).exp() + (b - m).exp()).ln()
    }
}

impl Bursts {
    /// A source on in look `look`, where its first detection is.
    pub fn new(look: i64) -> Self {
        Bursts {
            on: 0.0,
            off: f64::NEG_INFINITY,
            look,
            open: None,
            mute: false,
        }
    }

    /// Closes the looks before `look` (see [`Test::close_to`]).
    pub fn close_to(&mut self, look: i64, e: &Evidence, muted: bool) {
        let end = (e.look_s / BURST_S).min(0.5);
        let start = (e.look_s / PAUSE_S).min(0.5);
        while self.look < look {
            let heard = if self.mute {
                0.0
            } else {
                self.open.unwrap_or_else(|| e.miss_nats())
            };
            let (on, off) = (self.on + heard, self.off);
            self.on = log_sum_exp(on + (1.0 - end).ln(), off + start.ln());
            self.off = log_sum_exp(on + end.ln(), off + (1.0 - start).ln());
            self.look += 1;
            self.open = None;
            self.mute = muted;
            // Far past its last burst, every path is off: the rest is the same each look.
            if self.on < self.off - 30.0 && look - self.look > 4 {
                self.off += (look - self.look) as f64 * (1.0 - start).ln();
                self.on = self.off + start.ln();
                self.look = look;
            }
        }
    }

    /// A detection worth `nats` in look `look`, or `None` (see [`Test::hit`]).
    pub fn hit(&mut self, look: i64, nats: Option<f64>, e: &Evidence) {
        self.close_to(look, e, false);
        match nats {
            Some(nats) => self.open = Some(self.open.map_or(nats, |o: f64| o.max(nats))),
            None => self.mute = true,
        }
    }

    /// Marks the open look as telling nothing.
    pub fn mute(&mut self) {
        self.mute = true;
    }

    /// The open look's own evidence (nats).
    fn heard(&self) -> f64 {
        if self.mute {
            0.0
        } else {
            self.open.unwrap_or(0.0)
        }
    }

    /// The evidence with the open look counted (nats).
    pub fn total(&self) -> f64 {
        log_sum_exp(self.on + self.heard(), self.off)
    }

    /// Whether the evidence has fallen to [`REJECT_NATS`].
    pub fn rejected(&self) -> bool {
        self.total() <= REJECT_NATS
    }

    /// The log odds that the source sounds in the open look (nats).
    pub fn on_nats(&self) -> f64 {
        self.on + self.heard() - self.off
    }

    /// Whether the evidence makes a source that sounds now: at least `confirm_nats`
    /// that there is one, and at least [`ON_NATS`] that it is heard in this burst
    /// ([`ON_BUSY_NATS`] while another source talks: `busy`). While another talks, only
    /// once the candidate was `heard_alone` (a frame's only detection with no talking
    /// track heard in the 0.1 s before): a talker's wall reflection 20 deg from him,
    /// heard with each of his words 0.15-0.7 s apart, added up over them into a false
    /// source (`benches/words.py --seed 900`, scene 908; docs/experiments.md,
    /// 2026-12-07, eighth session).
    pub fn confirms(&self, e: &Evidence, busy: bool, heard_alone: bool) -> bool {
        let on = if busy { ON_BUSY_NATS } else { ON_NATS };
        self.total() >= e.confirm_nats && self.on_nats() >= on && (heard_alone || !busy)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn e() -> Evidence {
        Evidence::new(0.064, 0.4, 0.25, 1.0)
    }

    #[test]
    fn the_margin_ratio_is_the_two_pareto_densities() {
        let e = e();
        for m in [0.4_f64, 0.7, 1.0, 3.0, 30.0] {
            let f = |a: f64| a * e.floor.powf(a) / m.powf(a + 1.0);
            let direct = (f(SOURCE_PARETO) / f(CLUTTER_PARETO)).ln();
            assert!((e.margin_nats(m) - direct).abs() < 1e-9, "{m}");
        }
    }

    #[test]
    fn one_clap_far_over_the_threshold_in_quiet_confirms_at_once() {
        let e = e();
        // A clap 30 times the threshold.
        assert!(e.hit_nats(30.0, QUIET_RATE_PER_S) > e.confirm_nats);
        // Beside a talker, one detection at the threshold does not.
        assert!(e.hit_nats(1.0, BUSY_RATE_PER_S) < e.confirm_nats);
    }

    #[test]
    fn a_look_counts_once_by_its_best_detection_and_a_silent_look_counts_against() {
        let e = e();
        let mut t = Test::new(0);
        t.hit(0, Some(2.0), &e);
        t.hit(0, Some(3.0), &e);
        t.hit(0, Some(1.0), &e);
        assert_eq!(t.total(), 3.0);
        t.hit(3, Some(1.0), &e);
        assert!((t.nats - (3.0 + 2.0 * e.miss_nats())).abs() < 1e-12);
        assert!((t.total() - (4.0 + 2.0 * e.miss_nats())).abs() < 1e-12);
        // Looks beside a heard track count nothing: those gone by (as the tracker closes
        // them every frame) and the one a detection beside it falls in.
        t.close_to(6, &e, true);
        t.hit(6, None, &e);
        assert!((t.nats - (4.0 + 2.0 * e.miss_nats())).abs() < 1e-12);
        assert_eq!(t.total(), t.nats);
    }

    #[test]
    fn bursts_from_one_place_add_up_and_scattered_hits_do_not() {
        let e = e();
        // Words of 5 looks (0.32 s) every 1.5 s, each heard in 3 of its looks, each
        // look worth a third of the confirmation: no word alone is a source, a few are.
        let hit = 0.35 * e.confirm_nats;
        let word = |b: &mut Bursts, t: &mut Test, first: i64| {
            for k in [first, first + 2, first + 4] {
                b.hit(k, Some(hit), &e);
                t.hit(k, Some(hit), &e);
            }
        };
        let mut b = Bursts::new(0);
        let mut t = Test::new(0);
        word(&mut b, &mut t, 0);
        t.close_to(5, &e, false);
        assert!(t.total() < e.confirm_nats);
        let mut words = 1;
        while b.total() < e.confirm_nats && words < 10 {
            word(&mut b, &mut Test::new(words * 23), words * 23);
            b.close_to(words * 23 + 5, &e, false);
            words += 1;
        }
        assert!(
            (2..=4).contains(&words),
            "{words} words, {} nats",
            b.total()
        );
        // The same hits one at a time, one a word: clutter now and then.
        let mut b = Bursts::new(0);
        for w in 0..40 {
            b.hit(w * 23, Some(hit), &e);
        }
        b.close_to(40 * 23, &e, false);
        assert!(b.total() < 0.5 * e.confirm_nats, "{}", b.total());
        // Once the source is off, a silence costs about a nat per PAUSE_S: no burst
        // started (a little less: a burst unheard in a look or two is not ruled out).
        let mut b = Bursts::new(0);
        b.hit(0, Some(hit), &e);
        b.close_to(20, &e, false);
        let after = b.total();
        b.close_to(2020, &e, false);
        let expected = 2000.0 * e.look_s / PAUSE_S;
        let lost = after - b.total();
        assert!(
            (0.8 * expected..=expected).contains(&lost),
            "{lost} {expected}"
        );
    }

    #[test]
    fn a_candidate_never_heard_again_is_rejected() {
        let e = e();
        let mut t = Test::new(0);
        t.hit(0, Some(1.0), &e);
        t.close_to(100, &e, false);
        assert!(t.rejected());
    }
}
