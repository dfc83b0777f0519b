//! A measured setup's ground truth, written by hand (docs/interface.md, "Ground truth of
//! a measured setup"): the minimal JSON form
//! `{"sources": [{"azimuth_deg": 30, "elevation_deg": 10, "intervals": [[0.5, 2.0]]}]}`
//! (optional `name`, `x`/`y`/`z` instead of the angles, no elevation for an azimuth-only
//! truth, `turn_deg_per_s` or `path` (waypoints) for a moving source, `duration_s`); CSV with a
//! header naming its columns (`source,start_s,end_s,azimuth_deg,elevation_deg`, or the
//! names labs use, separated by `,`, `;` or tabs, times in seconds or `m:ss.s`); or the
//! label files of Audacity, Praat and ELAN (`truth_labels`). All become a [`Truth`] like
//! the one `ssl simulate` writes, with what a hand cannot know left unknown (no room, no
//! sample rate). Every problem is named once, with the lines it is on.

use super::truth::{Truth, TruthArray, TruthSource};
use super::truth_labels::{self, seconds, Piece};
use crate::geometry::{angles_deg, unit_from_angles};
use nalgebra::Vector3;
use serde_json::{Map, Value};

/// The keys of a hand-written source.
const SOURCE_KEYS: [&str; 10] = [
    "name",
    "azimuth_deg",
    "elevation_deg",
    "x",
    "y",
    "z",
    "intervals",
    "turn_deg_per_s",
    "turn_from_s",
    "path",
];

/// The problems an error line names one by one; the rest are counted.
const SHOWN_PROBLEMS: usize = 10;

/// The longest piece of the file an error line quotes, in characters.
const QUOTED_CHARS: usize = 80;

/// `v` as JSON, cut to [`QUOTED_CHARS`] characters (a truth of a million intervals is
/// not quoted whole in a message).
fn quoted(v: &Value) -> String {
    quoted_text(&v.to_string())
}

/// `text` cut to [`QUOTED_CHARS`] characters.
fn quoted_text(text: &str) -> String {
    match text.char_indices().nth(QUOTED_CHARS) {
        Some((cut, _)) => format!("{}... ({} characters)", &text[..cut], text.chars().count()),
        None => text.to_string(),
    }
}

/// Why the angles `az`, `el` (degrees) are not a direction: an elevation outside
/// [-90, 90], an azimuth outside [-360, 360].
fn bad_angles(az: f64, el: f64) -> Option<String> {
    if !(-90.0..=90.0).contains(&el) {
        return Some(format!("elevation_deg must be within -90..90, got {el}"));
    }
    if !(-360.0..=360.0).contains(&az) {
        return Some(format!("azimuth_deg must be within -360..360, got {az}"));
    }
    None
}

/// The CSV form's header.
pub const CSV_HEADER: &str = "source,start_s,end_s,azimuth_deg,elevation_deg";

/// A truth from text in any accepted form: what `ssl simulate` writes, the minimal JSON
/// form, or the CSV form. `Err` lists every problem found.
pub(crate) fn parse(text: &str) -> Result<Truth, String> {
    let start = text.trim_start_matches('\u{feff}').trim_start();
    if !start.starts_with('{') {
        let mut problems = Vec::new();
        let pieces = if truth_labels::is_textgrid(start) {
            truth_labels::from_textgrid(start, &mut problems)
        } else if truth_labels::is_label_file(start) {
            truth_labels::from_label_file(start, &mut problems)
        } else {
            from_csv(start, &mut problems)?
        };
        return assemble(pieces, problems);
    }
    let doc: Value = serde_json::from_str(start).map_err(|e| format!("not a truth file: {e}"))?;
    let Value::Object(top) = &doc else {
        return Err("not a truth file: a JSON object is needed".into());
    };
    // What `ssl simulate` writes names its tool and sample rate.
    if top.contains_key("tool") || top.contains_key("sample_rate") {
        let truth: Truth =
            serde_json::from_value(doc).map_err(|e| format!("not a truth file: {e}"))?;
        // 0 stands for a hand-written truth's unknown rate, never a simulation's.
        if truth.sample_rate == 0 {
            return Err("sample_rate 0 Hz is outside 1000-768000".into());
        }
        return Ok(truth);
    }
    from_minimal(top)
}

