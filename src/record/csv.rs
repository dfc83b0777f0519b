//! CSV: a header line from the record type's field names, then one row per record.
//!
//! Rows are written through a small serde serializer so that the columns come from the
//! record type itself. Numbers are written in Rust's shortest round-trip decimal form
//! (`0.5`, `1`, `-12.25`), never in exponent form, which every CSV reader parses.

use super::{
    DetectionRecord, EventRecord, Exporter, FileEntry, OutputError, Records, RunMetadata,
    SourceRecord,
};
use serde::ser::{self, Impossible, Serialize, SerializeStruct, Serializer};
use std::fmt::Write as _;
use std::io::Write;

/// Writes detections as CSV.
pub(crate) struct CsvExporter<W: Write> {
    out: csv::Writer<W>,
    buf: String,
    flush_each: bool,
    records: Records,
}

impl<W: Write> CsvExporter<W> {
    /// A CSV writer to `out` of `records`.
    pub fn new(out: W, records: Records) -> Self {
        CsvExporter {
            out: csv::WriterBuilder::new().from_writer(out),
            buf: String::new(),
            flush_each: false,
            records,
        }
    }

    /// Writes `record` when this writer is for `kind`.
    fn write<T: Serialize>(&mut self, kind: Records, record: &T) -> Result<(), OutputError> {
        if self.records != kind {
            return Ok(());
        }
        self.row(record)?;
        if self.flush_each {
            self.out.flush()?;
        }
        Ok(())
    }

    /// Writes the header of `template`'s columns (its field names, in order).
    fn header<T: Serialize>(&mut self, template: &T) -> Result<(), csv::Error> {
        template.serialize(&mut Row {
            out: &mut self.out,
            buf: &mut self.buf,
            header: true,
        })
    }

    /// Writes one row of `record`'s values.
    fn row<T: Serialize>(&mut self, record: &T) -> Result<(), csv::Error> {
        record.serialize(&mut Row {
            out: &mut self.out,
            buf: &mut self.buf,
            header: false,
        })
    }
}

impl<W: Write> Exporter<W> for CsvExporter<W> {
    fn begin(&mut self, meta: &RunMetadata) -> Result<(), OutputError> {
        // With --clock, the fields that are otherwise absent.
        let clock = meta.clock().then(String::new);
        match self.records {
            Records::Detections => self.header(&DetectionRecord {
                clock,
                ..Default::default()
            })?,
            Records::Events => self.header(&EventRecord {
                start_clock: clock.clone(),
                end_clock: clock,
                ..Default::default()
            })?,
            Records::Sources => self.header(&SourceRecord::default())?,
        }
        Ok(())
    }

    fn detection(&mut self, record: &DetectionRecord) -> Result<(), OutputError> {
        self.write(Records::Detections, record)
    }

    fn event(&mut self, record: &EventRecord) -> Result<(), OutputError> {
        self.write(Records::Events, record)
    }

    fn source(&mut self, record: &SourceRecord) -> Result<(), OutputError> {
        self.write(Records::Sources, record)
    }

    fn flush_each_record(&mut self) {
        self.flush_each = true;
    }

    fn finish(self: Box<Self>, _files: &[FileEntry]) -> Result<W, OutputError> {
        let mut out = self.out.into_inner().map_err(|e| e.into_error())?;
        out.flush()?;
        Ok(out)
    }
}

/// Serializes a struct of scalars as one CSV record: its field names (`header`) or its
/// values.
struct Row<'a, W: Write> {
    out: &'a mut csv::Writer<W>,
    buf: &'a mut String,
    header: bool,
}

/// Serializes one scalar as one CSV field.
struct Field<'a, W: Write> {
    out: &'a mut csv::Writer<W>,
    buf: &'a mut String,
}

fn unsupported<T>(what: &str) -> Result<T, csv::Error> {
    Err(ser::Error::custom(format!(
        "a CSV record holds scalars only, not {what}"
    )))
}

impl<W: Write> Field<'_, W> {
    fn display(self, v: impl std::fmt::Display) -> Result<(), csv::Error> {
        self.buf.clear();
        write!(self.buf, "{v}").expect("writing to a String");
        self.out.write_field(self.buf.as_bytes())
    }
}

