//! Drawing results (`ssl plot`, feature `plot`): one self-contained SVG.
//!
//! Each file of a result gets one row of three panels: azimuth against time, elevation
//! against time, and a sky map (azimuth against elevation). A detection is one mark in
//! each, coloured by its tracked source (else by its score, dark to bright); events are
//! drawn as bars over their span at their mean direction; a truth adds the true
//! directions over their active intervals (black lines, and rings on the sky map) and
//! the headline figures of `ssl evaluate` in the row's title.
//!
//! Large results stay small: a file with more than [`MAX_MARKS`] detections draws at most
//! one mark per cell of a grid of `TIME_BINS` columns by 1 deg (azimuth and elevation),
//! the first detection of the cell setting its colour; while more than [`MAX_MARKS`]
//! cells are occupied the cells double in size. The same input gives the same bytes. A
//! legend on the sky map says which colour is which source, and what black is.

mod read;

#[cfg(feature = "cli")]
pub(crate) use read::read_plot_file;
pub use read::{read_plot_data, PlotData, PlotFile};

use crate::evaluate::Report;
use crate::record::{DetectionRecord, Truth};
use plotters::prelude::*;
use std::collections::BTreeMap;

/// Columns of the time grid a file's marks are binned on.
pub(crate) const TIME_BINS: usize = 1200;
/// The most marks one panel draws.
#[doc(hidden)]
pub const MAX_MARKS: usize = 20_000;

/// The most files one picture draws (a row of three panels each): its size stays
/// bounded (40,000 one-row files made 629 MB of SVG).
#[doc(hidden)]
pub const MAX_FILES: usize = 64;

/// Width of the picture and height of one file's row (pixels): it fits a 1400-pixel
/// window with its scroll bar.
const WIDTH: u32 = 1360;
const ROW: u32 = 440;

/// Why a picture could not be drawn.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// The result holds nothing to draw for the files asked.
    #[error("{0}")]
    Empty(String),
    /// More files than one picture draws.
    #[error("the result holds {0} files; one picture draws at most {MAX_FILES}: pick one")]
    TooManyFiles(usize),
    /// The drawing failed (a bug).
    #[error("drawing failed: {0}")]
    Draw(String),
}

fn draw_err<E: std::fmt::Debug>(e: E) -> PlotError {
    PlotError::Draw(format!("{e:?}"))
}

/// Ten colours that tell tracks apart (Tableau 10).
const PALETTE: [(u8, u8, u8); 10] = [
    (31, 119, 180),
    (255, 127, 14),
    (44, 160, 44),
    (214, 39, 40),
    (148, 103, 189),
    (140, 86, 75),
    (227, 119, 194),
    (127, 127, 127),
    (188, 189, 34),
    (23, 190, 207),
];

fn track_colour(source: u64) -> RGBColor {
    let (r, g, b) = PALETTE[(source as usize).wrapping_sub(1) % PALETTE.len()];
    RGBColor(r, g, b)
}

/// Dark blue (low) to yellow (high), for `x` in 0..=1.
fn score_colour(x: f64) -> RGBColor {
    let x = x.clamp(0.0, 1.0);
    let stops = [
        (68.0, 1.0, 84.0),
        (33.0, 145.0, 140.0),
        (253.0, 231.0, 37.0),
    ];
    let (i, t) = if x < 0.5 {
        (0, x * 2.0)
    } else {
        (1, x * 2.0 - 1.0)
    };
    let mix = |a: f64, b: f64| (a + (b - a) * t).round() as u8;
    RGBColor(
        mix(stops[i].0, stops[i + 1].0),
        mix(stops[i].1, stops[i + 1].1),
        mix(stops[i].2, stops[i + 1].2),
    )
}

/// One mark: time, azimuth, elevation, colour, and its source (`None` untracked).
type Mark = (f64, f64, f64, RGBColor, Option<u64>);

