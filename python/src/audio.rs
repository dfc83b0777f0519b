//! Samples from Python: a numpy array (samples x channels, read where it lies, converted
//! a chunk at a time) or an iterator of such blocks (live audio). Both are
//! [`SampleSource`]s, so the localizer frames them exactly as it frames a WAV file.

use numpy::ndarray::{s, ArrayView2};
use numpy::{PyReadonlyArray2, PyUntypedArray, PyUntypedArrayMethods};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use ssl::stream::{InputError, SampleSource};
use std::sync::{Arc, Mutex};

/// The dtypes taken, as a WAV file holds them: 16- and 32-bit integers scaled as the
/// WAV reader scales them (by 2^15 and 2^31), floats as they are.
pub const DTYPES: &str = "int16, int32, float32 or float64";

/// A sample as the method reads it: the WAV reader's scaling, bit for bit.
pub trait Sample: numpy::Element + Copy + Sync {
    /// Whether a value can be non-finite.
    const FLOAT: bool;
    fn to_f32(self) -> f32;
}

impl Sample for i16 {
    const FLOAT: bool = false;
    fn to_f32(self) -> f32 {
        self as f32 / 32768.0
    }
}

impl Sample for i32 {
    const FLOAT: bool = false;
    fn to_f32(self) -> f32 {
        self as f32 / 2_147_483_648.0
    }
}

impl Sample for f32 {
    const FLOAT: bool = true;
    fn to_f32(self) -> f32 {
        self
    }
}

impl Sample for f64 {
    const FLOAT: bool = true;
    fn to_f32(self) -> f32 {
        self as f32
    }
}

/// A numpy array's samples, read in place (C or Fortran order, or any strides).
pub struct ArraySource<'a, T: Sample> {
    name: String,
    samples: ArrayView2<'a, T>,
    sample_rate: u32,
    position: usize,
}

impl<'a, T: Sample> ArraySource<'a, T> {
    pub fn new(name: &str, samples: ArrayView2<'a, T>, sample_rate: u32) -> Self {
        ArraySource {
            name: name.to_string(),
            samples,
            sample_rate,
            position: 0,
        }
    }
}

impl<T: Sample> SampleSource for ArraySource<'_, T> {
    fn name(&self) -> &str {
        &self.name
    }

    fn channels(&self) -> usize {
        self.samples.ncols()
    }

    fn sample_rate(&self) -> u32 {
        self.sample_rate
    }

    fn frames(&self) -> Option<u64> {
        Some(self.samples.nrows() as u64)
    }

    fn read(&mut self, out: &mut [f32]) -> Result<usize, InputError> {
        let ch = self.channels();
        let frames = (out.len() / ch).min(self.samples.nrows() - self.position);
        let part = self
            .samples
            .slice(s![self.position..self.position + frames, ..]);
        let out = &mut out[..frames * ch];
        match part.as_slice() {
            // C order: one run of samples, already interleaved.
            Some(run) => {
                for (o, &v) in out.iter_mut().zip(run) {
                    *o = v.to_f32();
                }
            }
            None => {
                for (to, row) in out.chunks_exact_mut(ch).zip(part.rows()) {
                    for (o, &v) in to.iter_mut().zip(row.iter()) {
                        *o = v.to_f32();
                    }
                }
            }
        }
        // A branch-free pass (it vectorizes) first; the sample's place only on a failure.
        let exponent = |v: &f32| v.to_bits() & 0x7f80_0000 == 0x7f80_0000;
        if T::FLOAT && out.iter().fold(false, |any, v| any | exponent(v)) {
            if let Some(i) = out.iter().position(exponent) {
                let frame = (self.position + i / ch) as u64;
                return Err(non_finite(frame, i % ch, out[i], self.sample_rate));
            }
        }
        self.position += frames;
        Ok(frames)
    }

    fn describe(&self) -> String {
        format!(
            "{} ch, {} Hz, numpy {}",
            self.channels(),
            self.sample_rate,
            std::any::type_name::<T>()
        )
    }
}