impl<W: Write> SerializeStruct for &mut Row<'_, W> {
    type Ok = ();
    type Error = csv::Error;

    fn serialize_field<T: ?Sized + Serialize>(
        &mut self,
        key: &'static str,
        value: &T,
    ) -> Result<(), csv::Error> {
        if self.header {
            self.out.write_field(key)
        } else {
            value.serialize(Field {
                out: self.out,
                buf: self.buf,
            })
        }
    }

    fn end(self) -> Result<(), csv::Error> {
        self.out.write_record(None::<&[u8]>)
    }
}

/// The serializer methods a struct of scalars never reaches.
macro_rules! refuse {
    ($($name:ident($($arg:ty),*) -> $ret:ty;)*) => {
        $(fn $name(self, $(_: $arg),*) -> Result<$ret, csv::Error> {
            unsupported(stringify!($name))
        })*
    };
}

impl<'b, 'a, W: Write> Serializer for &'b mut Row<'a, W> {
    type Ok = ();
    type Error = csv::Error;
    type SerializeSeq = Impossible<(), csv::Error>;
    type SerializeTuple = Impossible<(), csv::Error>;
    type SerializeTupleStruct = Impossible<(), csv::Error>;
    type SerializeTupleVariant = Impossible<(), csv::Error>;
    type SerializeMap = Impossible<(), csv::Error>;
    type SerializeStruct = Self;
    type SerializeStructVariant = Impossible<(), csv::Error>;

    fn serialize_struct(self, _: &'static str, _: usize) -> Result<Self, csv::Error> {
        Ok(self)
    }