/// The marks of `rows`: every row, or binned when there are more than [`MAX_MARKS`]
/// (see the module's documentation).
pub(crate) fn marks(rows: &[DetectionRecord], duration: f64) -> Vec<(f64, f64, f64, u64)> {
    if rows.len() <= MAX_MARKS {
        return rows
            .iter()
            .enumerate()
            .map(|(i, r)| (r.time_s, r.azimuth_deg, r.elevation_deg, i as u64))
            .collect();
    }
    let mut scale = 1.0;
    loop {
        let dt = duration.max(1e-9) / TIME_BINS as f64 * scale;
        let mut cells: BTreeMap<(i64, i64, i64), usize> = BTreeMap::new();
        for (i, r) in rows.iter().enumerate() {
            let key = (
                (r.time_s / dt).floor() as i64,
                (r.azimuth_deg / scale).floor() as i64,
                (r.elevation_deg / scale).floor() as i64,
            );
            cells.entry(key).or_insert(i);
            if cells.len() > MAX_MARKS {
                break;
            }
        }
        if cells.len() <= MAX_MARKS {
            let mut kept: Vec<usize> = cells.into_values().collect();
            kept.sort_unstable();
            return kept
                .into_iter()
                .map(|i| {
                    let r = &rows[i];
                    (r.time_s, r.azimuth_deg, r.elevation_deg, i as u64)
                })
                .collect();
        }
        scale *= 2.0;
    }
}

/// Draws `data` (its files, or only `only`) with `truth` and its report, if any, as SVG.
pub fn plot(
    data: &PlotData,
    only: Option<&str>,
    truth: Option<(&Truth, &Report)>,
) -> Result<String, PlotError> {
    let files: Vec<&PlotFile> = data
        .files
        .iter()
        .filter(|f| only.is_none_or(|o| f.name == o))
        .collect();
    if files.is_empty() {
        return Err(PlotError::Empty(match only {
            Some(o) => format!(
                "no file {o:?} in the result (it has: {})",
                data.files
                    .iter()
                    .map(|f| f.name.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
            None => "the result holds no detections and no events to draw".into(),
        }));
    }
    if files.len() > MAX_FILES {
        return Err(PlotError::TooManyFiles(files.len()));
    }
    let height = ROW * files.len() as u32 + 40;
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (WIDTH, height)).into_drawing_area();
        root.fill(&WHITE).map_err(draw_err)?;
        let (head, body) = root.split_vertically(40);
        head.draw_text(
            &data.heading(),
            &("sans-serif", 18).into_font().color(&BLACK),
            (12, 10),
        )
        .map_err(draw_err)?;
        let rows = body.split_evenly((files.len(), 1));
        for (area, file) in rows.iter().zip(&files) {
            draw_file(area, file, truth)?;
        }
        root.present().map_err(draw_err)?;
    }
    Ok(svg)
}

fn draw_file<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    file: &PlotFile,
    truth: Option<(&Truth, &Report)>,
) -> Result<(), PlotError> {
    let duration = file
        .duration()
        .max(truth.map_or(0.0, |t| t.0.duration_s))
        .max(1.0);
    let (lo, hi) = file.score_range();
    let kept = marks(&file.detections, duration);
    let colour = |i: u64| {
        let r = &file.detections[i as usize];
        match r.source {
            Some(s) => track_colour(s),
            None => score_colour(if hi > lo {
                (r.score - lo) / (hi - lo)
            } else {
                1.0
            }),
        }
    };
    let points: Vec<Mark> = kept
        .iter()
        .map(|&(t, a, e, i)| (t, a, e, colour(i), file.detections[i as usize].source))
        .collect();
    let title = file_title(file, kept.len(), truth);
    let area = area.titled(&title, ("sans-serif", 15)).map_err(draw_err)?;
    let third = area.dim_in_pixel().0 / 3;
    let (azimuth, rest) = area.split_horizontally(third);
    let (elevation, sky) = rest.split_horizontally(third);
    // Azimuth and elevation against time.
    for (panel, which) in [(&azimuth, 0usize), (&elevation, 1)] {
        draw_against_time(panel, which, duration, file, &points, truth)?;
    }
    draw_sky(&sky, file, &points, truth)
}

