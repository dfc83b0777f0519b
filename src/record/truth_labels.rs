//! Hand-written truth as labels: times as labs write them, directions written in a
//! label, and the label files of Audacity, Praat and ELAN (docs/guide.md, "Scoring
//! against your own truth"). Each file becomes [`Piece`]s, one per labelled interval,
//! that `truth_forms` assembles into sources.

/// One labelled interval: a source (by name, if the file names it) sounding from
/// `start` to `end` seconds from one direction, or moving from one to another.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Piece {
    /// The line of the file it comes from (1-based).
    pub line: usize,
    /// The source's name, if the file gives one.
    pub name: Option<String>,
    pub start: f64,
    pub end: f64,
    /// Azimuth and, if given, elevation (degrees) at `start`.
    pub from: (f64, Option<f64>),
    /// The same at `end`, for a source that moves over the interval.
    pub to: Option<(f64, Option<f64>)>,
}

/// Seconds from a time as labs write them: `12.5`, `1:02.5` (m:ss.s) or `1:02:03.5`
/// (h:mm:ss.s); with `decimal_comma`, `12,5` too. `None` for anything else, a negative
/// time, or minutes or seconds of 60 or more after a colon.
pub(super) fn seconds(text: &str, decimal_comma: bool) -> Option<f64> {
    let text = text.trim();
    let text = if decimal_comma {
        std::borrow::Cow::Owned(text.replace(',', "."))
    } else {
        std::borrow::Cow::Borrowed(text)
    };
    let parts: Vec<&str> = text.split(':').collect();
    if parts.len() > 3 || parts.iter().any(|p| p.is_empty()) {
        return None;
    }
    let last: f64 = parts[parts.len() - 1].parse().ok()?;
    if !last.is_finite() || last < 0.0 || parts.len() > 1 && last >= 60.0 {
        return None;
    }
    let mut total = 0.0;
    for (k, p) in parts[..parts.len() - 1].iter().enumerate() {
        let v: u64 = p.parse().ok()?;
        if k > 0 && v >= 60 {
            return None;
        }
        total = total * 60.0 + v as f64;
    }
    Some(if parts.len() > 1 {
        total * 60.0 + last
    } else {
        last
    })
}

/// A number as a label writes it (`30`, `-12.5`, `+15`).
fn number(text: &str) -> Option<f64> {
    text.trim_start_matches('+')
        .parse::<f64>()
        .ok()
        .filter(|v| v.is_finite())
}

/// A direction token: `AZ`, `AZ/EL`, or `AZ,EL`.
fn direction(token: &str) -> Option<(f64, Option<f64>)> {
    match token.split_once(['/', ',']) {
        Some((az, el)) => Some((number(az)?, Some(number(el)?))),
        None => Some((number(token)?, None)),
    }
}

/// A label's name, and its direction with, for a move, the direction at the end.
pub(super) type Said = (
    Option<String>,
    Option<((f64, Option<f64>), Option<(f64, Option<f64>)>)>,
);

/// What a label says: a name, then the direction (`AZ` or `AZ/EL`, degrees), or two
/// joined by `->` for a source that moves over the interval; `az=`, `el=` may name the
/// angles. `"talker A 30/10"` is `talker A` from azimuth 30, elevation 10; `"door -90"`
/// the door from azimuth -90 (no elevation); `"walker 0/0 -> 45/0"` a walker turning
/// from 0 to 45 deg.
pub(super) fn label(text: &str) -> Said {
    // `az=30 el=10` as `30/10`.
    let mut tokens: Vec<String> = Vec::new();
    for t in text.split_whitespace() {
        let lower = t.to_ascii_lowercase();
        if let Some(v) = lower
            .strip_prefix("el=")
            .or_else(|| lower.strip_prefix("elevation="))
        {
            match tokens.last_mut() {
                Some(last) if direction(last).is_some_and(|d| d.1.is_none()) => {
                    *last = format!("{last}/{v}");
                }
                _ => tokens.push(format!("el={v}")),
            }
        } else if let Some(v) = lower
            .strip_prefix("az=")
            .or_else(|| lower.strip_prefix("azimuth="))
        {
            tokens.push(v.to_string());
        } else if t == "\u{2192}" {
            tokens.push("->".into());
        } else {
            tokens.push(t.to_string());
        }
    }
    let name_of = |rest: &[String]| (!rest.is_empty()).then(|| rest.join(" "));
    let n = tokens.len();
    if n >= 3 && tokens[n - 2] == "->" {
        if let (Some(a), Some(b)) = (direction(&tokens[n - 3]), direction(&tokens[n - 1])) {
            return (name_of(&tokens[..n - 3]), Some((a, Some(b))));
        }
    }
    if let Some(d) = tokens.last().and_then(|t| direction(t)) {
        return (name_of(&tokens[..n - 1]), Some((d, None)));
    }
    (name_of(&tokens), None)
}

