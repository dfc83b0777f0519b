//! Reading records back: detections in any of the three formats, and truth files.

use super::{DetectionRecord, EventRecord, Truth};
use crate::stream::{io_reason, read_text};
use serde_json::Value;
use std::io::{BufRead, BufReader, Read};
use std::path::{Path, PathBuf};

/// Why a result or truth file could not be read.
#[derive(Debug, thiserror::Error)]
pub enum ReadError {
    /// The file could not be read.
    #[error("{}: cannot read: {}", path.display(), io_reason(error))]
    Io {
        /// The file.
        path: PathBuf,
        /// Why.
        error: std::io::Error,
    },
    /// The text is not what the tool writes.
    #[error("{}{message}", path.as_ref().map(|p| format!("{}: ", p.display())).unwrap_or_default())]
    Format {
        /// The file, when reading one.
        path: Option<PathBuf>,
        /// What is wrong, and where.
        message: String,
    },
}

fn format_error(message: String) -> ReadError {
    ReadError::Format {
        path: None,
        message,
    }
}

/// `e` in the file `path` (`-`: `<stdin>`), unless it names its file already.
fn in_file(path: &Path, e: ReadError) -> ReadError {
    match e {
        ReadError::Format {
            message,
            path: None,
        } => ReadError::Format {
            path: Some(if path == Path::new("-") {
                PathBuf::from("<stdin>")
            } else {
                path.to_path_buf()
            }),
            message,
        },
        other => other,
    }
}

/// The largest result file read (about ten million detections).
pub(crate) const MAX_RESULT_BYTES: u64 = 1 << 30;
/// The largest truth file read.
pub(crate) const MAX_TRUTH_BYTES: u64 = 64 << 20;

fn read_file(path: &Path, limit: u64) -> Result<String, ReadError> {
    read_text(path, limit).map_err(|error| ReadError::Io {
        path: path.to_path_buf(),
        error,
    })
}

/// One record of a result, as read.
#[derive(Debug, Clone)]
pub enum ResultRecord {
    /// A row of detections.
    Detection(DetectionRecord),
    /// A row of `--events`.
    Event(EventRecord),
}

/// What a result says besides its records: a JSON document's `geometry` and
/// `parameters` (`None` in CSV and NDJSON), and how many records of each kind it held.
#[derive(Debug, Clone, Default)]
pub struct ResultInfo {
    /// The document's `geometry` object.
    pub geometry: Option<Value>,
    /// The document's `parameters` object.
    pub parameters: Option<Value>,
    /// Detections read.
    pub detections: u64,
    /// Events read.
    pub events: u64,
}

impl ResultInfo {
    /// The array a JSON result was made with (with its orientation), from its
    /// `geometry` object: what `ssl evaluate` and `ssl plot` score by.
    pub fn array(&self) -> Option<crate::Geometry> {
        array_of(self.geometry.as_ref()?)
    }
}

/// The array a result's `geometry` object (a JSON result's, or a batch stamp's) names,
/// with its orientation.
pub(crate) fn array_of(geometry: &Value) -> Option<crate::Geometry> {
    {
        let g = serde_json::from_value::<super::GeometryInfo>(geometry.clone()).ok()?;
        let positions: Vec<[f64; 3]> = g.mics.iter().map(|m| m.position).collect();
        let geometry = crate::Geometry::from_positions(&positions).ok()?;
        Some(match g.orientation {
            Some(rows) => geometry.oriented(nalgebra::Matrix3::from_fn(|i, j| rows[i][j])),
            None => geometry,
        })
    }
}

/// Reads a result of `ssl analyze` in any of its three formats (CSV of detections or of
/// events, NDJSON, one JSON document), record by record: `each` gets every record in
/// order as it is read, so a result of any size is read in the memory its caller keeps.
/// A UTF-8 byte order mark is skipped. What `ssl analyze` does not write is an error
/// with its position: an empty input, text that is not a result, a malformed record, a
/// number that is not finite. The input is read up to `MAX_RESULT_BYTES`.
/// `each` may refuse a record with a message, which becomes the error.
pub fn read_result(
    input: impl Read,
    mut each: impl FnMut(ResultRecord) -> Result<(), String>,
) -> Result<ResultInfo, ReadError> {
    let input = NoBoms::new(Limited(input.take(MAX_RESULT_BYTES + 1)));
    let mut input = BufReader::with_capacity(1 << 16, input);
    let first = first_byte(&mut input).map_err(|e| format_error(io_reason(&e)))?;
    let mut info = ResultInfo::default();
    match first {
        None => Err(format_error(
            "empty: not a result of ssl analyze (an NDJSON result with no detections is empty; CSV and JSON keep a header)".into(),
        )),
        Some(b'{') => {
            let mut de = serde_json::Deserializer::from_reader(input);
            loop {
                let seed = TopSeed {
                    each: &mut each,
                    info: &mut info,
                };
                serde::de::DeserializeSeed::deserialize(seed, &mut de).map_err(json_error)?;
                if de.end().is_ok() {
                    return Ok(info);
                }
            }
        }
        Some(_) => {
            read_csv(input, &mut info, &mut each)?;
            Ok(info)
        }
    }
}