/// The minimal JSON form.
fn from_minimal(top: &Map<String, Value>) -> Result<Truth, String> {
    let mut problems = Vec::new();
    for key in top.keys().filter(|k| *k != "sources" && *k != "duration_s") {
        problems.push(format!(
            "unknown key `{key}` (a hand-written truth has `sources` and optionally `duration_s`)"
        ));
    }
    let duration = match top.get("duration_s") {
        None => None,
        Some(v) => match v.as_f64() {
            Some(d) if d.is_finite() && d > 0.0 => Some(d),
            _ => {
                problems.push(format!("duration_s must be a positive number, got {v}"));
                None
            }
        },
    };
    let mut sources = Vec::new();
    match top.get("sources") {
        Some(Value::Array(list)) if !list.is_empty() => {
            for (i, s) in list.iter().enumerate() {
                match source(i, s) {
                    Ok(s) => sources.push(s),
                    Err(mut p) => problems.append(&mut p),
                }
            }
        }
        Some(_) => problems.push("`sources` must be a non-empty array of sources".into()),
        None => problems.push("missing `sources` (an array of sources)".into()),
    }
    finish(sources, duration, problems)
}

/// Source `i` (0-based) of the minimal form.
fn source(i: usize, s: &Value) -> Result<TruthSource, Vec<String>> {
    let at = format!("source {}", i + 1);
    let Value::Object(s) = s else {
        return Err(vec![format!("{at}: an object is needed")]);
    };
    let mut problems = Vec::new();
    for key in s.keys().filter(|k| !SOURCE_KEYS.contains(&k.as_str())) {
        problems.push(format!("{at}: unknown key `{key}`"));
    }
    let number = |k: &str, problems: &mut Vec<String>| -> Option<f64> {
        let v = s.get(k)?;
        match v.as_f64().filter(|x| x.is_finite()) {
            Some(x) => Some(x),
            None => {
                problems.push(format!("{at}: {k} must be a number, got {}", quoted(v)));
                None
            }
        }
    };
    let (az, el) = (
        number("azimuth_deg", &mut problems),
        number("elevation_deg", &mut problems),
    );
    let (x, y, z) = (
        number("x", &mut problems),
        number("y", &mut problems),
        number("z", &mut problems),
    );
    let waypoints = match s.get("path") {
        None => Vec::new(),
        Some(v) => waypoints(&at, v, &mut problems),
    };
    let azimuth_only = az.is_some() && el.is_none() && x.is_none()
        || !waypoints.is_empty() && waypoints.iter().any(|w| w.1 .1.is_none());
    let direction = match (az, el, x, y, z) {
        (Some(a), e, None, None, None) => match bad_angles(a, e.unwrap_or(0.0)) {
            None => Some(unit_from_angles(a, e.unwrap_or(0.0))),
            Some(why) => {
                problems.push(format!("{at}: {why}"));
                None
            }
        },
        (None, None, None, None, None) if !waypoints.is_empty() => {
            let (_, (a, e)) = waypoints[0];
            Some(unit_from_angles(a, e.unwrap_or(0.0)))
        }
        (None, None, Some(x), Some(y), Some(z)) => {
            let v = Vector3::new(x, y, z);
            if v.norm() > 0.0 {
                Some(v.normalize())
            } else {
                problems.push(format!("{at}: x, y, z must not all be 0"));
                None
            }
        }
        (None, None, None, None, None) => {
            problems.push(format!(
                "{at}: missing its direction (azimuth_deg and elevation_deg, azimuth_deg alone, x, y and z, or path)"
            ));
            None
        }
        _ => {
            problems.push(format!(
                "{at}: give azimuth_deg and elevation_deg, or x, y and z, not a mix or a part"
            ));
            None
        }
    };
    let intervals = match s.get("intervals") {
        None => {
            problems.push(format!(
                "{at}: missing intervals (when it sounds: [[start_s, end_s], ...])"
            ));
            None
        }
        Some(v) => intervals(&at, v, &mut problems),
    };
    let name = match s.get("name") {
        None => None,
        Some(Value::String(n)) => Some(n.clone()),
        Some(v) => Some(v.to_string()),
    };
    let turn = number("turn_deg_per_s", &mut problems);
    let turn_from = number("turn_from_s", &mut problems);
    if turn_from.is_some() && turn.is_none() {
        problems.push(format!("{at}: turn_from_s needs turn_deg_per_s"));
    }
    if turn.is_some() && !waypoints.is_empty() {
        problems.push(format!("{at}: give turn_deg_per_s or path, not both"));
    }
    match (direction, intervals, problems.is_empty()) {
        (Some(u), Some(active), true) => {
            let first = active.iter().map(|iv| iv[0]).fold(f64::INFINITY, f64::min);
            let mut source = truth_source(i, name, u, active);
            source.turn_deg_per_s = turn;
            source.turn_from_s = turn.map(|_| turn_from.unwrap_or(first));
            source.waypoints = waypoints
                .into_iter()
                .map(|(t, (a, e))| [t, a, e.unwrap_or(0.0)])
                .collect();
            source.azimuth_only = azimuth_only;
            Ok(source)
        }
        _ => Err(problems),
    }
}