/// Whether `text` looks like a label file: its first line tab-separated, with two
/// times among its fields (Audacity's label track: `start<TAB>end<TAB>label`; ELAN's
/// tab-delimited export: tier, times, annotation).
pub(super) fn is_label_file(text: &str) -> bool {
    let Some(first) = text.lines().find(|l| !l.trim().is_empty()) else {
        return false;
    };
    first.contains('\t')
        && first
            .split('\t')
            .filter(|f| seconds(f, false).is_some())
            .count()
            >= 2
}

/// The pieces of a label file (see [`is_label_file`]): on each line, the first two
/// distinct times are the start and the end (ELAN may write each time twice, as
/// h:mm:ss.ms and as seconds, and a duration after them); the last other field is the
/// label, and the first, when there are two or more, the tier, which names the source
/// when the label does not. Audacity's spectral lines (`\` first) are skipped.
pub(super) fn from_label_file(text: &str, problems: &mut Vec<(usize, String)>) -> Vec<Piece> {
    let mut pieces = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let line_no = i + 1;
        if line.trim().is_empty() || line.starts_with('\\') {
            continue;
        }
        let mut times: Vec<f64> = Vec::new();
        let mut texts: Vec<&str> = Vec::new();
        for f in line.split('\t') {
            match seconds(f, false) {
                Some(t) if times.len() < 2 && times.last() != Some(&t) => times.push(t),
                Some(_) => {}
                None if !f.trim().is_empty() => texts.push(f.trim()),
                None => {}
            }
        }
        let [start, end] = times[..] else {
            problems.push((line_no, "needs a start and an end time".into()));
            continue;
        };
        let tier = (texts.len() >= 2).then(|| label(texts[0]));
        let (mut name, mut said) = label(texts.last().copied().unwrap_or(""));
        if said.is_none() {
            // The tier names the source and its direction; the annotation is a word.
            if let Some((tier_name, tier_said)) = tier.clone() {
                (name, said) = (tier_name, tier_said);
            }
        } else if name.is_none() {
            name = tier.and_then(|t| t.0);
        }
        let Some((from, to)) = said else {
            problems.push((
                line_no,
                "the label names no direction (write it as `NAME AZ/EL`, `NAME AZ`, or `AZ/EL -> AZ/EL` for a move)".into(),
            ));
            continue;
        };
        pieces.push(Piece {
            line: line_no,
            name,
            start,
            end,
            from,
            to,
        });
    }
    pieces
}

/// Whether `text` is a Praat TextGrid.
pub(super) fn is_textgrid(text: &str) -> bool {
    text.lines()
        .take(3)
        .any(|l| l.contains("ooTextFile") || l.contains("\"TextGrid\""))
}

