//! A measured setup's ground truth, written by hand (docs/interface.md, "Ground truth of
//! a measured setup"): the minimal JSON form
//! `{"sources": [{"azimuth_deg": 30, "elevation_deg": 10, "intervals": [[0.5, 2.0]]}]}`
//! (optional `name`, `x`/`y`/`z` instead of the angles, `duration_s`), or CSV with the
//! header `source,start_s,end_s,azimuth_deg,elevation_deg` (one row per interval). Both
//! become a [`Truth`] like the one `ssl simulate` writes, with what a hand cannot know
//! left unknown (no room, no sample rate). Every problem is listed at once.

use super::truth::{Truth, TruthArray, TruthSource};
use crate::geometry::{angles_deg, unit_from_angles};
use nalgebra::Vector3;
use serde_json::{Map, Value};

/// The keys of a hand-written source.
const SOURCE_KEYS: [&str; 7] = [
    "name",
    "azimuth_deg",
    "elevation_deg",
    "x",
    "y",
    "z",
    "intervals",
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
        return from_csv(start);
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
    let direction = match (az, el, x, y, z) {
        (Some(a), Some(e), None, None, None) => match bad_angles(a, e) {
            None => Some(unit_from_angles(a, e)),
            Some(why) => {
                problems.push(format!("{at}: {why}"));
                None
            }
        },
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
                "{at}: missing its direction (azimuth_deg and elevation_deg, or x, y and z)"
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
    match (direction, intervals, problems.is_empty()) {
        (Some(u), Some(active), true) => Ok(truth_source(i, name, u, active)),
        _ => Err(problems),
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

/// The CSV form: one row per interval, sources by their label in order of appearance.
fn from_csv(text: &str) -> Result<Truth, String> {
    let mut reader = csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .from_reader(text.as_bytes());
    let header: Vec<String> = reader
        .headers()
        .map_err(|e| format!("not a truth file: {e}"))?
        .iter()
        .map(str::to_string)
        .collect();
    if header.join(",") != CSV_HEADER {
        return Err(format!(
            "not a truth file: a JSON truth, or CSV with the header `{CSV_HEADER}`, is needed; the first line is `{}`",
            quoted_text(&header.join(","))
        ));
    }
    let mut labels: Vec<String> = Vec::new();
    let mut found: Vec<(Vector3<f64>, Vec<[f64; 2]>)> = Vec::new();
    let mut problems = Vec::new();
    for (row, record) in reader.records().enumerate() {
        let line = row + 2;
        let record = match record {
            Ok(r) => r,
            Err(e) => {
                problems.push(format!("line {line}: {e}"));
                continue;
            }
        };
        let num = |k: usize| {
            record
                .get(k)
                .and_then(|v| v.parse::<f64>().ok())
                .filter(|v| v.is_finite())
        };
        let (Some(start), Some(end), Some(az), Some(el)) = (num(1), num(2), num(3), num(4)) else {
            problems.push(format!(
                "line {line}: start_s, end_s, azimuth_deg and elevation_deg must be numbers"
            ));
            continue;
        };
        if !(start >= 0.0 && start < end) {
            problems.push(format!(
                "line {line}: needs 0 <= start_s < end_s, got {start} and {end}"
            ));
            continue;
        }
        if let Some(why) = bad_angles(az, el) {
            problems.push(format!("line {line}: {why}"));
            continue;
        }
        let u = unit_from_angles(az, el);
        let label = record.get(0).unwrap_or("").to_string();
        match labels.iter().position(|l| *l == label) {
            Some(k) => {
                if found[k].0.angle(&u).to_degrees() > 1e-6 {
                    problems.push(format!(
                        "line {line}: source `{label}` has another direction than on its first row (a source that moves needs the JSON form of ssl simulate)"
                    ));
                }
                found[k].1.push([start, end]);
            }
            None => {
                labels.push(label);
                found.push((u, vec![[start, end]]));
            }
        }
    }
    if found.is_empty() && problems.is_empty() {
        problems.push("no rows after the header".into());
    }
    let sources = found
        .into_iter()
        .zip(labels)
        .enumerate()
        .map(|(i, ((u, active), label))| truth_source(i, Some(label), u, active))
        .collect();
    finish(sources, None, problems)
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
            r#"{"sources": [{"azimuth_deg": 30}, {"elevation_deg": 5, "azimuth_deg": 1, "intervals": [[2, 1]], "duration_s": 3}, {"x": 1, "intervals": [[0, 1]], "colour": 3}], "seed": 1}"#,
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
}