/// A source's path (its waypoints): `[[time_s, azimuth_deg, elevation_deg], ...]` (or `[time_s,
/// azimuth_deg]` for an azimuth-only truth), in time order.
fn waypoints(at: &str, v: &Value, problems: &mut Vec<String>) -> Vec<(f64, (f64, Option<f64>))> {
    let read = |w: &Value| {
        let w = w.as_array().filter(|w| (2..=3).contains(&w.len()))?;
        let n: Vec<f64> = w
            .iter()
            .map(|x| x.as_f64().filter(|x| x.is_finite()))
            .collect::<Option<_>>()?;
        (n[0] >= 0.0 && bad_angles(n[1], n.get(2).copied().unwrap_or(0.0)).is_none())
            .then(|| (n[0], (n[1], n.get(2).copied())))
    };
    let list: Option<Vec<_>> = v
        .as_array()
        .filter(|l| !l.is_empty())
        .and_then(|l| l.iter().map(read).collect());
    match list {
        Some(list) if list.windows(2).all(|w| w[0].0 < w[1].0) => list,
        _ => {
            problems.push(format!(
                "{at}: path must be a non-empty list of [time_s, azimuth_deg, elevation_deg] (or [time_s, azimuth_deg]) in time order, got {}",
                quoted(v)
            ));
            Vec::new()
        }
    }
}

fn intervals(at: &str, v: &Value, problems: &mut Vec<String>) -> Option<Vec<[f64; 2]>> {
    let bad = |problems: &mut Vec<String>| {
        problems.push(format!(
            "{at}: intervals must be a non-empty list of [start_s, end_s] with 0 <= start_s < end_s, got {}",
            quoted(v)
        ));
        None
    };
    let Value::Array(list) = v else {
        return bad(problems);
    };
    let mut out = Vec::new();
    for iv in list {
        let pair = iv.as_array().filter(|p| p.len() == 2).and_then(|p| {
            Some([p[0].as_f64()?, p[1].as_f64()?])
                .filter(|[a, b]| a.is_finite() && b.is_finite() && *a >= 0.0 && a < b)
        });
        match pair {
            Some(p) => out.push(p),
            None => return bad(problems),
        }
    }
    if out.is_empty() {
        return bad(problems);
    }
    Some(out)
}