    refuse! {
        serialize_bool(bool) -> ();
        serialize_i8(i8) -> ();
        serialize_i16(i16) -> ();
        serialize_i32(i32) -> ();
        serialize_i64(i64) -> ();
        serialize_u8(u8) -> ();
        serialize_u16(u16) -> ();
        serialize_u32(u32) -> ();
        serialize_u64(u64) -> ();
        serialize_f32(f32) -> ();
        serialize_f64(f64) -> ();
        serialize_char(char) -> ();
        serialize_str(&str) -> ();
        serialize_bytes(&[u8]) -> ();
        serialize_none() -> ();
        serialize_unit() -> ();
        serialize_unit_struct(&'static str) -> ();
        serialize_unit_variant(&'static str, u32, &'static str) -> ();
        serialize_seq(Option<usize>) -> Self::SerializeSeq;
        serialize_tuple(usize) -> Self::SerializeTuple;
        serialize_tuple_struct(&'static str, usize) -> Self::SerializeTupleStruct;
        serialize_tuple_variant(&'static str, u32, &'static str, usize) -> Self::SerializeTupleVariant;
        serialize_map(Option<usize>) -> Self::SerializeMap;
        serialize_struct_variant(&'static str, u32, &'static str, usize) -> Self::SerializeStructVariant;
    }

    fn serialize_some<T: ?Sized + Serialize>(self, _: &T) -> Result<(), csv::Error> {
        unsupported("an option")
    }

    fn serialize_newtype_struct<T: ?Sized + Serialize>(
        self,
        _: &'static str,
        _: &T,
    ) -> Result<(), csv::Error> {
        unsupported("a newtype")
    }

    fn serialize_newtype_variant<T: ?Sized + Serialize>(
        self,
        _: &'static str,
        _: u32,
        _: &'static str,
        _: &T,
    ) -> Result<(), csv::Error> {
        unsupported("an enum")
    }
}

impl<W: Write> Serializer for Field<'_, W> {
    type Ok = ();
    type Error = csv::Error;
    type SerializeSeq = Impossible<(), csv::Error>;
    type SerializeTuple = Impossible<(), csv::Error>;
    type SerializeTupleStruct = Impossible<(), csv::Error>;
    type SerializeTupleVariant = Impossible<(), csv::Error>;
    type SerializeMap = Impossible<(), csv::Error>;
    type SerializeStruct = Impossible<(), csv::Error>;
    type SerializeStructVariant = Impossible<(), csv::Error>;

    fn serialize_bool(self, v: bool) -> Result<(), csv::Error> {
        self.display(v)
    }
    fn serialize_i8(self, v: i8) -> Result<(), csv::Error> {
        self.display(v)
    }
    fn serialize_i16(self, v: i16) -> Result<(), csv::Error> {
        self.display(v)
    }
    fn serialize_i32(self, v: i32) -> Result<(), csv::Error> {
        self.display(v)
    }
    fn serialize_i64(self, v: i64) -> Result<(), csv::Error> {
        self.display(v)
    }
    fn serialize_u8(self, v: u8) -> Result<(), csv::Error> {
        self.display(v)
    }
    fn serialize_u16(self, v: u16) -> Result<(), csv::Error> {
        self.display(v)
    }
    fn serialize_u32(self, v: u32) -> Result<(), csv::Error> {
        self.display(v)
    }
    fn serialize_u64(self, v: u64) -> Result<(), csv::Error> {
        self.display(v)
    }
    fn serialize_f32(self, v: f32) -> Result<(), csv::Error> {
        self.display(v)
    }
    fn serialize_f64(self, v: f64) -> Result<(), csv::Error> {
        self.display(v)
    }
    fn serialize_char(self, v: char) -> Result<(), csv::Error> {
        self.display(v)
    }
    fn serialize_str(self, v: &str) -> Result<(), csv::Error> {
        self.out.write_field(v)
    }
    fn serialize_none(self) -> Result<(), csv::Error> {
        self.out.write_field("")
    }
    fn serialize_some<T: ?Sized + Serialize>(self, v: &T) -> Result<(), csv::Error> {
        v.serialize(self)
    }
    fn serialize_unit_variant(
        self,
        _: &'static str,
        _: u32,
        variant: &'static str,
    ) -> Result<(), csv::Error> {
        self.out.write_field(variant)
    }

    refuse! {
        serialize_bytes(&[u8]) -> ();
        serialize_unit() -> ();
        serialize_unit_struct(&'static str) -> ();
        serialize_seq(Option<usize>) -> Self::SerializeSeq;
        serialize_tuple(usize) -> Self::SerializeTuple;
        serialize_tuple_struct(&'static str, usize) -> Self::SerializeTupleStruct;
        serialize_tuple_variant(&'static str, u32, &'static str, usize) -> Self::SerializeTupleVariant;
        serialize_map(Option<usize>) -> Self::SerializeMap;
        serialize_struct(&'static str, usize) -> Self::SerializeStruct;
        serialize_struct_variant(&'static str, u32, &'static str, usize) -> Self::SerializeStructVariant;
    }

    fn serialize_newtype_struct<T: ?Sized + Serialize>(
        self,
        _: &'static str,
        v: &T,
    ) -> Result<(), csv::Error> {
        v.serialize(self)
    }

    fn serialize_newtype_variant<T: ?Sized + Serialize>(
        self,
        _: &'static str,
        _: u32,
        _: &'static str,
        _: &T,
    ) -> Result<(), csv::Error> {
        unsupported("an enum with data")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The header is the record's field names; values are written the way Rust prints
    /// them (no exponents, integers without a decimal point), `None` as an empty field.
    #[test]
    fn rows_follow_the_record_type() {
        let mut csv = CsvExporter::new(Vec::new(), Records::Detections);
        csv.header(&DetectionRecord::default()).unwrap();
        let record = DetectionRecord {
            time_s: 0.106667,
            azimuth_deg: -0.0000001,
            elevation_deg: 10.0,
            x: 1.0,
            y: 0.0,
            z: 1e-6,
            score: 58.6523,
            file: "a, b.wav".into(),
            frame: Some(9),
            mics: None,
            source: Some(3),
            uncertainty_deg: Some(4.5),
            clock: None,
        };
        csv.row(&record).unwrap();
        let text = String::from_utf8(csv.out.into_inner().unwrap()).unwrap();
        assert_eq!(
            text,
            "time_s,azimuth_deg,elevation_deg,x,y,z,score,file,frame,mics,source,uncertainty_deg\n\
             0.106667,-0.0000001,10,1,0,0.000001,58.6523,\"a, b.wav\",9,,3,4.5\n"
        );
    }
}