/// A file's panel title: its counts, and its scores against the truth.
fn file_title(file: &PlotFile, kept: usize, truth: Option<(&Truth, &Report)>) -> String {
    let mut title = format!(
        "{}: {} detections{}",
        file.name,
        file.detections.len(),
        if file.events.is_empty() {
            String::new()
        } else {
            format!(", {} events", file.events.len())
        }
    );
    if kept < file.detections.len() {
        title += &format!(" ({} marks per panel, binned)", kept);
    }
    if let Some((_, report)) = truth {
        title += &format!(
            "; against the truth: mean error {} ({}), events detected {} (heard {}), {} false per minute",
            report
                .mean_error_deg
                .map_or("-".into(), |e| format!("{e:.2} deg")),
            report.metric,
            report
                .event_detection_rate
                .map_or("-".into(), |r| format!("{:.0}%", 100.0 * r)),
            report
                .event_coverage
                .map_or("-".into(), |r| format!("{:.0}%", 100.0 * r)),
            report
                .false_per_minute
                .map_or("-".into(), |r| format!("{r:.1}")),
        );
    }
    if file.detections.first().is_some_and(|r| r.source.is_none()) {
        title += "; colour: score (dark low, bright high)";
    } else if !file.detections.is_empty() {
        title += "; colour: tracked source";
    }
    title
}

/// Azimuth (`which` 0) or elevation (1) against time: the truth's lines, the events'
/// bars (a moving source's along its path) and the detections' marks.
fn draw_against_time<DB: DrawingBackend>(
    panel: &DrawingArea<DB, plotters::coord::Shift>,
    which: usize,
    duration: f64,
    file: &PlotFile,
    points: &[Mark],
    truth: Option<(&Truth, &Report)>,
) -> Result<(), PlotError> {
    let (range, label) = if which == 0 {
        (-180.0..180.0, "azimuth (deg)")
    } else {
        (-90.0..90.0, "elevation (deg)")
    };
    let mut chart = ChartBuilder::on(panel)
        .margin(8)
        .x_label_area_size(36)
        .y_label_area_size(48)
        .build_cartesian_2d(0.0..duration, range)
        .map_err(draw_err)?;
    chart
        .configure_mesh()
        .x_desc("time (s)")
        .y_desc(label)
        .max_light_lines(0)
        .bold_line_style(RGBColor(225, 225, 225))
        .x_labels(8)
        .y_labels(9)
        .x_label_formatter(&|v| plain(*v))
        .y_label_formatter(&|v| format!("{v:.0}"))
        .draw()
        .map_err(draw_err)?;
    let value = |a: f64, e: f64| if which == 0 { a } else { e };
    if let Some((t, _)) = truth {
        for s in &t.sources {
            for &[a, b] in &s.active {
                for piece in truth_path(s, a, b) {
                    chart
                        .draw_series(LineSeries::new(
                            piece.iter().map(|&(t, az, el)| (t, value(az, el))),
                            BLACK.mix(0.45).stroke_width(2),
                        ))
                        .map_err(draw_err)?;
                }
            }
        }
    }
    for e in &file.events {
        let c = track_colour(e.source).mix(0.35).filled();
        let end = e.end_s.max(e.start_s + duration / 400.0);
        match moved(e) {
            // A source that moved: a band along its path, from its first detection's
            // direction to its last's.
            Some(((a0, e0), (a1, e1))) => {
                let (v0, v1) = (value(a0, e0), value(a1, e1));
                chart
                    .draw_series(std::iter::once(Polygon::new(
                        vec![
                            (e.start_s, v0 - 2.5),
                            (end, v1 - 2.5),
                            (end, v1 + 2.5),
                            (e.start_s, v0 + 2.5),
                        ],
                        c,
                    )))
                    .map_err(draw_err)?;
            }
            None => {
                let v = value(e.azimuth_deg, e.elevation_deg);
                chart
                    .draw_series(std::iter::once(Rectangle::new(
                        [(e.start_s, v - 2.5), (end, v + 2.5)],
                        c,
                    )))
                    .map_err(draw_err)?;
            }
        }
    }
    chart
        .draw_series(
            points
                .iter()
                .map(|&(t, a, e, c, _)| Circle::new((t, value(a, e)), 2, c.filled())),
        )
        .map_err(draw_err)?;
    Ok(())
}