fn truth_source(
    index: usize,
    name: Option<String>,
    u: Vector3<f64>,
    active: Vec<[f64; 2]>,
) -> TruthSource {
    let (azimuth_deg, elevation_deg) = angles_deg(&u);
    TruthSource {
        index,
        signal: name.unwrap_or_else(|| format!("source {}", index + 1)),
        level_db: 0.0,
        position_room: [0.0; 3],
        x: u.x,
        y: u.y,
        z: u.z,
        azimuth_deg,
        elevation_deg,
        distance_m: None,
        active,
        turn_deg_per_s: None,
        turn_from_s: None,
        waypoints: Vec::new(),
        azimuth_only: false,
    }
}

/// The truth of `sources`, or every problem.
fn finish(
    sources: Vec<TruthSource>,
    duration: Option<f64>,
    problems: Vec<String>,
) -> Result<Truth, String> {
    if !problems.is_empty() {
        let mut line = problems[..problems.len().min(SHOWN_PROBLEMS)].join("; ");
        if problems.len() > SHOWN_PROBLEMS {
            line += &format!("; and {} more problems", problems.len() - SHOWN_PROBLEMS);
        }
        return Err(format!("not a truth file: {line}"));
    }
    let last = sources
        .iter()
        .flat_map(|s| s.active.iter().map(|iv| iv[1]))
        .fold(0.0, f64::max);
    Ok(Truth {
        tool: Default::default(),
        sample_rate: 0,
        duration_s: duration.unwrap_or(last),
        seed: 0,
        speed_of_sound: 343.0,
        room: None,
        array: TruthArray::default(),
        sources,
        noise: None,
        recording: None,
    })
}

/// What a CSV column holds.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Column {
    Source,
    Start,
    End,
    Azimuth,
    Elevation,
    EndAzimuth,
    EndElevation,
}

/// The names a CSV header may give each column (lower case, once units in brackets and
/// a unit suffix such as `_s` or `_deg` are taken off).
const COLUMNS: [(Column, &[&str]); 7] = [
    (
        Column::Source,
        &["source", "name", "label", "speaker", "talker", "id", "tier"],
    ),
    (
        Column::Start,
        &[
            "start", "begin", "onset", "from", "t_start", "tmin", "xmin", "t0",
        ],
    ),
    (
        Column::End,
        &["end", "stop", "offset", "to", "t_end", "tmax", "xmax", "t1"],
    ),
    (Column::Azimuth, &["azimuth", "az", "doa", "azi"]),
    (Column::Elevation, &["elevation", "el", "elev", "ele"]),
    (
        Column::EndAzimuth,
        &["end_azimuth", "end_az", "to_azimuth", "azimuth_end"],
    ),
    (
        Column::EndElevation,
        &["end_elevation", "end_el", "to_elevation", "elevation_end"],
    ),
];

/// The column a header field names, if any.
fn column(field: &str) -> Option<Column> {
    let mut name = field.trim().trim_matches('"').to_ascii_lowercase();
    // Units in brackets: `start (s)`, `azimuth [deg]`.
    if let Some(cut) = name.find(['(', '[']) {
        name.truncate(cut);
    }
    let mut name = name.trim().replace([' ', '-'], "_");
    for suffix in [
        "_degrees", "_deg", "_seconds", "_secs", "_sec", "_s", "_time",
    ] {
        if let Some(base) = name.strip_suffix(suffix) {
            name = base.to_string();
            break;
        }
    }
    COLUMNS
        .iter()
        .find(|(_, names)| names.contains(&name.as_str()))
        .map(|&(c, _)| c)
}

