"""The options of :class:`ssloc.Localizer`, typed: one per flag of `ssl analyze`
that changes what is found, generated from the flags' definitions by
python/tests/test_options.py (`SSLOC_UPDATE=1 pytest tests/test_options.py`
rewrites it). Do not edit."""

from typing import Literal, Sequence, TypedDict, Union


class Options(TypedDict, total=False):
    """Keyword arguments of :class:`ssloc.Localizer` and :func:`ssloc.analyze`: the
    command line's flags, ``--false-per-hour 1000`` as ``false_per_hour=1000``, a
    switch as ``True``."""

    # Method
    paper: bool
    """--paper: The paper's method as published: a tolerance of 2 samples, a fixed threshold of 0.5 per pair, parabolic peaks, no residual gate, no averaging over frames, no background subtraction, no dereverberation, one source per frame"""
    every_frame: bool
    """--every-frame: A direction for every frame with sound and no detection decision (what SRP-PHAT tools give): the consistent set when there is one, else the steered response's peak over the same weighted correlations; no tracker. The threshold only sets the cones: a row far under it may be a reflection or the noise, and its uncertainty_deg widens toward 180 (choose rows by it or by score yourself)"""
    speed_of_sound: Union[float, str]
    """--speed-of-sound: Speed of sound in m/s [default: the geometry's, else 343]"""

    # Frames
    frame_size: Union[float, str]
    """--frame-size: Frame size N in samples [default: about 21 ms: 1024 at 44.1/48 kHz, 256 at 16 kHz]"""
    frame_ms: Union[float, str]
    """--frame-ms: Frame length in milliseconds, the same at every sample rate: N is the power of two nearest to it at each file's rate"""
    window: Literal['hann', 'hamming', 'rectangular']
    """--window: Analysis window [default: hann]"""
    start: Union[float, str]
    """--start: Analyse from this time on (seconds from the start of each file; rounded down to a hop, so times and frames stay the file's) [default: 0]"""
    end: Union[float, str]
    """--end: Analyse up to this time (seconds from the start of each file; none: to its end)"""

    # Spectral weighting
    no_weighting: bool
    """--no-weighting: Plain PHAT: skip the spectral weighting (w_e = 1), for comparison"""
    alpha: Union[float, str]
    """--alpha: Noise over-subtraction alpha of the spectral weighting (paper eq. 4) [default: 0.4]"""
    gamma: Union[float, str]
    """--gamma: Exponent gamma that favours high-SNR bins (paper eq. 5) [default: 0.3]"""
    reverb_level: Union[float, str]
    """--reverb-level: Share of the recent frames' power taken as late reverberation in the noise estimate [default: 0.5; 0 with --min-score or --paper]"""
    band: Union[float, str]
    """--band: Analyse only these frequencies, LOW-HIGH in Hz (2k-8k for birds; to shut out a noise that owns a band, such as 200-20k above mains hum). Not for speech: the weighting already favours the bins a talker stands out in, and 300-3400 found fewer of a talker's words and twice the error on small arrays; HIGH beyond half the sample rate is taken as it"""

    # Peaks and consistency
    peaks: Union[float, str]
    """--peaks: Peaks M kept in each pair's cross-correlation [default: 8]"""
    interpolation: Literal['none', 'parabolic', 'cosine']
    """--interpolation: Sub-sample refinement of correlation peaks [default: cosine; parabolic with --paper]"""
    tolerance: Union[float, str]
    """--tolerance: Consistency tolerance in samples: how far a pair's peak may be from the delay the reference pairs imply [default: --tolerance-us]"""
    tolerance_us: Union[float, str]
    """--tolerance-us: Consistency tolerance in microseconds, the same time at every sample rate [default: 50]"""

    # Detection threshold
    min_score: Union[float, str]
    """--min-score: A fixed threshold instead of the calibrated one: drop detections scoring below this per microphone pair (a frame with P pairs needs P times it; 0 keeps every consistent set). The default threshold is calibrated per frame against its background (a diffuse field's coherence between the microphones plus --threshold-sigmas of chance correlation)"""
    threshold_sigmas: Union[float, str]
    """--threshold-sigmas: The calibrated threshold's allowance for chance correlation, in standard deviations [default: 6]"""

    # Reverberation and background
    residual_gate_us: Union[float, str]
    """--residual-gate-us: Drop detections whose delays no single source fits (plane wave, or spherical wave from 0.25-3 m) with an RMS residual under this many microseconds; 0 turns the gate off [default: 100]"""
    average_frames: Union[float, str]
    """--average-frames: Average each pair's correlation over this many frames: the frame's own and the ones before it (1: none, as in the paper) [default: 6]"""
    background_s: Union[float, str]
    """--background-s: Subtract from each pair's correlation its steady background (a fan next to the array), learned over about this many seconds; 0: none, as in the paper [default: 2]"""
    dereverb: Literal['auto', 'on', 'off']
    """--dereverb: Remove the reverberation's diffuse part from each pair's cross-spectrum (its coherence over the frames averaged) before correlating: a room shortens the delays by a few percent, which raises a planar array's elevations by 5-13 deg [default: auto]"""
    wpe: bool
    """--wpe: Dereverberate the input before analysis (multichannel linear prediction, WPE, below 4 kHz): more of a reverberant room's speech is found (two talkers 2 m from the prism at RT60 0.45 s: 74% of the 0.1 s windows instead of 68%), at about 15 times the time; at most 32 microphones"""

    # Several talkers
    max_sources: Union[float, str]
    """--max-sources: The most sources reported in one frame (1 to 4), for the tracker to confirm; a further source must pass the threshold on its own (1 with --min-score or --no-track) [default: 2]"""
    candidates: Union[float, str]
    """--candidates: Also report candidates down to this share of the detection threshold, for the tracker to confirm (a track starts from 2 detections above the threshold, 4 of which 1 is above it, or 12 candidates within --confirm-s) or drop [default: 0.4 with the calibrated threshold, 1 (none) with --min-score]"""
    riders: Union[float, str]
    """--riders: Search a frame that gives nothing down to --candidates again down to this share of the threshold: what it gives only adds a row to a talking track within a candidate's gate, without moving it, and starts nothing; at or above --candidates, none [default: 0.3 with the calibrated threshold, 1 (none) with --min-score]"""
    patterns_s: Union[float, str]
    """--patterns-s: Learn each talker's correlation pattern (its reflections too) while it dominates, and look for other talkers once it is removed from each pair's correlation averaged over about this many seconds; in frames that give nothing, that average's best direction adds up a faint talker's frames (arrays whose longest delay is 8 samples or more); 0: neither [default: 0.17]"""
    no_bin_votes: bool
    """--no-bin-votes: No riders from single frequency bins: on arrays a few centimetres across, each bin's own direction finds a talker that a louder one hides in the correlations, and adds its rows to that talker's track (two talkers on a 6-mic circle at 16 kHz: 60-70% of the 0.1 s windows instead of 56-66%)"""

    # Tracking
    no_track: bool
    """--no-track: No tracking: every frame's detection is written, without a `source` (tracking groups detections into sources, drops those no track confirms, smooths each row's direction over its track's (--smooth-s), and delays rows by up to --delay-s and --smooth-s)"""
    confirm_by: Literal['evidence', 'rules']
    """--confirm-by: How a candidate becomes a source [default: evidence]"""
    false_per_hour: Union[float, str]
    """--false-per-hour: With --confirm-by evidence: at most this many false sources an hour of background (fewer: more evidence needed before a source is reported) [default: 1]"""
    confirm_s: Union[float, str]
    """--confirm-s: With --confirm-by rules: a track is confirmed by 2 detections within this many seconds (of its latest) [default: 0.5]"""
    delay_s: Union[float, str]
    """--delay-s: Rows wait up to this many seconds for their track to be confirmed (the tracker's delay; never less than --confirm-s): a detection not confirmed by then is dropped, so a talker confirmed late loses its first detections [default: 1]"""
    smooth_s: Union[float, str]
    """--smooth-s: Each tracked row's direction is its track's mean over this many seconds before and after it, corrected for the track's turn (rows come out that much later); 0: each frame's own direction [default: 0.2]"""
    keep_unconfirmed: bool
    """--keep-unconfirmed: Also write the detections no track confirmed (isolated ones, a track's outliers), with an empty `source` (null in JSON), in frame order among the others"""
    forget_s: Union[float, str]
    """--forget-s: A source silent for this many seconds is forgotten: one heard again where it was within this time gets its id back, later a new one. On a static array keep it long; on an array that moves or turns (a robot), about as long as it stays still, since a source's direction then changes without the source moving [default: 120]"""

    # Output
    clock: bool
    """--clock: Add wall-clock times from each recording's Broadcast WAV time reference (bext: date and samples since midnight): `clock` on rows, `start_clock` and `end_clock` on events, ISO 8601 to the microsecond on the recorder's clock; a file without one is an error"""