/// Reads a result file, or standard input for `-` (see [`read_result`]).
pub fn read_result_file(
    path: &Path,
    each: impl FnMut(ResultRecord) -> Result<(), String>,
) -> Result<ResultInfo, ReadError> {
    let result = if path == Path::new("-") {
        read_result(std::io::stdin().lock(), each)
    } else {
        let file = std::fs::File::open(path).map_err(|error| ReadError::Io {
            path: path.to_path_buf(),
            error,
        })?;
        read_result(file, each)
    };
    result.map_err(|e| in_file(path, e))
}

/// Reads the detections of a CSV, NDJSON or JSON result of `ssl analyze` (`-` is
/// standard input). Events are left out; a result that holds only events is an error.
#[doc(hidden)]
pub fn read_detections(path: &Path) -> Result<Vec<DetectionRecord>, ReadError> {
    read_detections_with_info(path).map(|(rows, _)| rows)
}

/// As [`read_detections`], with what the result says besides its records (a JSON
/// document's geometry and parameters).
fn read_detections_with_info(path: &Path) -> Result<(Vec<DetectionRecord>, ResultInfo), ReadError> {
    detections(|each| read_result_file(path, each)).map_err(|e| in_file(path, e))
}

/// A result's detections and events, with what it says besides (for `ssl evaluate`,
/// which scores the events the run wrote when it holds them). A result of events only
/// is read too.
pub fn read_records_with_info(
    path: &Path,
) -> Result<(Vec<DetectionRecord>, Vec<EventRecord>, ResultInfo), ReadError> {
    let (mut rows, mut events) = (Vec::new(), Vec::new());
    let info = read_result_file(path, |r| {
        match r {
            ResultRecord::Detection(d) => rows.push(d),
            ResultRecord::Event(e) => events.push(e),
        }
        Ok(())
    })
    .map_err(|e| in_file(path, e))?;
    Ok((rows, events, info))
}

/// Parses detections from the text of a CSV, NDJSON or JSON result (see
/// [`read_detections`]).
#[doc(hidden)]
pub fn parse_detections(text: &str) -> Result<Vec<DetectionRecord>, ReadError> {
    detections(|each| read_result(text.as_bytes(), each)).map(|(rows, _)| rows)
}

/// The detections `read` hands over; a result of events only is an error.
fn detections(
    read: impl FnOnce(
        &mut dyn FnMut(ResultRecord) -> Result<(), String>,
    ) -> Result<ResultInfo, ReadError>,
) -> Result<(Vec<DetectionRecord>, ResultInfo), ReadError> {
    let mut rows = Vec::new();
    let info = read(&mut |r| {
        if let ResultRecord::Detection(d) = r {
            rows.push(d);
        }
        Ok(())
    })?;
    if info.detections == 0 && info.events > 0 {
        return Err(format_error(
            "holds events (--events) but no detections: analyse without --events to score or read its rows".into(),
        ));
    }
    Ok((rows, info))
}

/// A reader that drops a UTF-8 byte order mark at the start of any line: results
/// concatenated (`cat a.csv b.csv`) each keep the mark an editor saved them with.
struct NoBoms<R> {
    inner: R,
    /// Whether the next byte starts a line.
    line_start: bool,
    /// Bytes of a mark seen so far at a line's start (at most 2).
    held: Vec<u8>,
    /// Bytes read, not yet handed on.
    buf: Vec<u8>,
    at: usize,
}

const BOM: &[u8; 3] = b"\xEF\xBB\xBF";

impl<R: Read> NoBoms<R> {
    fn new(inner: R) -> Self {
        NoBoms {
            inner,
            line_start: true,
            held: Vec::new(),
            buf: Vec::new(),
            at: 0,
        }
    }
}

impl<R: Read> Read for NoBoms<R> {
    fn read(&mut self, out: &mut [u8]) -> std::io::Result<usize> {
        while self.at == self.buf.len() {
            let mut raw = [0u8; 1 << 14];
            let n = self.inner.read(&mut raw)?;
            self.buf.clear();
            self.at = 0;
            if n == 0 {
                // A line that ended in part of a mark: those bytes are text.
                self.buf.append(&mut self.held);
                if self.buf.is_empty() {
                    return Ok(0);
                }
                break;
            }
            for &b in &raw[..n] {
                if self.line_start && b == BOM[self.held.len()] {
                    self.held.push(b);
                    if self.held.len() == 3 {
                        self.held.clear();
                        self.line_start = false;
                    }
                    continue;
                }
                self.buf.append(&mut self.held);
                self.buf.push(b);
                self.line_start = b == b'\n';
            }
        }
        let n = out.len().min(self.buf.len() - self.at);
        out[..n].copy_from_slice(&self.buf[self.at..self.at + n]);
        self.at += n;
        Ok(n)
    }
}