fn non_finite(frame: u64, channel: usize, value: f32, sample_rate: u32) -> InputError {
    InputError::NonFinite {
        frame,
        channel,
        nan: value.is_nan(),
        sample_rate,
    }
}

/// A numpy array of one of [`DTYPES`], borrowed for reading.
pub enum Borrowed<'py> {
    I16(PyReadonlyArray2<'py, i16>),
    I32(PyReadonlyArray2<'py, i32>),
    F32(PyReadonlyArray2<'py, f32>),
    F64(PyReadonlyArray2<'py, f64>),
}

impl<'py> Borrowed<'py> {
    /// `array` (samples x channels), or a `TypeError` / `ValueError` saying what it is.
    pub fn new(array: &Bound<'py, PyAny>) -> PyResult<Self> {
        let untyped = array.cast::<PyUntypedArray>().map_err(|_| {
            PyTypeError::new_err("audio must be a numpy array (samples x channels)")
        })?;
        if untyped.ndim() != 2 {
            return Err(PyValueError::new_err(format!(
                "audio must be 2-D (samples x channels); this array has shape {:?}",
                untyped.shape()
            )));
        }
        if let Ok(a) = array.extract() {
            return Ok(Borrowed::F32(a));
        }
        if let Ok(a) = array.extract() {
            return Ok(Borrowed::I16(a));
        }
        if let Ok(a) = array.extract() {
            return Ok(Borrowed::I32(a));
        }
        if let Ok(a) = array.extract() {
            return Ok(Borrowed::F64(a));
        }
        Err(PyTypeError::new_err(format!(
            "audio of dtype {} is not read: give {DTYPES} (convert with .astype)",
            untyped.dtype()
        )))
    }
}

/// Blocks of samples from a Python iterator, each a numpy array (samples x channels) of
/// one of [`DTYPES`] with the first block's channels. Whatever the blocks' sizes, the
/// framer sees the same samples in the same order.
pub struct BlockSource {
    name: String,
    iterator: Py<PyAny>,
    channels: usize,
    sample_rate: u32,
    /// Interleaved samples taken from blocks and not yet read.
    pending: Vec<f32>,
    /// How many of `pending` were read.
    taken: usize,
    /// Sample frames handed on so far (for the position of a non-finite sample).
    position: u64,
    done: bool,
    /// An exception the iterator raised: the run stops, and it is raised again.
    pub raised: Arc<Mutex<Option<PyErr>>>,
}

impl BlockSource {
    /// Reads the first block (for the channel count) from `iterator`.
    pub fn new(name: &str, iterator: Bound<'_, PyAny>, sample_rate: u32) -> PyResult<Self> {
        let mut source = BlockSource {
            name: name.to_string(),
            iterator: iterator.unbind(),
            channels: 0,
            sample_rate,
            pending: Vec::new(),
            taken: 0,
            position: 0,
            done: false,
            raised: Arc::default(),
        };
        Python::attach(|py| source.next_block(py))?;
        if source.done {
            return Err(PyValueError::new_err(format!(
                "{name}: the iterator gave no block of samples"
            )));
        }
        Ok(source)
    }

    /// Appends the next block to `pending`; `done` at the end.
    fn next_block(&mut self, py: Python<'_>) -> PyResult<()> {
        let iterator = self.iterator.bind(py);
        let block = match iterator.call_method0("__next__") {
            Ok(b) => b,
            Err(e) if e.is_instance_of::<pyo3::exceptions::PyStopIteration>(py) => {
                self.done = true;
                return Ok(());
            }
            Err(e) => return Err(e),
        };
        let borrowed = Borrowed::new(&block)?;
        // The samples read are dropped before the buffer grows.
        self.pending.drain(..self.taken);
        self.taken = 0;
        // pending[0] is now sample frame `position`; the block starts at `base`.
        let base = self.pending.len();
        match &borrowed {
            Borrowed::I16(a) => self.append(a.as_array()),
            Borrowed::I32(a) => self.append(a.as_array()),
            Borrowed::F32(a) => self.append(a.as_array()),
            Borrowed::F64(a) => self.append(a.as_array()),
        }
        .map_err(|e| PyValueError::new_err(format!("{}: {e}", self.name)))?;
        if let Some(i) = (base..self.pending.len()).find(|&i| !self.pending[i].is_finite()) {
            let ch = self.channels;
            let frame = self.position + (i / ch) as u64;
            let e = non_finite(frame, i % ch, self.pending[i], self.sample_rate);
            return Err(PyValueError::new_err(format!("{}: {e}", self.name)));
        }
        Ok(())
    }

    fn append<T: Sample>(&mut self, block: ArrayView2<'_, T>) -> Result<(), String> {
        if self.channels == 0 {
            self.channels = block.ncols();
        }
        if block.ncols() != self.channels {
            return Err(format!(
                "a block has {} channel(s) where the first had {}",
                block.ncols(),
                self.channels
            ));
        }
        self.pending.reserve(block.len());
        for row in block.rows() {
            self.pending.extend(row.iter().map(|v| v.to_f32()));
        }
        Ok(())
    }
}

impl SampleSource for BlockSource {
    fn name(&self) -> &str {
        &self.name
    }

    fn channels(&self) -> usize {
        self.channels
    }

    fn sample_rate(&self) -> u32 {
        self.sample_rate
    }

    fn frames(&self) -> Option<u64> {
        None
    }

    fn read(&mut self, out: &mut [f32]) -> Result<usize, InputError> {
        let ch = self.channels;
        // What has arrived is handed on; the next block is asked for only when none has.
        while self.pending.len() - self.taken < ch && !self.done {
            if let Err(e) = Python::attach(|py| self.next_block(py)) {
                let message = e.to_string();
                *self.raised.lock().expect("not poisoned") = Some(e);
                return Err(InputError::Read(std::io::Error::other(message)));
            }
        }
        let available = (self.pending.len() - self.taken) / ch;
        let frames = (out.len() / ch).min(available);
        let n = frames * ch;
        out[..n].copy_from_slice(&self.pending[self.taken..self.taken + n]);
        self.taken += n;
        self.position += frames as u64;
        Ok(frames)
    }

    fn is_live(&self) -> bool {
        true
    }

    fn describe(&self) -> String {
        format!(
            "{} ch, {} Hz, numpy blocks",
            self.channels, self.sample_rate
        )
    }
}

/// `$body` with `$source` an [`ArraySource`] of the view, whatever its dtype.
macro_rules! with_array_source {
    ($view:expr, $name:expr, $rate:expr, |$source:ident| $body:expr) => {
        match $view {
            View::I16(v) => {
                let $source = ArraySource::new($name, v, $rate);
                $body
            }
            View::I32(v) => {
                let $source = ArraySource::new($name, v, $rate);
                $body
            }
            View::F32(v) => {
                let $source = ArraySource::new($name, v, $rate);
                $body
            }
            View::F64(v) => {
                let $source = ArraySource::new($name, v, $rate);
                $body
            }
        }
    };
}

/// The views of a borrowed array, which may cross into a thread without the GIL.
pub enum View<'a> {
    I16(numpy::ndarray::ArrayView2<'a, i16>),
    I32(numpy::ndarray::ArrayView2<'a, i32>),
    F32(numpy::ndarray::ArrayView2<'a, f32>),
    F64(numpy::ndarray::ArrayView2<'a, f64>),
}

impl Borrowed<'_> {
    /// The array's view, which may cross into a thread without the GIL.
    pub fn view(&self) -> View<'_> {
        match self {
            Borrowed::I16(a) => View::I16(a.as_array()),
            Borrowed::I32(a) => View::I32(a.as_array()),
            Borrowed::F32(a) => View::F32(a.as_array()),
            Borrowed::F64(a) => View::F64(a.as_array()),
        }
    }
}

pub(crate) use with_array_source;