/// The pieces of a Praat TextGrid in its long text form: every interval with a
/// non-empty text, on any interval tier; the direction from the text, else from the
/// tier's name, and the source named by the text, else by the tier.
pub(super) fn from_textgrid(text: &str, problems: &mut Vec<(usize, String)>) -> Vec<Piece> {
    let value = |line: &str| -> Option<String> {
        let (_, v) = line.split_once('=')?;
        let v = v.trim();
        Some(
            v.strip_prefix('"')
                .and_then(|v| v.strip_suffix('"'))
                .map_or_else(|| v.to_string(), |v| v.replace("\"\"", "\"")),
        )
    };
    let mut pieces = Vec::new();
    let mut tier: Option<String> = None;
    let mut in_interval = false;
    let (mut xmin, mut xmax) = (None, None);
    let mut intervals = 0;
    for (i, raw) in text.lines().enumerate() {
        let line = raw.trim();
        if line.starts_with("item [") {
            tier = None;
            in_interval = false;
        } else if line.starts_with("name =") && !in_interval {
            tier = value(line);
        } else if line.starts_with("intervals [") {
            in_interval = true;
            (xmin, xmax) = (None, None);
        } else if line.starts_with("points [") {
            in_interval = false;
        } else if in_interval && line.starts_with("xmin =") {
            xmin = value(line).and_then(|v| seconds(&v, false));
        } else if in_interval && line.starts_with("xmax =") {
            xmax = value(line).and_then(|v| seconds(&v, false));
        } else if in_interval && line.starts_with("text =") {
            in_interval = false;
            intervals += 1;
            let text = value(line).unwrap_or_default();
            if text.trim().is_empty() {
                continue;
            }
            let (Some(start), Some(end)) = (xmin, xmax) else {
                problems.push((i + 1, "an interval without xmin and xmax".into()));
                continue;
            };
            let (name, said) = label(&text);
            let from_tier = tier.as_deref().map(label);
            let Some((from, to)) = said.or_else(|| from_tier.as_ref().and_then(|t| t.1)) else {
                problems.push((
                    i + 1,
                    format!("the interval's text `{text}` names no direction, nor does its tier"),
                ));
                continue;
            };
            let tier_name = from_tier.and_then(|t| t.0).or(tier.clone());
            pieces.push(Piece {
                line: i + 1,
                name: name.filter(|_| said.is_some()).or(tier_name).or(Some(text)),
                start,
                end,
                from,
                to,
            });
        }
    }
    if intervals == 0 {
        problems.push((
            0,
            "no interval found (a TextGrid in Praat's long text form, \"Save as text file\", is needed)"
                .into(),
        ));
    }
    pieces
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn times_are_read_as_labs_write_them() {
        assert_eq!(seconds("12.5", false), Some(12.5));
        assert_eq!(seconds("1:02.5", false), Some(62.5));
        assert_eq!(seconds("1:02:03.5", false), Some(3723.5));
        assert_eq!(seconds("0:00:01.250", false), Some(1.25));
        assert_eq!(seconds("12,5", true), Some(12.5));
        assert_eq!(seconds("12,5", false), None);
        assert_eq!(seconds("1:75", false), None);
        assert_eq!(seconds("-1", false), None);
        assert_eq!(seconds("talker", false), None);
    }

    #[test]
    fn a_label_gives_a_name_and_a_direction() {
        assert_eq!(
            label("talker A 30/10"),
            (Some("talker A".into()), Some(((30.0, Some(10.0)), None)))
        );
        assert_eq!(
            label("door -90"),
            (Some("door".into()), Some(((-90.0, None), None)))
        );
        assert_eq!(label("+45"), (None, Some(((45.0, None), None))));
        assert_eq!(
            label("B az=30 el=-5"),
            (Some("B".into()), Some(((30.0, Some(-5.0)), None)))
        );
        assert_eq!(
            label("walker 0/0 -> 45/10"),
            (
                Some("walker".into()),
                Some(((0.0, Some(0.0)), Some((45.0, Some(10.0)))))
            )
        );
        assert_eq!(label("speech"), (Some("speech".into()), None));
    }

    #[test]
    fn audacity_and_elan_label_files_are_read() {
        let mut problems = Vec::new();
        // Audacity: start, end, label; a spectral line skipped.
        let audacity = "0.500000\t2.000000\tA 30/10\n\\\t100.0\t3000.0\n4.000000\t6.500000\tA 30/10\n2.5\t3\tdoor -90\n";
        assert!(is_label_file(audacity));
        let pieces = from_label_file(audacity, &mut problems);
        assert!(problems.is_empty(), "{problems:?}");
        assert_eq!(pieces.len(), 3);
        assert_eq!(
            (pieces[1].start, pieces[1].end, pieces[1].line),
            (4.0, 6.5, 3)
        );
        assert_eq!(pieces[2].name.as_deref(), Some("door"));
        // ELAN: tier, begin (h:mm:ss.ms and seconds), end (both), duration, annotation
        // with the direction; or the direction in the tier's name.
        let elan = "talker A\t\t00:00:01.500\t1.5\t00:00:02.250\t2.25\t0.75\t30/0\n\
                    B 120/5\t\t00:00:03.000\t3.0\t00:00:04.000\t4.0\t1.0\tyes\n\
                    C\t\t00:00:05.000\t5.0\t00:00:06.000\t6.0\t1.0\tno direction\n";
        assert!(is_label_file(elan));
        let pieces = from_label_file(elan, &mut problems);
        assert_eq!(pieces.len(), 2, "{pieces:?}");
        assert_eq!((pieces[0].start, pieces[0].end), (1.5, 2.25));
        assert_eq!(pieces[0].name.as_deref(), Some("talker A"));
        assert_eq!(pieces[1].name.as_deref(), Some("B"));
        assert_eq!(pieces[1].from, (120.0, Some(5.0)));
        assert_eq!(problems.len(), 1);
        assert_eq!(problems[0].0, 3);
    }

    #[test]
    fn a_textgrid_is_read_by_tier() {
        let grid = "File type = \"ooTextFile\"\nObject class = \"TextGrid\"\n\nxmin = 0\nxmax = 8\ntiers? <exists>\nsize = 2\nitem []:\n\
            item [1]:\n class = \"IntervalTier\"\n name = \"A 30/10\"\n xmin = 0\n xmax = 8\n intervals: size = 3\n\
             intervals [1]:\n  xmin = 0\n  xmax = 0.5\n  text = \"\"\n\
             intervals [2]:\n  xmin = 0.5\n  xmax = 2\n  text = \"hello\"\n\
             intervals [3]:\n  xmin = 2\n  xmax = 8\n  text = \"\"\n\
            item [2]:\n class = \"IntervalTier\"\n name = \"events\"\n xmin = 0\n xmax = 8\n intervals: size = 1\n\
             intervals [1]:\n  xmin = 3\n  xmax = 3.2\n  text = \"door -90/0\"\n";
        assert!(is_textgrid(grid));
        let mut problems = Vec::new();
        let pieces = from_textgrid(grid, &mut problems);
        assert!(problems.is_empty(), "{problems:?}");
        assert_eq!(pieces.len(), 2);
        assert_eq!(pieces[0].name.as_deref(), Some("A"));
        assert_eq!((pieces[0].start, pieces[0].end), (0.5, 2.0));
        assert_eq!(pieces[0].from, (30.0, Some(10.0)));
        assert_eq!(pieces[1].name.as_deref(), Some("door"));
        assert_eq!(pieces[1].from, (-90.0, Some(0.0)));
    }
}