/// The CSV form: a header naming the columns (in any order; others are ignored), then
/// one row per interval; `,`, `;` (with decimal commas) or tab between fields.
fn from_csv(text: &str, problems: &mut Vec<(usize, String)>) -> Result<Vec<Piece>, String> {
    let first = text
        .lines()
        .find(|l| !l.trim().is_empty() && !l.starts_with('#'))
        .unwrap_or("");
    let (delimiter, decimal_comma) = if first.contains('\t') {
        (b'\t', false)
    } else if first.contains(';') {
        (b';', true)
    } else {
        (b',', false)
    };
    let mut reader = csv::ReaderBuilder::new()
        .delimiter(delimiter)
        .flexible(true)
        .trim(csv::Trim::All)
        .comment(Some(b'#'))
        .from_reader(text.as_bytes());
    let header: Vec<String> = reader
        .headers()
        .map_err(|e| format!("not a truth file: {e}"))?
        .iter()
        .map(str::to_string)
        .collect();
    let at: Vec<Option<Column>> = header.iter().map(|h| column(h)).collect();
    let find = |c: Column| at.iter().position(|&x| x == Some(c));
    let (Some(start), Some(end), Some(azimuth)) = (
        find(Column::Start),
        find(Column::End),
        find(Column::Azimuth),
    ) else {
        return Err(format!(
            "not a truth file: a JSON truth, a label file, or CSV whose header names a start, an end and an azimuth column (`{CSV_HEADER}`; start/begin/onset, end/stop/offset, azimuth/az/doa, elevation/el and source/name/label/speaker are understood, with or without units) is needed; the first line is `{}`",
            quoted_text(first)
        ));
    };
    let (source, elevation) = (find(Column::Source), find(Column::Elevation));
    let (end_azimuth, end_elevation) = (find(Column::EndAzimuth), find(Column::EndElevation));
    let mut pieces = Vec::new();
    for (i, record) in reader.records().enumerate() {
        let record = match record {
            Ok(r) => r,
            Err(e) => {
                problems.push((i + 2, e.to_string()));
                continue;
            }
        };
        let line = record.position().map_or(i + 2, |p| p.line() as usize);
        let field = |k: Option<usize>| k.and_then(|k| record.get(k)).filter(|v| !v.is_empty());
        let times = (
            field(Some(start)).and_then(|v| seconds(v, decimal_comma)),
            field(Some(end)).and_then(|v| seconds(v, decimal_comma)),
        );
        let (Some(t0), Some(t1)) = times else {
            problems.push((
                line,
                "the start and the end must be times (seconds, or m:ss.s)".into(),
            ));
            continue;
        };
        let angles = [Some(azimuth), elevation, end_azimuth, end_elevation]
            .map(|k| angle(field(k), decimal_comma));
        let [Ok(Some(az)), Ok(el), Ok(az_end), Ok(el_end)] = angles else {
            problems.push((
                line,
                "the azimuth and the elevation must be numbers (degrees)".into(),
            ));
            continue;
        };
        pieces.push(Piece {
            line,
            name: field(source).map(str::to_string),
            start: t0,
            end: t1,
            from: (az, el),
            to: az_end.map(|a| (a, el_end.or(el))),
        });
    }
    Ok(pieces)
}

/// An angle in a CSV field (degrees): `None` for an empty field, `Err` for one that is
/// not a number.
fn angle(field: Option<&str>, decimal_comma: bool) -> Result<Option<f64>, ()> {
    let Some(v) = field else { return Ok(None) };
    let v = if decimal_comma {
        v.replace(',', ".")
    } else {
        v.to_string()
    };
    v.trim_start_matches('+')
        .parse::<f64>()
        .ok()
        .filter(|x| x.is_finite())
        .map(Some)
        .ok_or(())
}