/// A reader that fails past `MAX_RESULT_BYTES` instead of reading on.
struct Limited<R>(std::io::Take<R>);

impl<R: Read> Read for Limited<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.0.read(buf)?;
        if self.0.limit() == 0 {
            return Err(std::io::Error::new(
                std::io::ErrorKind::FileTooLarge,
                format!("longer than {MAX_RESULT_BYTES} bytes"),
            ));
        }
        Ok(n)
    }
}

/// Skips a byte order mark and leading white space; the first byte after them.
fn first_byte(input: &mut impl BufRead) -> std::io::Result<Option<u8>> {
    loop {
        let buf = input.fill_buf()?;
        if buf.is_empty() {
            return Ok(None);
        }
        match buf.iter().position(|b| !b.is_ascii_whitespace()) {
            Some(i) => return Ok(Some(buf[i])),
            // A buffer of nothing but white space: on to the next.
            None => {
                let n = buf.len();
                input.consume(n);
            }
        }
    }
}

fn json_error(e: serde_json::Error) -> ReadError {
    if e.is_io() {
        return format_error(format!("cannot read: {e}"));
    }
    format_error(e.to_string())
}

/// The CSV of detections (`time_s,...`) or of events (`file,source,start_s,...`), row by
/// row.
fn read_csv(
    input: impl Read,
    info: &mut ResultInfo,
    each: &mut impl FnMut(ResultRecord) -> Result<(), String>,
) -> Result<(), ReadError> {
    let mut reader = csv::Reader::from_reader(input);
    let not_result = |first: String| {
        format_error(format!(
            "not a result of ssl analyze: its first line is {first:?}, not a CSV header of detections or events"
        ))
    };
    let headers = match reader.byte_headers() {
        Ok(h) => h.clone(),
        Err(e) if e.is_io_error() => return Err(format_error(format!("cannot read: {e}"))),
        Err(_) => return Err(not_result(String::new())),
    };
    let first = String::from_utf8_lossy(&headers.as_slice()[..headers.as_slice().len().min(60)])
        .into_owned();
    let events = headers.get(0) == Some(b"file")
        && headers.get(1) == Some(b"source")
        && headers.get(2) == Some(b"start_s");
    if !events && headers.get(0) != Some(b"time_s") {
        let shown: Vec<String> = headers
            .iter()
            .map(|f| String::from_utf8_lossy(f).into_owned())
            .collect();
        return Err(not_result(if shown.is_empty() {
            first
        } else {
            shown.join(",").chars().take(60).collect()
        }));
    }
    let mut row = csv::ByteRecord::new();
    let mut n = 0u64;
    loop {
        match reader.read_byte_record(&mut row) {
            Ok(false) => return Ok(()),
            Ok(true) => {}
            Err(e) => return Err(format_error(format!("row {}: {e}", n + 1))),
        }
        n += 1;
        // Results concatenated (`cat a.csv b.csv`): the header again.
        if row == headers {
            continue;
        }
        let line = row.position().map_or(n + 1, |p| p.line());
        let at = |e: String| format_error(format!("row {n} (line {line}): {e}"));
        let record = if events {
            ResultRecord::Event(
                row.deserialize(Some(&headers))
                    .map_err(|e| at(e.to_string()))?,
            )
        } else {
            ResultRecord::Detection(
                row.deserialize(Some(&headers))
                    .map_err(|e| at(e.to_string()))?,
            )
        };
        accept(record, info, each).map_err(at)?;
    }
}

/// Counts a record and hands it over, refusing one with a number that is not finite.
fn accept(
    record: ResultRecord,
    info: &mut ResultInfo,
    each: &mut impl FnMut(ResultRecord) -> Result<(), String>,
) -> Result<(), String> {
    match &record {
        ResultRecord::Detection(d) => {
            if let Some(field) = d.non_finite() {
                return Err(format!("a detection's {field} is not a finite number"));
            }
            info.detections += 1;
        }
        ResultRecord::Event(e) => {
            if let Some(field) = e.non_finite() {
                return Err(format!("an event's {field} is not a finite number"));
            }
            info.events += 1;
        }
    }
    each(record)
}

/// A top-level JSON object: a document (`detections` and `events` are streamed, the
/// rest kept) or one NDJSON record.
struct TopSeed<'a, F> {
    each: &'a mut F,
    info: &'a mut ResultInfo,
}