/// The first and last directions (azimuth, elevation) of a moving source's event
/// ([`is_path`](crate::record::event::is_path)), unless its azimuth crosses +-180 deg
/// (drawn as its mean, a bar); `None` for a still one.
fn moved(e: &crate::record::EventRecord) -> Option<((f64, f64), (f64, f64))> {
    let (first, last) = e.ends()?;
    (crate::record::event::is_path(&first, &last)
        && (e.end_azimuth_deg - e.start_azimuth_deg).abs() < 180.0)
        .then_some((
            (e.start_azimuth_deg, e.start_elevation_deg),
            (e.end_azimuth_deg, e.end_elevation_deg),
        ))
}

/// The sky map: events at their mean direction, detections by source, the truth.
fn draw_sky<DB: DrawingBackend>(
    sky: &DrawingArea<DB, plotters::coord::Shift>,
    file: &PlotFile,
    points: &[Mark],
    truth: Option<(&Truth, &Report)>,
) -> Result<(), PlotError> {
    // The sky map.
    let mut chart = ChartBuilder::on(sky)
        .margin(8)
        .x_label_area_size(36)
        .y_label_area_size(48)
        .build_cartesian_2d(-180.0..180.0, -90.0..90.0)
        .map_err(draw_err)?;
    chart
        .configure_mesh()
        .x_desc("azimuth (deg)")
        .y_desc("elevation (deg)")
        .max_light_lines(0)
        .bold_line_style(RGBColor(225, 225, 225))
        .x_labels(7)
        .y_labels(7)
        .x_label_formatter(&|v| format!("{v:.0}"))
        .y_label_formatter(&|v| format!("{v:.0}"))
        .draw()
        .map_err(draw_err)?;
    // Events at their mean direction (an events-only result draws these alone).
    let mut sources: Vec<u64> = file.events.iter().map(|e| e.source).collect();
    sources.extend(points.iter().filter_map(|p| p.4));
    sources.sort_unstable();
    sources.dedup();
    if !file.events.is_empty() {
        chart
            .draw_series(file.events.iter().map(|e| {
                Rectangle::new(
                    [
                        (e.azimuth_deg - 2.5, e.elevation_deg - 2.5),
                        (e.azimuth_deg + 2.5, e.elevation_deg + 2.5),
                    ],
                    track_colour(e.source).mix(0.6).filled(),
                )
            }))
            .map_err(draw_err)?
            .label("event (mean direction; bars over time)")
            .legend(|(x, y)| {
                Rectangle::new(
                    [(x, y - 4), (x + 8, y + 4)],
                    RGBColor(127, 127, 127).filled(),
                )
            });
    }
    if points.iter().any(|p| p.4.is_none()) {
        chart
            .draw_series(
                points
                    .iter()
                    .filter(|p| p.4.is_none())
                    .map(|&(_, a, e, c, _)| Circle::new((a, e), 2, c.filled())),
            )
            .map_err(draw_err)?
            .label("detection (colour: score, dark low, bright high)")
            .legend(|(x, y)| Circle::new((x + 4, y), 3, score_colour(0.8).filled()));
    }
    for (k, &source) in sources.iter().enumerate() {
        let c = track_colour(source);
        let series = chart
            .draw_series(
                points
                    .iter()
                    .filter(|p| p.4 == Some(source))
                    .map(|&(_, a, e, c, _)| Circle::new((a, e), 2, c.filled())),
            )
            .map_err(draw_err)?;
        // Ten colours: beyond them the legend would repeat them, and grow past the panel.
        if k < PALETTE.len() {
            series
                .label(format!("source {source}"))
                .legend(move |(x, y)| Circle::new((x + 4, y), 3, c.filled()));
        } else if k == PALETTE.len() {
            series
                .label(format!("... {} sources in all", sources.len()))
                .legend(move |(x, y)| Circle::new((x + 4, y), 3, c.filled()));
        }
    }
    if let Some((t, _)) = truth {
        chart
            .draw_series(t.sources.iter().map(|s| {
                Cross::new(
                    (s.azimuth_deg, s.elevation_deg),
                    7,
                    BLACK.mix(0.6).stroke_width(2),
                )
            }))
            .map_err(draw_err)?
            .label("truth (black: crosses here, lines over time)")
            .legend(|(x, y)| Cross::new((x + 4, y), 4, BLACK.stroke_width(2)));
        // A moving source's path, from its cross on.
        for s in t.sources.iter().filter(|s| s.moves()) {
            for &[a, b] in &s.active {
                for piece in truth_path(s, a, b) {
                    chart
                        .draw_series(LineSeries::new(
                            piece.iter().map(|&(_, az, el)| (az, el)),
                            BLACK.mix(0.6).stroke_width(1),
                        ))
                        .map_err(draw_err)?;
                }
            }
        }
    }
    if !sources.is_empty() || truth.is_some() || points.iter().any(|p| p.4.is_none()) {
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::LowerRight)
            .background_style(WHITE.mix(0.85))
            .border_style(RGBColor(200, 200, 200))
            .label_font(("sans-serif", 11))
            .draw()
            .map_err(draw_err)?;
    }
    Ok(())
}