/// Problems by line, each message once with the lines it is on (`lines 3-14 (12
/// lines): ...`); line 0 is the file as a whole.
fn grouped(problems: Vec<(usize, String)>) -> Vec<String> {
    let mut order: Vec<(String, Vec<usize>)> = Vec::new();
    let mut index: std::collections::HashMap<String, usize> = std::collections::HashMap::new();
    for (line, message) in problems {
        match index.get(&message) {
            Some(&k) => order[k].1.push(line),
            None => {
                index.insert(message.clone(), order.len());
                order.push((message, vec![line]));
            }
        }
    }
    order
        .into_iter()
        .map(|(message, mut lines)| {
            lines.retain(|&l| l > 0);
            lines.sort_unstable();
            lines.dedup();
            match lines.len() {
                0 => message,
                1 => format!("line {}: {message}", lines[0]),
                n => {
                    let mut runs: Vec<String> = Vec::new();
                    let mut k = 0;
                    while k < n {
                        let mut j = k;
                        while j + 1 < n && lines[j + 1] == lines[j] + 1 {
                            j += 1;
                        }
                        runs.push(if j > k {
                            format!("{}-{}", lines[k], lines[j])
                        } else {
                            lines[k].to_string()
                        });
                        k = j + 1;
                    }
                    let shown = if runs.len() > 5 {
                        format!("{}, ...", runs[..5].join(", "))
                    } else {
                        runs.join(", ")
                    };
                    format!("lines {shown} ({n} lines): {message}")
                }
            }
        })
        .collect()
}

/// The sources of labelled intervals: by name in order of appearance, or, for pieces
/// without one, by direction. A source heard from one direction is still; one whose
/// pieces give other directions, or a move within one, follows waypoints (each piece's
/// start and end). A source whose pieces give no elevation is known in azimuth only.
fn assemble(pieces: Vec<Piece>, mut problems: Vec<(usize, String)>) -> Result<Truth, String> {
    let mut groups: Vec<(Option<String>, Vec<Piece>)> = Vec::new();
    for p in pieces {
        if let Some(why) = bad_angles(p.from.0, p.from.1.unwrap_or(0.0))
            .or_else(|| p.to.and_then(|(a, e)| bad_angles(a, e.unwrap_or(0.0))))
        {
            problems.push((p.line, why));
            continue;
        }
        if !(p.start >= 0.0 && p.start < p.end) {
            problems.push((p.line, "needs 0 <= start < end".into()));
            continue;
        }
        let same = |g: &(Option<String>, Vec<Piece>)| match (&p.name, &g.0) {
            (Some(a), Some(b)) => a == b,
            (None, None) => g.1[0].from == p.from && g.1[0].to == p.to,
            _ => false,
        };
        match groups.iter_mut().find(|g| same(g)) {
            Some(g) => g.1.push(p),
            None => groups.push((p.name.clone(), vec![p])),
        }
    }
    if groups.is_empty() && problems.is_empty() {
        problems.push((0, "no interval with a direction found".into()));
    }
    let mut sources = Vec::new();
    for (i, (name, mut list)) in groups.into_iter().enumerate() {
        list.sort_by(|a, b| a.start.total_cmp(&b.start));
        let given = list
            .iter()
            .filter(|p| p.from.1.is_some() && p.to.is_none_or(|t| t.1.is_some()))
            .count();
        if given > 0 && given < list.len() {
            let label = name.clone().unwrap_or_else(|| format!("source {}", i + 1));
            for p in list.iter().filter(|p| p.from.1.is_none()) {
                problems.push((
                    p.line,
                    format!("source `{label}` has no elevation here but has one elsewhere"),
                ));
            }
            continue;
        }
        let azimuth_only = given == 0;
        let dir = |(a, e): (f64, Option<f64>)| unit_from_angles(a, e.unwrap_or(0.0));
        let first = dir(list[0].from);
        let moves = list
            .iter()
            .any(|p| p.to.is_some() || dir(p.from).angle(&first).to_degrees() > 1e-6);
        let waypoints = if moves {
            list.iter()
                .flat_map(|p| {
                    let to = p.to.unwrap_or(p.from);
                    [
                        [p.start, p.from.0, p.from.1.unwrap_or(0.0)],
                        [p.end, to.0, to.1.unwrap_or(0.0)],
                    ]
                })
                .collect()
        } else {
            Vec::new()
        };
        let active = merged(list.iter().map(|p| [p.start, p.end]).collect());
        let mut source = truth_source(i, name, first, active);
        source.waypoints = waypoints;
        source.azimuth_only = azimuth_only;
        sources.push(source);
    }
    finish(sources, None, grouped(problems))
}