impl<'de, F: FnMut(ResultRecord) -> Result<(), String>> serde::de::DeserializeSeed<'de>
    for TopSeed<'_, F>
{
    type Value = ();

    fn deserialize<D: serde::Deserializer<'de>>(self, d: D) -> Result<(), D::Error> {
        d.deserialize_map(self)
    }
}

impl<'de, F: FnMut(ResultRecord) -> Result<(), String>> serde::de::Visitor<'de> for TopSeed<'_, F> {
    type Value = ();

    fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str("a result of ssl analyze: a JSON document, or NDJSON records")
    }

    fn visit_map<A: serde::de::MapAccess<'de>>(self, mut map: A) -> Result<(), A::Error> {
        use serde::de::Error;
        let mut fields = serde_json::Map::new();
        let mut document = false;
        while let Some(key) = map.next_key::<String>()? {
            let kind = match key.as_str() {
                "detections" => Kind::Detection,
                "events" => Kind::Event,
                _ => {
                    let value: Value = map.next_value()?;
                    fields.insert(key, value);
                    continue;
                }
            };
            let seed = ListSeed {
                kind,
                each: &mut *self.each,
                info: &mut *self.info,
            };
            match map.next_value_seed(seed)? {
                // A document's list, streamed.
                None => document = true,
                // An event's count of detections.
                Some(count) => {
                    fields.insert(key, Value::from(count));
                }
            }
        }
        if document {
            self.info.geometry = fields.remove("geometry");
            self.info.parameters = fields.remove("parameters");
            return Ok(());
        }
        let record = if fields.contains_key("time_s") {
            ResultRecord::Detection(
                serde_json::from_value(Value::Object(fields)).map_err(A::Error::custom)?,
            )
        } else if fields.contains_key("start_s") {
            ResultRecord::Event(
                serde_json::from_value(Value::Object(fields)).map_err(A::Error::custom)?,
            )
        } else {
            return Err(A::Error::custom(
                "an object that is not a result of ssl analyze (no `detections`, `time_s` or `start_s`)",
            ));
        };
        accept(record, self.info, self.each).map_err(A::Error::custom)
    }
}

#[derive(Clone, Copy)]
enum Kind {
    Detection,
    Event,
}

/// A document's `detections` or `events` list, each element handed over as it is read;
/// or an event record's `detections` count.
struct ListSeed<'a, F> {
    kind: Kind,
    each: &'a mut F,
    info: &'a mut ResultInfo,
}

impl<'de, F: FnMut(ResultRecord) -> Result<(), String>> serde::de::DeserializeSeed<'de>
    for ListSeed<'_, F>
{
    type Value = Option<u64>;

    fn deserialize<D: serde::Deserializer<'de>>(self, d: D) -> Result<Option<u64>, D::Error> {
        d.deserialize_any(self)
    }
}

impl<'de, F: FnMut(ResultRecord) -> Result<(), String>> serde::de::Visitor<'de>
    for ListSeed<'_, F>
{
    type Value = Option<u64>;

    fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str("a list of records (or an event's count of detections)")
    }

    fn visit_u64<E: serde::de::Error>(self, v: u64) -> Result<Option<u64>, E> {
        Ok(Some(v))
    }

    fn visit_seq<A: serde::de::SeqAccess<'de>>(self, mut seq: A) -> Result<Option<u64>, A::Error> {
        use serde::de::Error;
        let (list, mut k) = (
            match self.kind {
                Kind::Detection => "detections",
                Kind::Event => "events",
            },
            0usize,
        );
        loop {
            let record = match self.kind {
                Kind::Detection => seq.next_element()?.map(ResultRecord::Detection),
                Kind::Event => seq.next_element()?.map(ResultRecord::Event),
            };
            let Some(record) = record else {
                return Ok(None);
            };
            accept(record, self.info, self.each)
                .map_err(|e| A::Error::custom(format!("`{list}`[{k}]: {e}")))?;
            k += 1;
        }
    }
}

impl Truth {
    /// Reads a truth file: what `ssl simulate` writes, or a hand-written one (the
    /// minimal JSON or the CSV form of docs/interface.md).
    pub fn from_file(path: &Path) -> Result<Self, ReadError> {
        Self::from_text(&read_file(path, MAX_TRUTH_BYTES)?).map_err(|e| in_file(path, e))
    }

    /// Parses a truth file's text, in any of the forms [`Truth::from_file`] reads; a
    /// hand-written one's problems are listed all at once.
    pub fn from_text(text: &str) -> Result<Self, ReadError> {
        super::truth_forms::parse(text).map_err(format_error)
    }

    /// Parses a truth in JSON (either JSON form of [`Truth::from_text`]).
    pub fn from_json(text: &str) -> Result<Self, ReadError> {
        Self::from_text(text)
    }
}