impl PlotFile {
    /// The last time in the file's rows and events.
    fn duration(&self) -> f64 {
        let rows = self.detections.iter().map(|r| r.time_s);
        let events = self.events.iter().map(|e| e.end_s);
        rows.chain(events).fold(0.0, f64::max)
    }

    /// The lowest and highest score.
    fn score_range(&self) -> (f64, f64) {
        self.detections
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), r| {
                (lo.min(r.score), hi.max(r.score))
            })
    }
}

impl PlotData {
    /// The picture's heading: the array and the threshold, when the result says.
    fn heading(&self) -> String {
        let mut s = String::from("ssl plot");
        if let Some(a) = &self.array {
            s += &format!(" | array: {a}");
        }
        if let Some(t) = &self.threshold {
            s += &format!(" | threshold: {t}");
        }
        s
    }
}

/// A tick's value as plain numbers: `600`, not `600.0`; `2.5` as it is.
fn plain(v: f64) -> String {
    let r = (v * 1000.0).round() / 1000.0 + 0.0;
    if r == r.trunc() {
        format!("{r:.0}")
    } else {
        format!("{r}")
    }
}

/// A true source's direction from `a` to `b` seconds as (time, azimuth, elevation),
/// sampled every 20 ms for a moving source (its two ends for a still one), in pieces
/// that do not cross azimuth +-180.
fn truth_path(s: &crate::record::TruthSource, a: f64, b: f64) -> Vec<Vec<(f64, f64, f64)>> {
    let steps = if s.moves() {
        ((b - a) / 0.02).ceil().max(1.0) as usize
    } else {
        1
    };
    let mut pieces: Vec<Vec<(f64, f64, f64)>> = vec![Vec::new()];
    for i in 0..=steps {
        let t = a + (b - a) * i as f64 / steps as f64;
        let (az, el) = crate::geometry::angles_deg(&s.direction_at(t));
        let piece = pieces.last_mut().expect("one piece at least");
        if piece
            .last()
            .is_some_and(|&(_, last, _)| (az - last).abs() > 180.0)
        {
            pieces.push(Vec::new());
        }
        pieces.last_mut().expect("just pushed").push((t, az, el));
    }
    pieces
}