/// Intervals in time order with those that touch or overlap joined (a moving source
/// written as pieces end to end is one interval).
fn merged(mut intervals: Vec<[f64; 2]>) -> Vec<[f64; 2]> {
    intervals.sort_by(|a, b| a[0].total_cmp(&b[0]));
    let mut out: Vec<[f64; 2]> = Vec::new();
    for iv in intervals {
        match out.last_mut() {
            Some(last) if iv[0] <= last[1] + 1e-9 => last[1] = last[1].max(iv[1]),
            _ => out.push(iv),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_minimal_json_form_is_read() {
        let t = parse(
            r#"{"sources": [{"azimuth_deg": 30, "elevation_deg": 10, "intervals": [[0.5, 2.0], [4.0, 6.5]]},
                            {"name": "door", "x": 0, "y": -2, "z": 0, "intervals": [[3, 3.2]]}]}"#,
        )
        .unwrap();
        assert_eq!(t.sources.len(), 2);
        assert!((t.sources[0].azimuth_deg - 30.0).abs() < 1e-9);
        assert_eq!(t.sources[0].active, vec![[0.5, 2.0], [4.0, 6.5]]);
        assert_eq!(t.sources[1].signal, "door");
        assert!((t.sources[1].azimuth_deg + 90.0).abs() < 1e-9);
        assert_eq!(t.duration_s, 6.5);
        assert_eq!(t.sample_rate, 0);
    }

    #[test]
    fn every_problem_is_listed_at_once() {
        let err = parse(
            r#"{"sources": [{"elevation_deg": 30}, {"elevation_deg": 5, "azimuth_deg": 1, "intervals": [[2, 1]], "duration_s": 3}, {"x": 1, "intervals": [[0, 1]], "colour": 3}], "seed": 1}"#,
        )
        .unwrap_err();
        for needle in [
            "unknown key `seed`",
            "source 1: give azimuth_deg and elevation_deg",
            "source 1: missing intervals",
            "source 2: intervals must be",
            "source 2: unknown key `duration_s`",
            "source 3: unknown key `colour`",
            "source 3: give azimuth_deg",
        ] {
            assert!(err.contains(needle), "{needle}: {err}");
        }
        assert!(!err.contains('\n'));
    }

    #[test]
    fn the_csv_form_is_read_one_row_per_interval() {
        let t = parse(
            "source,start_s,end_s,azimuth_deg,elevation_deg\nA,0.5,2,30,10\nB,2.5,3,-120,0\nA,4,6.5,30,10\n",
        )
        .unwrap();
        assert_eq!(t.sources.len(), 2);
        assert_eq!(t.sources[0].signal, "A");
        assert_eq!(t.sources[0].active, vec![[0.5, 2.0], [4.0, 6.5]]);
        assert_eq!(t.duration_s, 6.5);
        let err =
            parse("source,start_s,end_s,azimuth_deg,elevation_deg\nA,1,0.5,30,10\nA,x,2,30,10\n")
                .unwrap_err();
        assert!(err.contains("line 2") && err.contains("line 3"), "{err}");
        let err = parse("time,az\n1,2\n").unwrap_err();
        assert!(err.contains("the first line is `time,az`"), "{err}");
    }

    #[test]
    fn csv_as_labs_write_it_is_read() {
        // Other names, another order, units in brackets, m:ss times, a comment.
        let t = parse(
            "# talkers\nSpeaker;Onset (s);Offset (s);Azimuth [deg];Elevation [deg]\nA;0:00,5;0:02;30;10\nB;2,5;3;-120;0\n",
        )
        .unwrap();
        assert_eq!(t.sources.len(), 2);
        assert_eq!(t.sources[0].active, vec![[0.5, 2.0]]);
        assert!((t.sources[1].azimuth_deg + 120.0).abs() < 1e-9);
        let t = parse("start\tend\taz\n1:00.5\t1:02\t45\n").unwrap();
        assert_eq!(t.sources[0].active, vec![[60.5, 62.0]]);
        // Azimuth only: scored in azimuth.
        assert!(t.sources[0].azimuth_only);
        assert_eq!(t.sources[0].elevation_deg, 0.0);
        let err = parse("begin,finish,az\n1,2,3\n").unwrap_err();
        assert!(err.contains("the first line is `begin,finish,az`"), "{err}");
    }

    #[test]
    fn a_moving_source_written_in_pieces_is_one_source_with_waypoints() {
        // A walker turning 20 deg/s from 0 deg, written as 0.5 s pieces with their start
        // and end directions, then as pieces each at one direction.
        let mut csv =
            String::from("source,start_s,end_s,azimuth_deg,elevation_deg,end_azimuth_deg\n");
        for k in 0..8 {
            let t = 1.0 + 0.5 * k as f64;
            csv += &format!(
                "walker,{t},{},{},5,{}\n",
                t + 0.5,
                10.0 * k as f64,
                10.0 * (k + 1) as f64
            );
        }
        let t = parse(&csv).unwrap();
        assert_eq!(t.sources.len(), 1);
        let s = &t.sources[0];
        assert_eq!(s.active, vec![[1.0, 5.0]]);
        assert!(s.moves() && !s.azimuth_only);
        for time in [1.0, 1.25, 2.6, 4.99] {
            let want = crate::geometry::unit_from_angles(20.0 * (time - 1.0), 5.0);
            assert!(
                s.direction_at(time).angle(&want).to_degrees() < 1e-6,
                "{time}"
            );
        }
        // The same source at another direction on another row: it moved between them.
        let t = parse("source,start_s,end_s,azimuth_deg,elevation_deg\nA,0,1,10,0\nA,2,3,50,0\n")
            .unwrap();
        assert_eq!(t.sources.len(), 1);
        assert!(
            (crate::geometry::angles_deg(&t.sources[0].direction_at(2.5)).0 - 50.0).abs() < 1e-9
        );
        assert_eq!(t.sources[0].active, vec![[0.0, 1.0], [2.0, 3.0]]);
    }

    #[test]
    fn json_takes_turns_waypoints_and_azimuths_alone() {
        let t = parse(
            r#"{"sources": [{"azimuth_deg": 0, "elevation_deg": 0, "intervals": [[1, 3]], "turn_deg_per_s": 30},
                            {"path": [[0, 90], [2, 120]], "intervals": [[0, 2]]},
                            {"azimuth_deg": -45, "intervals": [[0, 1]]}]}"#,
        )
        .unwrap();
        let a = crate::geometry::angles_deg(&t.sources[0].direction_at(2.0)).0;
        assert!((a - 30.0).abs() < 1e-9, "{a}");
        let b = crate::geometry::angles_deg(&t.sources[1].direction_at(1.0)).0;
        assert!((b - 105.0).abs() < 1e-9, "{b}");
        assert!(t.sources[1].azimuth_only && t.sources[2].azimuth_only);
        assert!(!t.sources[0].azimuth_only);
        let err = parse(r#"{"sources": [{"path": [[2, 0], [1, 5]], "intervals": [[0, 2]]}]}"#)
            .unwrap_err();
        assert!(err.contains("in time order"), "{err}");
    }

    #[test]
    fn a_mistake_on_many_lines_is_named_once_with_its_lines() {
        let mut csv = String::from("source,start_s,end_s,azimuth_deg,elevation_deg\n");
        for k in 0..12 {
            csv += &format!("A,{k},{},x,0\n", k + 1);
        }
        csv += "B,1,0.5,3,0\n";
        let err = parse(&csv).unwrap_err();
        assert_eq!(err.matches("must be numbers").count(), 1, "{err}");
        assert!(err.contains("lines 2-13 (12 lines)"), "{err}");
        assert!(err.contains("line 14: needs 0 <= start < end"), "{err}");
    }
}
